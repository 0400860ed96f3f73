"""Kinematic tasks: Jacobians (symbolic and at a configuration), singularity analysis, positions.

Values follow the conventions of ``context`` (TaskView): numbers, lists, expressions, given
entries and earlier answers; a configuration ``q`` or, by default, the coordinates found in ``given``
completed by the exercise's ``configuration``.

Task kinds
----------
``jacobian``: ``name`` (default J) and one of
  - ``point`` (a named point or ``{body, at}``) with ``components`` (x, y, z, angle, wx, wy, wz;
    default [x, y]) and optional ``frame`` (a body: rows expressed in that link's frame),
  - ``body`` with ``components`` [angle] (planar orientation of a link),
  - ``expression``: a list of expressions of the coordinates r(q) (analytic Jacobian dr/dq),
  - ``matrix``: a numeric matrix given by the exercise,
  - ``stack``: names of earlier Jacobians to stack (extended / augmented Jacobian).
  Options: ``q``, ``parameters`` (values for this task only, e.g. lengths in other units),
  ``derivative: true`` (J'(q, dq) dq, answer ``<name>_dot_dq``), ``singularities: true`` (symbolic det J or det(J J^T) and the numeric
  rank, null space and left null space), ``minors: true`` (det J_{-i}), ``pinv: true``,
  ``position: true`` (the task value r(q)).
  Answers: ``<name>`` (symbolic), ``<name>_num``, ``<name>_rank``, ``<name>_null``,
  ``<name>_left_null``, ``<name>_det``, ``<name>_minors`` (list, in order of the deleted columns),
  ``<name>_pinv``, ``<name>_position``, ``<name>_manipulability``.
``forward_kinematics``: ``points`` (mapping label -> point) at ``q``: answers ``p_<label>``
  (numeric) and ``p_<label>_expr`` (symbolic).

Highlight keys emitted in steps (for the 3D walkthrough): ``configuration`` (coordinate values),
``points`` ([{label, position}]), ``vectors`` ([{label, origin, vector, role}], role in desired,
achieved, error, force, gradient), ``joint_values`` ([{label, values, lower?, upper?, saturated?,
violating?}]: one value per joint, e.g. velocities with their bounds), ``scale`` (task scaling),
``profile`` (timing law), ``path`` ([[x, y, z], ...]).
"""
from __future__ import annotations

from typing import List

import numpy as np
import sympy as sp

from .. import jacobians as jac
from ..errors import UserError
from ..expressions import parse_expression
from ..latex import mat, num, vec
from ..steps import symbol_latex, to_latex
from . import task
from .context import TaskView


def _components(spec) -> List[str]:
    comps = spec.get("components", ["x", "y"])
    if isinstance(comps, str):
        comps = [comps]
    return list(comps)


@task("jacobian")
def jacobian_task(ctx, spec):
    """A task Jacobian, symbolic and at a configuration, with optional singularity analysis."""
    d = TaskView(ctx)
    robot = d.robot
    name = spec.get("name", "J")
    L = lambda e: to_latex(e, robot.coordinates)
    J_sym, r_sym, J_num, what = None, None, None, ""
    if "matrix" in spec:
        J_num = np.atleast_2d(d.array(spec["matrix"], f"{name}.matrix"))
        what = "given by the exercise"
    elif "stack" in spec:
        parts = [d.objects[p] if p in d.objects else None for p in spec["stack"]]
        missing = [p for p, obj in zip(spec["stack"], parts) if obj is None]
        if missing:
            raise d._fail(f"{name}.stack: unknown Jacobian(s) {missing} (define them in earlier jacobian tasks)")
        J_num = np.vstack([p["num"] for p in parts])
        if all(p["sym"] is not None for p in parts):
            J_sym = sp.Matrix.vstack(*[p["sym"] for p in parts])
        what = "stacked " + ", ".join(f"${_tex(p)}$" for p in spec["stack"])
    elif "expression" in spec:
        exprs = spec["expression"] if isinstance(spec["expression"], list) else [spec["expression"]]
        r_sym = sp.Matrix([d.expression(e, f"{name}.expression") for e in exprs])
        J_sym = r_sym.jacobian(sp.Matrix(robot.q)).applyfunc(sp.expand)
        what = "analytic Jacobian of the task function"
    else:
        comps = _components(spec)
        try:
            J_sym = jac.jacobian(robot, spec.get("point"), comps, spec.get("body"), spec.get("frame"))
            r_sym = jac.task_function(robot, spec.get("point"), comps, spec.get("body")) if "frame" not in spec else None
        except UserError as exc:
            raise d._fail(f"{name}: {exc}") from None
        what = (f"rows {', '.join(f'${_tex(c)}$' for c in comps)} of {_point_text(spec.get('point') or spec.get('body'), robot)}"
                + (f" in the frame of {spec['frame']}" if spec.get("frame") else ""))
    q = None
    params = d.params
    for k, v in (spec.get("parameters") or {}).items():
        if k not in params:
            raise d._fail(f"{name}.parameters: {robot.name} has no parameter '{k}'")
        params[k] = d.number(v, f"{name}.parameters.{k}")
    if J_num is None:
        q = d.configuration(spec.get("q"))
        J_num = np.atleast_2d(jac.evaluate(robot, d.substitute(J_sym), q, params))
    d.objects[name] = {"sym": J_sym, "num": J_num, "r": r_sym, "q": q}
    if J_sym is not None:
        ctx.step(f"Jacobian ${_tex(name)}$", f"{_tex(name)}(q) = " + L(J_sym), f"{what[:1].upper() + what[1:]}.")
        ctx.answer(name, J_sym)
    conf = {c: float(v) for c, v in zip(robot.coordinates, q)} if q is not None else {}
    ctx.step(f"${_tex(name)}$ at the configuration", f"{_tex(name)} = " + mat(J_num),
             ("At $" + ", ".join(f"{to_latex(robot.q[k], robot.coordinates)} = {num(v)}" for k, v in enumerate(conf.values()))
              + "$.") if conf else "Numeric matrix.",
             configuration=conf)
    ctx.answer(f"{name}_num", J_num)
    if spec.get("position") and r_sym is not None and q is not None:
        r_num = np.asarray(jac.evaluate(robot, d.substitute(r_sym), q, params), float).reshape(-1)
        ctx.step(f"Task value", f"r(q) = " + L(r_sym) + " = " + vec(r_num), "")
        ctx.answer(f"{name}_position", r_num)
    if spec.get("derivative") and J_sym is not None:
        Jdot = sum((J_sym.diff(qk) * dqk for qk, dqk in zip(robot.q, robot.dq)), sp.zeros(*J_sym.shape))
        Jdot_dq = (Jdot * sp.Matrix(robot.dq)).applyfunc(sp.expand)
        ctx.step("Velocity-dependent term", rf"\dot {_tex(name)}(q, \dot q)\,\dot q = " + L(Jdot_dq),
                 r"Second-order kinematics: $\ddot p = J \ddot q + \dot J \dot q$.")
        ctx.answer(f"{name}_dot_dq", Jdot_dq)
    a = jac.analyze(J_num, float(spec.get("threshold", jac.DEFAULT_THRESHOLD)))
    ctx.answer(f"{name}_rank", a.rank)
    if spec.get("singularities"):
        if J_sym is not None:
            D = jac.determinant_condition(J_sym)
            T = _tex(name)
            label = rf"\det {T}" if J_sym.rows == J_sym.cols else rf"\det({T} {T}^T)"
            ctx.step("Singularity condition", label + " = " + L(D), "The configurations where it vanishes are singular.")
            ctx.answer(f"{name}_det", D)
        text = (f"Rank {a.rank} of {J_num.shape[0]}: singular values {', '.join(num(s) for s in a.singular_values)}. ")
        if a.null_space.shape[1]:
            text += "Null-space columns are joint motions that leave the task still (self motions). "
        if a.left_null_space.shape[1]:
            text += "Left null-space columns are task directions no joint velocity can produce; forces along them are balanced by the structure with zero joint torques ($J^T F = 0$)."
        ctx.step("Rank and null spaces",
                 rf"\mathrm{{rank}}\,{_tex(name)} = {a.rank},\quad \mathcal{{N}}({_tex(name)}) = \mathrm{{span}}\," + mat(a.null_space if a.null_space.size else np.zeros((J_num.shape[1], 1)))
                 + (rf",\quad \mathcal{{N}}({_tex(name)}^T) = \mathrm{{span}}\," + mat(a.left_null_space) if a.left_null_space.shape[1] else ""),
                 text.strip())
        ctx.answer(f"{name}_null", a.null_space)
        ctx.answer(f"{name}_left_null", a.left_null_space)
        ctx.answer(f"{name}_manipulability", a.manipulability)
    if spec.get("minors"):
        minors = jac.column_minors(J_num)
        ctx.step("Square minors", r",\ ".join(rf"\det {_tex(name)}_{{-{','.join(map(str, k))}}} = {num(v)}" for k, v in minors.items()),
                 "Determinants of the square submatrices obtained by deleting columns.")
        ctx.answer(f"{name}_minors", list(minors.values()))
    if spec.get("pinv"):
        from ..redundancy import pinv
        P = pinv(J_num, float(spec.get("threshold", jac.DEFAULT_THRESHOLD)))
        ctx.step("Pseudoinverse", f"{_tex(name)}^\\# = " + mat(P), "From the SVD with an absolute threshold.")
        ctx.answer(f"{name}_pinv", P)


def _tex(name: str) -> str:
    """LaTeX of a Jacobian's or component's name (``J_cm`` -> ``J_{cm}``, ``j1`` -> ``j_{1}``)."""
    return symbol_latex(str(name))


def _point_text(point, robot) -> str:
    """A point of a task for a sentence: its name, or "the point at (x, y, z) of link2"."""
    if isinstance(point, dict):
        at = point.get("at")
        where = f" at ${to_latex(sp.Matrix([parse_expression(str(v)) for v in at]).T, robot.coordinates)}$" if at else ""
        return f"the point{where} of {point.get('body', 'the last link')}"
    return str(point).replace("_", " ")


@task("forward_kinematics")
def forward_kinematics_task(ctx, spec):
    """Positions of points at a configuration: ``points: {label: point}``."""
    d = TaskView(ctx)
    q = d.configuration(spec.get("q"))
    pts = spec.get("points") or {"ee": "ee"}
    shown = []
    for label, point in pts.items():
        try:
            body, local = jac.point_location(d.robot, point)
        except UserError as exc:
            raise d._fail(f"forward_kinematics.{label}: {exc}") from None
        p_sym = jac._kinematics(d.robot).point_position(body, local)
        p = np.asarray(jac.evaluate(d.robot, p_sym, q, d.params), float).reshape(-1)
        if d.robot.is_planar:
            p_sym, p = p_sym[:2, :], p[:2]
        ctx.answer(f"p_{label}_expr", p_sym)
        ctx.answer(f"p_{label}", p)
        shown.append({"label": label, "position": (list(p) + [0.0])[:3]})
        ctx.step(f"Position of {label}", f"p_{{{label}}} = " + to_latex(p_sym, d.robot.coordinates) + " = " + vec(p), "",
                 points=[shown[-1]], configuration={c: float(v) for c, v in zip(d.robot.coordinates, q)})
