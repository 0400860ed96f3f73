"""Reaction to known external forces: the torque that keeps a chosen joint acceleration (by default
none: q'' = 0, the least norm a fully actuated robot can get) while forces act on points of the
robot, and the dynamically consistent torque law of a task with a null-space torque. Values and
forces follow ``stability._Loop``.

``reaction_torque``: M(q) q'' + c + g + k + friction = tau + sum J_i^T F_i, solved for tau with
  q'' = ``acceleration`` (default 0). Options: ``external`` ([{point, force, name}]), ``state``
  (coordinate or velocity name -> value, symbols allowed: where to evaluate), ``acceleration``,
  ``substitute``, ``suffix``. Answers ``M``, ``c``, ``tau_reaction`` (any state), and at the state
  ``c_at``, ``J_<name>_at``, ``tau_ext_at`` (sum J^T F), ``tau_reaction_at``, ``ddq_norm_at``.

Example (2011-06-17#1): ``{kind: reaction_torque, substitute: {g0: 0, l1: 1, l2: 1, d1: 1/2,
d2: 1/2}, external: [{point: {body: link2, at: [l2/2, 0, 0]}, force: [-10, 0], name: K}],
state: {q1: 0, q2: pi/4, dq1: 0, dq2: -pi/2}}`` gives tau = c - J_K^T F at the impact.
"""
from __future__ import annotations

import sympy as sp

from ..expressions import symbol
from . import task
from .stability import _force_terms, _Loop


@task("reaction_torque")
def reaction_torque_task(ctx, spec):
    """Torque giving a chosen acceleration under known external forces (see the module docstring)."""
    lp = _Loop(ctx, spec, "reaction_torque")
    if not all(lp.robot.actuated):
        raise lp.fail("every coordinate must be actuated (q'' is then free to choose)")
    ddq = lp.vector(spec.get("acceleration", [0] * lp.n), lp.n, "acceleration")
    c = (lp.C * sp.Matrix(lp.dq)).applyfunc(sp.expand)
    lp.answer("M", lp.M)
    lp.answer("c", c)
    ext = _force_terms(lp, spec.get("external"), "external", 1)
    tau = (lp.M * ddq + c + lp.g + lp.k + lp.friction - ext).applyfunc(sp.expand)
    joints = [b.name for b in lp.robot.bodies]
    lp.ctx.step("Reaction torque", rf"\tau = M(q)\ddot q_d + c(q,\dot q) + g(q) - \sum J^T F = {lp.L(tau)}",
                r"With every joint actuated any $\ddot q$ can be imposed; $\ddot q_d = 0$ is the one of least norm, "
                "so the torque cancels the velocity terms and the effect of the forces.", joints=joints)
    lp.answer("tau_reaction", tau)
    state = spec.get("state")
    if state is None:
        return
    if not isinstance(state, dict):
        raise lp.fail("state: expected {coordinate or velocity: value}")
    names = set(lp.coords) | {f"d{c}" for c in lp.coords}
    bad = sorted(set(state) - names)
    if bad:
        raise lp.fail(f"state: unknown names {bad} (coordinates and their velocities d<q>)")
    at = {symbol(k): lp.expr(v, f"state.{k}") for k, v in state.items()}
    ev = lambda X: sp.Matrix(X).xreplace(at).applyfunc(lambda e: sp.nsimplify(sp.expand(e)) if e.is_number else sp.expand(e))
    c_at, ext_at, tau_at = ev(c), ev(ext), ev(tau)
    for item in spec.get("external") or []:
        label = str(item.get("name", "F1"))
        lp.answer(f"J_{label}_at", ev(ctx.answers[f"J_{label}{lp.suffix}"]))
    ddq_at = ev(ddq)
    lp.ctx.step("At the state", rf"c = {lp.L(c_at)},\quad \sum J^T F = {lp.L(ext_at)},\quad \tau = {lp.L(tau_at)}",
                rf"$\ddot q = {lp.L(ddq_at)}$ right after the forces act.", joints=joints)
    lp.answer("c_at", c_at)
    lp.answer("tau_ext_at", ext_at)
    lp.answer("tau_reaction_at", tau_at)
    lp.answer("ddq_norm_at", sp.sqrt(sum(e ** 2 for e in ddq_at)))
