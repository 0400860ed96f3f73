"""Impacts of a robot on a contact (core: ``app.core.impact``) and iterative learning of the gravity
compensation for regulation (core: ``app.core.learning``).

``impact``: an instantaneous impact when the gap phi(q) closes: M (q'+ - q'-) = J^T Lambda with
  J = dphi/dq and the restitution law J q'+ = -e J q'-. Options: ``gap`` (expression of the
  coordinates), ``velocity`` (q'- before the impact, one expression per coordinate),
  ``restitution`` (e, default 1: elastic), ``cases`` (label -> {parameter: value}; ``oo`` for a
  limit to infinity): the post-impact velocities in special cases (limits taken).
  Answers: ``dq_after`` (q'+), ``impulse`` (Lambda), ``energy_loss`` (T- - T+), ``momentum_change``
  (sum of M (q'+ - q'-) over the coordinates, zero when the impulse is internal), and per case
  ``dq_after_<label>``.
``gravity_learning``: PD plus a feedforward u_i updated at each reached equilibrium,
  u_i = u_{i-1} + K_P (q_d - q_i), u_0 = 0. Options: ``kp`` (scalar or diagonal), ``q_d``, ``q_0``
  (default the configuration), ``epsilon`` (tolerance on the error), ``beta`` (contraction design
  value; default the smallest unit fraction 1/N above alpha / k_p), ``iterations`` (default 8).
  Answers: ``alpha`` (bound on ||dg/dq||), ``converges`` (k_p > 2 alpha), ``beta``,
  ``contraction`` (beta / (1 - beta)), ``e_bounds`` (|e_0| times the contraction powers),
  ``i_min`` (first iteration whose bound is below epsilon), ``q_iterates``, ``e_iterates``
  (norms), ``u_iterates``, ``u_true`` (g(q_d)).

Examples:

    - {kind: impact, gap: "x2 - x1", velocity: [v0, 0],
       cases: {light: {m2: 0}, equal: {m2: m1}, heavy: {m2: oo}}}
    - {kind: gravity_learning, kp: 500, q_d: [pi/3], q_0: [0], epsilon: 0.01}
"""
from __future__ import annotations

import numpy as np
import sympy as sp

from .. import impact as imp
from .. import learning as lrn
from ..exercise import ExerciseError
from ..expressions import ExpressionError, parse_expression, symbol
from ..latex import num, vec
from ..steps import to_latex
from . import task
from .context import TaskView


def _expr(value, where):
    if value == "oo":
        return sp.oo
    try:
        return parse_expression(value)
    except ExpressionError as exc:
        raise ExerciseError(f"{where}: {exc}") from None


@task("impact")
def impact_task(ctx, spec):
    """Velocities after an impact (see the module docstring)."""
    robot = ctx.robot
    dyn = ctx.dynamics()
    if "gap" not in spec or "velocity" not in spec:
        raise ExerciseError("impact: give the gap phi(q) and the velocity before the impact")
    phi = sp.Matrix([_expr(g, "impact.gap") for g in (spec["gap"] if isinstance(spec["gap"], list) else [spec["gap"]])])
    vel = spec["velocity"]
    if not isinstance(vel, list) or len(vel) != robot.n:
        raise ExerciseError(f"impact.velocity: {robot.n} expressions (one per coordinate)")
    dq_minus = sp.Matrix([_expr(v, "impact.velocity") for v in vel])
    e = _expr(spec.get("restitution", 1), "impact.restitution")
    J = phi.jacobian(sp.Matrix(robot.q))
    try:
        res = imp.impact(dyn.M, J, dq_minus, e)
    except imp.ImpactError as exc:
        raise ExerciseError(f"impact: {exc}") from None
    ctx.answer("dq_after", res.dq_after)
    ctx.answer("impulse", res.impulse)
    ctx.answer("energy_loss", res.energy_loss)
    ctx.answer("momentum_change", res.momentum_change)
    L = lambda x: to_latex(x, robot.coordinates)
    ctx.step("Impact law", rf"M(\dot q^+ - \dot q^-) = J^T\Lambda,\quad J\dot q^+ = -e J\dot q^-,\quad J = {L(J)}",
             "Impulsive contact force along the gap; finite forces (gravity, inputs) do not act in the instant of the impact.",
             bodies=[b.name for b in robot.bodies])
    ctx.step("Velocities after the impact", rf"\Lambda = {L(res.impulse)},\quad \dot q^+ = {L(res.dq_after)},\quad "
             rf"T^- - T^+ = {L(res.energy_loss)}",
             "Momentum along the free directions is kept; with $e = 1$ the kinetic energy is kept as well.")
    for label, subs in (spec.get("cases") or {}).items():
        if not isinstance(subs, dict):
            raise ExerciseError(f"impact.cases.{label}: a mapping parameter -> value")
        val = res.dq_after
        for name, v in subs.items():
            target = _expr(v, f"impact.cases.{label}.{name}")
            val = val.applyfunc(lambda x: sp.limit(x, symbol(name), target))
        val = val.applyfunc(sp.simplify)
        ctx.answer(f"dq_after_{label}", val)
        arrow = ", ".join(rf"{k} \to {v}" for k, v in subs.items())
        ctx.step(f"Case: {label}", rf"{arrow}:\quad \dot q^+ = {L(val)}",
                 "The post-impact velocities in this limit case.")


@task("gravity_learning")
def gravity_learning_task(ctx, spec):
    """Iterative feedforward learning of the gravity torque for regulation (see the module docstring)."""
    d = TaskView(ctx)
    robot = ctx.robot
    num_model = ctx.numeric
    q_d = d.array(spec.get("q_d"), "gravity_learning.q_d").reshape(-1)
    q_0 = d.configuration(spec.get("q_0"))
    kp = d.array(spec.get("kp"), "gravity_learning.kp").reshape(-1) * np.ones(robot.n)
    eps = d.number(spec.get("epsilon", 0.01), "gravity_learning.epsilon")
    if q_d.size != robot.n:
        raise ExerciseError(f"gravity_learning.q_d: {robot.n} values")
    dg = ctx.dynamics().g.jacobian(sp.Matrix(robot.q))
    alpha = lrn.gradient_bound(dg, robot, d.params)
    beta = d.number(spec["beta"], "gravity_learning.beta") if "beta" in spec else None
    try:
        run = lrn.iterate(num_model.g, kp, q_d, q_0, alpha, eps, beta, int(spec.get("iterations", 8)))
    except lrn.LearningError as exc:
        raise ExerciseError(f"gravity_learning: {exc}") from None
    for name in ("alpha", "converges", "beta", "contraction", "e_bounds", "i_min", "e_iterates", "u_true"):
        ctx.answer(name, getattr(run, name))
    ctx.answer("q_iterates", np.array(run.q_iterates))
    ctx.answer("u_iterates", np.array(run.u_iterates))
    relation = ">" if run.converges else r"\le"
    ctx.step("Convergence condition", rf"\alpha = \max\|\partial g/\partial q\| = {num(alpha)},\quad "
             rf"k_P = {num(min(kp))} {relation} 2\alpha = {num(2 * alpha)}",
             r"With $k_P > 2\alpha$ the iterations contract: $|e_i| < \frac{\beta}{1 - \beta} |e_{i-1}|$ with "
             r"$k_P \beta > \alpha$, $\beta \le \frac{1}{2}$.")
    ctx.step("Error bounds", rf"\beta = {num(run.beta)},\ \frac{{\beta}}{{1-\beta}} = {num(run.contraction)},\quad "
             rf"\hat e_i = {vec(run.e_bounds)},\quad i_{{min}} = {run.i_min}",
             rf"The first iteration whose bound is below $\varepsilon = {num(eps)}$.")
    rows = [rf"i = {i}: q = {vec(q, 4)},\ u = {vec(u, 4)}" for i, (q, u) in enumerate(zip(run.q_iterates, run.u_iterates))]
    ctx.step("Iterates", r",\quad ".join(rows),
             r"Each rest configuration solves $g(q) = K_P (q_d - q) + u_{i-1}$; then $u_i = u_{i-1} + K_P (q_d - q_i)$. "
             rf"The feedforward converges to $g(q_d) = {vec(run.u_true, 4)}$.")
