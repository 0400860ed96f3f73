"""Task-space acceleration and the inverse dynamics of a task with a contact force.

``task_acceleration``: for a point of the robot (and optional extra task rows r(q), e.g. a link
angle), the task acceleration p'' = J q'' + J' q' and, when a desired task acceleration is given,
the joint accelerations that realize it and the torque that produces them while the robot
applies a force F at the point: tau = M q'' + c + g + k + friction + J_p^T F.
Options: ``point`` (a named point, default ``ee``), ``components`` (default [x, y]), ``rows``
(extra task functions of q, appended), ``velocity`` (coordinate -> value of its velocity;
unnamed velocities stay symbols), ``acceleration`` (the desired task acceleration, one entry per
task row), ``force`` (the force the robot applies at the point, one entry per point component),
``substitute`` (parameter -> value). Answers: ``p``, ``J``, ``J_dot``, ``J_dot_dq``, ``pdd``
(J q'' + J' q'), and with ``acceleration``: ``ddq`` (J^-1 (p''_d - J' q'), square J) and ``tau``.

>>> from app.core.exercise import parse_exercise, solve
>>> ex = parse_exercise({"id": "x", "robot": "planar_2r", "question": "?", "tasks": [
...     {"kind": "task_acceleration", "point": "ee"}]})
>>> solve(ex).answers["J_dot_dq"][0]
-dq1**2*l1*cos(q1) - l2*(dq1**2 + 2*dq1*dq2 + dq2**2)*cos(q1 + q2)
"""
from __future__ import annotations

import sympy as sp

from ..exercise import ExerciseError
from ..kinematics import Kinematics
from . import task
from .context import TaskView
from .underactuated import _inverse, _time_derivative

_AXES = {"x": 0, "y": 1, "z": 2}


@task("task_acceleration")
def task_acceleration_task(ctx, spec):
    """Task acceleration and task inverse dynamics with a contact force (module docstring)."""
    m = TaskView(ctx)
    name = spec.get("point", "ee")
    pt = m.robot.points.get(name)
    comps = spec.get("components", ["x", "y"])
    if pt is None or not isinstance(comps, list) or any(c not in _AXES for c in comps):
        raise ExerciseError(f"task_acceleration: a named point of {m.robot.name} ({', '.join(m.robot.points)}) "
                            "and components among x, y, z")
    fixed = m.mapping_of_parameters(spec.get("substitute"), "task_acceleration.substitute")
    p3 = Kinematics(m.robot).point_position(pt.body, pt.position)
    p_pt = sp.Matrix([p3[_AXES[c]] for c in comps])
    rows = [m.ctx.expr(e, "task_acceleration.rows") for e in (spec.get("rows") or [])]
    r = m.tidy_matrix(sp.Matrix.vstack(p_pt, sp.Matrix(rows)) if rows else p_pt)
    J = m.tidy_matrix(r.jacobian(m.q))
    Jp = J[:len(comps), :]
    vel = {m.dq[m.coords.index(k.name)]: v for k, v in m.mapping(spec.get("velocity"), "task_acceleration.velocity").items()}
    J_dot = m.tidy_matrix(_time_derivative(J, m.q, m.dq))
    J_dot_dq = m.tidy_matrix(J_dot * m.dq)
    pdd = m.tidy_matrix(J * m.ddq + J_dot_dq)
    L = m.L
    bodies = [pt.body] if pt.body else []
    ctx.step("Task and its Jacobian", rf"r(q) = {L(r)},\quad J = {L(J)}", f"The position of {name}"
             + (" and the extra task rows." if rows else "."), bodies=bodies)
    ctx.step("Task acceleration", rf"\ddot r = J\ddot q + \dot J\dot q,\quad \dot J = {L(J_dot)},\quad \dot J\dot q = {L(J_dot_dq)}",
             r"Differentiating $\dot r = J \dot q$ once more.", bodies=bodies)
    ctx.answer("p", r)
    ctx.answer("J", J)
    ctx.answer("J_dot", J_dot)
    ctx.answer("J_dot_dq", J_dot_dq)
    ctx.answer("pdd", pdd)
    if spec.get("acceleration") is None:
        return
    acc = sp.Matrix([m.ctx.expr(e, "task_acceleration.acceleration") for e in spec["acceleration"]])
    if acc.rows != J.rows or J.rows != J.cols:
        raise ExerciseError(f"task_acceleration.acceleration: {J.rows} entries, and as many task rows as "
                            f"coordinates ({len(m.coords)}) to invert J (add rows)")
    ddq = m.tidy_matrix(_inverse(J) * (acc - J_dot_dq.subs(vel)))
    F = sp.Matrix([m.ctx.expr(e, "task_acceleration.force") for e in (spec.get("force") or [0] * len(comps))])
    if F.rows != len(comps):
        raise ExerciseError(f"task_acceleration.force: {len(comps)} entries (one per point component)")
    sub = {**dict(zip(m.ddq, ddq)), **vel}
    tau = m.tidy_matrix(((m.M * m.ddq + m.n).subs(sub, simultaneous=True) + Jp.T * F).subs(fixed))
    ctx.step("Joint accelerations for the task", rf"\ddot q = J^{{-1}}(\ddot r_d - \dot J\dot q) = {L(ddq)}",
             "The task rows fix every joint acceleration.", joints=[b.name for b in m.robot.bodies])
    ctx.step("Torque with the contact force", rf"\tau = M\ddot q + c + g + J_p^T F = {L(tau)}",
             "Inverse dynamics, plus the torque that makes the robot apply F at the point.",
             joints=[b.name for b in m.robot.bodies])
    ctx.answer("ddq", ddq)
    ctx.answer("tau", tau)
