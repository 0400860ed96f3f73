"""Kinematic calibration exercises (task kind ``calibration``) on top of app/core/calibration.py.

``calibration``: the regressor of a point with respect to kinematic parameters and encoder
offsets, and the least-squares estimate from measured positions.
Options: ``point`` (a named point, default ``ee``), ``components`` (default [x, y]),
``parameters`` (robot parameters to calibrate), ``offsets`` (coordinates whose encoder offsets are
calibrated), ``experiments`` (list of ``{q: [...], p: [...]}``: joint readings and the measured
position; values may name ``given`` entries), ``transform`` (``{body, parameter}``: the derivative
of the body's homogeneous transform from its parent with respect to the parameter).
Answers: ``Phi`` (symbolic regressor [dp/dparameters, dp/doffsets]), ``Phi_nominal`` (at the
nominal parameter values), ``linear`` (p affine in the
unknowns: one least-squares step is exact), ``Phi_stacked`` and ``dp_stacked`` (the experiments
stacked at the nominal values), ``rank``, ``delta`` (the correction), ``estimate`` (nominal +
correction, parameters then offsets), ``residual`` (norm of the position errors left),
``iterations``; with ``transform``: ``dA`` (symbolic) and ``dA_nominal`` (at the nominal values).

>>> from app.core.exercise import parse_exercise, solve
>>> ex = parse_exercise({"id": "x", "robot": "planar_2r", "question": "?", "tasks": [
...     {"kind": "calibration", "parameters": ["l1", "l2"],
...      "experiments": [{"q": [0, 0], "p": [2.0, 0]}, {"q": [0, "pi/2"], "p": [1.1, 0.9]}]}]})
>>> [f"{x:.3f}" for x in solve(ex).answers["estimate"]]
['1.100', '0.900']
"""
from __future__ import annotations

import numpy as np
import sympy as sp

from .. import calibration as cal
from ..expressions import symbol
from ..kinematics import Kinematics
from ..latex import mat, sig, vec
from ..steps import to_latex
from . import task
from .context import TaskView

_AXES = {"x": 0, "y": 1, "z": 2}


def _point(d, spec):
    name = spec.get("point", "ee")
    pt = d.robot.points.get(name)
    if pt is None:
        raise d._fail(f"calibration.point: the robot {d.robot.name} has no point '{name}' "
                      f"(points: {', '.join(d.robot.points) or 'none'})")
    comps = spec.get("components", ["x", "y"])
    if not isinstance(comps, list) or any(c not in _AXES for c in comps):
        raise d._fail("calibration.components: a list of x, y, z")
    p3 = Kinematics(d.robot).point_position(pt.body, pt.position)
    return name, sp.Matrix([sp.expand(p3[_AXES[c]]) for c in comps])


def _names(d, spec, key, allowed, what):
    names = spec.get(key) or []
    if not isinstance(names, list) or any(n not in allowed for n in names):
        raise d._fail(f"calibration.{key}: a list of {what} ({', '.join(allowed)})")
    return list(names)


@task("calibration")
def calibration_task(ctx, spec):
    """Calibration regressor and least-squares estimate (see the module docstring)."""
    d = TaskView(ctx)
    robot = d.robot
    coords = list(robot.coordinates)
    params = _names(d, spec, "parameters", list(robot.parameters), "robot parameters")
    offs = _names(d, spec, "offsets", coords, "coordinates")
    if not params and not offs and not spec.get("transform"):
        raise d._fail("calibration: give the parameters and/or offsets to calibrate (or a transform)")
    L = lambda e: to_latex(e, coords)
    nominal = {symbol(k): v for k, v in d.params.items()}
    if spec.get("transform"):
        _transform_derivative(ctx, d, spec["transform"], nominal)
    if not params and not offs:
        return
    label, p = _point(d, spec)
    q = [symbol(c) for c in coords]
    unknowns = [symbol(k) for k in params] + [symbol(f"delta_{c}") for c in offs]
    shifted = p.subs({symbol(c): symbol(c) + symbol(f"delta_{c}") for c in offs}, simultaneous=True)
    Phi = cal.regressor(shifted, unknowns[:len(params)], unknowns[len(params):]).subs(
        {symbol(f"delta_{c}"): 0 for c in offs}).applyfunc(sp.expand)
    linear = cal.is_linear(shifted, unknowns)
    ctx.step("Regressor of the calibration",
             rf"\Delta p_{{{label}}} \approx \Phi(q)\,\begin{{pmatrix}}\Delta\pi\\ \Delta\theta\end{{pmatrix}},\quad "
             rf"\Phi = {L(Phi)}",
             f"Derivatives of the position of {label.replace('_', ' ')} with respect to "
             + ", ".join([f"${to_latex(symbol(p), coords)}$" for p in params]
                         + [f"the offset of ${to_latex(symbol(c), coords)}$" for c in offs])
             + (": $p$ depends linearly on them, so the least-squares step is exact." if linear
                else ": first-order model, iterated about each new estimate."),
             bodies=[b.name for b in robot.bodies])
    Phi_nom = Phi.subs({symbol(k): _exact(nominal[symbol(k)]) for k in params}).applyfunc(sp.expand)
    ctx.answer("Phi", Phi)
    ctx.answer("Phi_nominal", Phi_nom)
    ctx.answer("linear", bool(linear))
    raw = spec.get("experiments")
    if not raw:
        return
    if not isinstance(raw, list) or any(not isinstance(e, dict) or set(e) != {"q", "p"} for e in raw):
        raise d._fail("calibration.experiments: a list of {q: [...], p: [...]}")
    exps = [(d.array(e["q"], "experiments.q").reshape(-1), d.array(e["p"], "experiments.p").reshape(-1)) for e in raw]
    for qv, pv in exps:
        if qv.size != len(coords) or pv.size != p.rows:
            raise d._fail(f"calibration.experiments: each q has {len(coords)} values and each p {p.rows}")
    offsets = unknowns[len(params):]
    nominal_all = {**nominal, **{s: 0.0 for s in offsets}}
    est = cal.least_squares_calibration(shifted, unknowns, q, nominal_all, exps)
    ctx.step("Stacked experiments", rf"\Delta\bar p = {vec(est.stacked_error)} = {mat(est.stacked_regressor)}"
             rf"\begin{{pmatrix}}\Delta\pi\\ \Delta\theta\end{{pmatrix}}",
             f"Measured minus nominal positions, {len(exps)} experiments; the stacked regressor has rank {est.rank}"
             + (" (rows of singular configurations carry no information)." if est.rank < len(unknowns) or
                np.any(np.all(np.abs(est.stacked_regressor) < 1e-12, axis=1)) else "."))
    names = params + [f"offset of {c}" for c in offs]
    ctx.step("Least-squares estimate", rf"\Delta = \bar\Phi^\# \Delta\bar p = {vec(est.delta)},\quad "
             + r",\ ".join(rf"{to_latex(symbol(n), coords) if n in params else n} = {v:.4f}" for n, v in zip(names, est.values)),
             f"{est.iterations} step(s); position error left ${sig(est.residual, 3)}$ m.")
    ctx.answer("Phi_stacked", est.stacked_regressor)
    ctx.answer("dp_stacked", est.stacked_error)
    ctx.answer("rank", est.rank)
    ctx.answer("delta", est.delta)
    ctx.answer("estimate", est.values)
    ctx.answer("residual", est.residual)
    ctx.answer("iterations", est.iterations)


def _exact(value: float) -> sp.Expr:
    """A nominal number as an exact multiple of pi or a rational when it is one (pi/2, 0.5)."""
    return sp.nsimplify(value, [sp.pi], tolerance=1e-12)


def _transform_derivative(ctx, d, spec, nominal):
    """d(A_i)/d(parameter) of a body's transform from its parent frame, and at the nominal values."""
    robot = d.robot
    body, param = (spec.get("body"), spec.get("parameter")) if isinstance(spec, dict) else (None, None)
    bodies = {b.name: b for b in robot.bodies}
    if body not in bodies or param not in robot.parameters:
        raise d._fail("calibration.transform: expected {body: NAME, parameter: NAME} of the robot")
    kin = Kinematics(robot)
    fb = kin.body_frame(body)
    parent = bodies[body].parent
    Rp, pp = (sp.eye(3), sp.zeros(3, 1)) if parent is None else (kin.body_frame(parent).R, kin.body_frame(parent).p)
    A = sp.eye(4)
    A[:3, :3] = (Rp.T * fb.R).applyfunc(sp.simplify)
    A[:3, 3] = (Rp.T * (fb.p - pp)).applyfunc(sp.simplify)
    dA = cal.transform_derivative(A, symbol(param))
    dA_nom = dA.subs({symbol(param): _exact(nominal[symbol(param)])})
    L = lambda e: to_latex(e, list(robot.coordinates))
    ctx.step(f"Derivative of the transform of {body.replace('_', ' ')}", rf"\frac{{\partial A}}{{\partial {L(symbol(param))}}} = {L(dA)},"
             rf"\quad \text{{nominal}}: {L(dA_nom)}",
             f"Homogeneous transform of {body.replace('_', ' ')} from its parent, differentiated with respect to "
             f"${L(symbol(param))}$ and "
             "evaluated at its nominal value.", bodies=[body])
    ctx.answer("dA", dA)
    ctx.answer("dA_nominal", dA_nom)
