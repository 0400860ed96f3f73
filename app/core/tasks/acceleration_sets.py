"""Sets of joint accelerations reachable under torque bounds at a state (core:
app.core.torque_polygon), with the bounds written symbolically from the robot's model.

``acceleration_polygon``: -T - n <= M(q) q'' <= T - n with n = c(q, q') + g(q) + k(q) (+ friction).
  Options: ``limits`` (T_i: names or numbers, one per joint), ``gravity`` (default true; false drops
  g and the springs, e.g. a horizontal robot), ``velocity`` (q', default rest), ``q`` (default the
  exercise's coordinates), ``name`` (answer prefix, default P).
  Answers ``<name>_M`` and ``<name>_lower``, ``<name>_upper`` (symbolic: the bounds on M q''),
  ``<name>_M_at``, ``<name>_n_at``, ``<name>_vertices`` (one row per vertex), ``<name>_max_norm``,
  ``<name>_max_norm_vertex``, ``<name>_zero_feasible`` (q'' = 0 reachable: the velocity can be kept),
  ``<name>_slope_ratio`` (b11 b22 / b12^2 > 1 for two joints with b12 != 0: the edges of the first
  band are steeper).

Example (2009-07-10#1): ``{kind: acceleration_polygon, limits: [T1, T2], velocity: [3, -4]}``
with T1, T2 given: the polygon at that state and whether q'' = 0 is still possible.
"""
from __future__ import annotations

import numpy as np
import sympy as sp

from .. import torque_polygon as tp
from ..expressions import symbol
from ..latex import mat, num, vec
from ..steps import to_latex
from . import task
from .context import TaskView


@task("acceleration_polygon")
def acceleration_polygon_task(ctx, spec):
    """Reachable joint accelerations under torque bounds (see the module docstring)."""
    d = TaskView(ctx)
    robot = d.robot
    name = str(spec.get("name", "P"))
    n = robot.n
    dyn = ctx.dynamics()
    raw = spec.get("limits")
    if not isinstance(raw, list) or len(raw) != n:
        raise d._fail(f"acceleration_polygon.limits: expected {n} torque bounds")
    T = sp.Matrix([d.expression(str(v), "acceleration_polygon.limits") for v in raw])
    moving = spec.get("velocity") is not None
    grav = spec.get("gravity", True)
    bias = (dyn.c if moving else sp.zeros(n, 1)) + ((dyn.g + dyn.spring) if grav else sp.zeros(n, 1))
    if moving:
        bias += dyn.friction
    L = lambda X: to_latex(X, robot.coordinates)
    lower, upper = (-T - bias).applyfunc(sp.expand), (T - bias).applyfunc(sp.expand)
    ctx.step(r"Torque bounds as bounds on $M \ddot q$", rf"{L(lower)} \le {L(dyn.M)}\,\ddot q \le {L(upper)}",
             "Each joint gives a band between two parallel lines (a slab in general): "
             + ("velocity terms and gravity shift it." if moving and grav else "gravity shifts it." if grav else
                "no gravity, at rest: the bands are centred at the origin."))
    ctx.answer(f"{name}_M", dyn.M)
    ctx.answer(f"{name}_lower", lower)
    ctx.answer(f"{name}_upper", upper)
    q = d.configuration(spec.get("q"))
    dq = d.array(spec["velocity"], "velocity").reshape(-1) if moving else np.zeros(n)
    values = {sp.Symbol(k, real=True): v for k, v in d.scalars().items()}
    values.update({s: float(v) for s, v in zip(robot.q, q)})
    values.update({s: float(v) for s, v in zip(robot.dq, dq)})
    num_of = lambda X: np.array(sp.Matrix(X).xreplace(values).evalf(), dtype=float)
    try:
        Mn, nn, Tn = num_of(dyn.M), num_of(bias).reshape(-1), num_of(T).reshape(-1)
    except TypeError:
        return                          # no numbers: the symbolic bounds only
    P = tp.acceleration_polytope(Mn, nn, -Tn, Tn)
    ctx.step("At the state", rf"M = {mat(Mn)},\quad n = {vec(nn)},\quad T = {vec(Tn)}",
             "At $" + ", ".join(f"{to_latex(symbol(c), robot.coordinates)} = {num(v)}" for c, v in zip(robot.coordinates, q))
             + (r",\ \dot q = " + vec(dq) + "$" if moving else "$, at rest") + ".",
             configuration={c: float(v) for c, v in zip(robot.coordinates, q)})
    ctx.answer(f"{name}_M_at", Mn)
    ctx.answer(f"{name}_n_at", nn)
    ctx.step("Reachable accelerations", r"\text{vertices: }" + r",\ ".join(vec(v) for v in P.vertices)
             + rf",\quad \max\|\ddot q\| = {num(P.max_norm)}\ \text{{at}}\ {vec(P.max_norm_vertex)}",
             "The largest norm is at a vertex. " + (r"$\ddot q = 0$ is reachable: the state can be held at constant velocity."
                                                 if P.zero_feasible else r"$\ddot q = 0$ is NOT reachable: velocity terms and "
                                                 "gravity need more torque than available; this constant-velocity regime "
                                                 "cannot be sustained."))
    ctx.answer(f"{name}_vertices", P.vertices)
    ctx.answer(f"{name}_max_norm", P.max_norm)
    ctx.answer(f"{name}_max_norm_vertex", P.max_norm_vertex)
    ctx.answer(f"{name}_zero_feasible", P.zero_feasible)
    if n == 2 and abs(Mn[0, 1]) > 1e-12:
        ratio = Mn[0, 0] * Mn[1, 1] / Mn[0, 1] ** 2
        ctx.step("Slopes of the band edges", rf"\frac{{b_{{11}}/b_{{12}}}}{{b_{{12}}/b_{{22}}}} = \frac{{b_{{11}} b_{{22}}}}{{b_{{12}}^2}} = {num(ratio)} > 1",
                 "Because det B > 0 the edges of the first band are steeper than those of the second.")
        ctx.answer(f"{name}_slope_ratio", ratio)
