"""Numeric recursive Newton-Euler on any robot file (``app.core.newton_euler``): the inverse
dynamics u = NE(q, q', q'') with or without gravity and with a wrench at a point, checked against
J^T F_e and against the pinocchio twin. No symbolic model is derived.

``newton_euler`` options: ``q`` (default: the configuration of the exercise), ``velocity``,
``acceleration`` (default zeros), ``gravity`` (default true; false is the NE_0 of the exams),
``wrench: {point, force, moment}`` (what the robot exerts on its environment at a named point or
``{body, at}``; world axes; moment default zero), ``name`` (default ``u``), ``check`` (default
true: compare with pinocchio's M q'' + c + g + J^T F_e).
Answers: ``<name>`` (generalized forces), ``<name>_J`` (6 x n geometric Jacobian at the wrench
point), ``<name>_JT_F`` (J^T F_e), ``<name>_matches_JT_F`` (true when u = J^T F_e: no gravity and
the robot at rest), ``<name>_check`` (largest |u - pinocchio|), ``<name>_link_forces`` (force
exerted on each body by its parent, one row per body), ``<name>_link_moments`` (moment about the
joint point).

Example (the exams' NE_0(q, 0, 0) with a tip wrench):

    - {kind: newton_euler, name: u_tip, gravity: false,
       wrench: {point: ee, force: [10, -5, 20], moment: [1, 2, -0.5]}}
"""
from __future__ import annotations

import numpy as np

from .. import jacobians as jac
from ..errors import UserError
from ..latex import mat, num, vec
from ..newton_euler import NewtonEuler, Wrench
from . import task
from .context import TaskView


def _vector(d, spec, key, n, default=None):
    if key not in spec:
        return np.zeros(n) if default is None else default
    v = d.array(spec[key], key).reshape(-1)
    if v.size != n:
        raise d._fail(f"newton_euler.{key}: expected {n} values, got {v.size}")
    return v


@task("newton_euler")
def newton_euler_task(ctx, spec):
    """u = NE(q, q', q'') (see the module docstring)."""
    d = TaskView(ctx)
    robot = ctx.robot
    name = str(spec.get("name", "u"))
    q = d.configuration(spec.get("q"))
    dq = _vector(d, spec, "velocity", robot.n)
    ddq = _vector(d, spec, "acceleration", robot.n)
    gravity = bool(spec.get("gravity", True))
    try:
        ne = NewtonEuler(robot, d.params)
    except (KeyError, TypeError) as exc:
        raise d._fail(f"newton_euler: {exc}") from None
    wrenches, J, F = [], None, None
    if spec.get("wrench"):
        w = spec["wrench"]
        if not isinstance(w, dict) or "point" not in w or "force" not in w:
            raise d._fail("newton_euler.wrench: expected {point, force, moment}")
        try:
            body, local = jac.point_location(robot, w["point"])
        except UserError as exc:
            raise d._fail(f"newton_euler.wrench.point: {exc}") from None
        local = np.array([float(e) for e in jac.evaluate(robot, local, q, d.params).reshape(-1)])
        force = _vector(d, w, "force", 3)
        moment = _vector(d, w, "moment", 3)
        wrenches.append(Wrench(body, local, force, moment))
        J = ne.geometric_jacobian(q, body, local)
        F = np.concatenate([force, moment])
    u = ne.inverse_dynamics(q, dq, ddq, gravity, wrenches)
    states, _ = ne.forward(q, dq, ddq, gravity)
    ne.backward(states, wrenches)
    forces = np.array([st.force for st in states])
    moments = np.array([st.moment for st in states])
    ctx.answer(name, u)
    ctx.answer(f"{name}_link_forces", forces)
    ctx.answer(f"{name}_link_moments", moments)
    at_rest = not gravity and not np.any(dq) and not np.any(ddq)
    what = ("no gravity" if not gravity else "with gravity") + (", at rest" if not np.any(dq) and not np.any(ddq) else "")
    ctx.step("Forward recursion", rf"q = {vec(q)},\ \dot q = {vec(dq)},\ \ddot q = {vec(ddq)}",
             f"Angular velocities and accelerations, and linear accelerations, from the base to the tip ({what}).",
             configuration=dict(zip(robot.coordinates, map(float, q))))
    rows = [rf"f_{{{k + 1}}} = {vec(f, 3)},\ m_{{{k + 1}}} = {vec(m, 3)}" for k, (f, m) in enumerate(zip(forces, moments))]
    ctx.step("Backward recursion", r",\quad ".join(rows),
             "Force and moment (about the joint point) that each link receives from the previous one; "
             + ("the recursion starts from the wrench the tip exerts on the environment." if wrenches else
                "the recursion starts from zero force and moment at the free tip."),
             bodies=[b.name for b in robot.bodies])
    parts = [rf"u = {vec(u)}"]
    if J is not None:
        JT_F = J.T @ F
        ctx.answer(f"{name}_J", J)
        ctx.answer(f"{name}_JT_F", JT_F)
        scale = max(1.0, float(np.max(np.abs(JT_F))))
        if at_rest:
            ctx.answer(f"{name}_matches_JT_F", bool(np.max(np.abs(u - JT_F)) < 1e-9 * scale))
        parts.append(rf"J^T(q) F_e = {mat(J.T, 3)} {vec(F)} = {vec(JT_F)}")
    if spec.get("check", True):
        err = _pinocchio_difference(robot, d.params, q, dq, ddq, gravity, J, F, u)
        if err is not None:
            ctx.answer(f"{name}_check", err)
            parts.append(rf"\max |u - u_{{\mathrm{{pinocchio}}}}| = {num(err, 12) if err else '0'}")
    ctx.step("Generalized forces", r",\quad ".join(parts),
             "Projection of the link moments (revolute) or forces (prismatic) on the joint axes, mapped to the "
             r"coordinates; with no gravity and the robot at rest only the tip wrench remains: $u = J^T F_e$.",
             joints=[b.name for b in robot.bodies])


def _pinocchio_difference(robot, params, q, dq, ddq, gravity, J, F, u):
    """|u - (M q'' + c + g + J^T F)| with pinocchio (None when the twin cannot be built)."""
    try:
        from ..numeric import PinocchioTwin
        twin = PinocchioTwin(robot, params)
        M, c, g = twin.terms(q, dq)
    except Exception:   # a robot pinocchio cannot represent (e.g. motor coordinates): no check
        return None
    ref = M @ ddq + c + (g if gravity else 0)
    if J is not None:
        ref = ref + J.T @ F
    return float(np.max(np.abs(u - ref)))
