"""Energy of a robot along its motion: rates of the total energy, kinetic and potential energy and
Lagrangian for a given input, the input that makes the total energy decrease fastest, and the
kinetic energy from one Newton-Euler call.

``energy``: Options: ``at`` and ``velocity`` (coordinate -> value or expression; default the
symbols q, q'), ``input`` (list u, one per coordinate), ``torque_bounds`` (list T_j with
|u_j| <= T_j: the fastest decrease of E = T + U), ``newton_euler`` (true: y = NE_0(q, 0, q'/2),
the inverse dynamics without gravity and velocity, and T = q'^T y), ``substitute`` (parameter ->
value, e.g. zero friction), ``hamiltonian`` (true: H(q, p) and Hamilton's equations with p = M q'), ``suffix``.
From M q'' + c + g + k + f = u and the skew-symmetry of
M' - 2C: T' = q'^T (u - g - k - f), U' = q'^T (g + k), E' = q'^T (u - f), L' = T' - U'.
Answers: ``E_dot``, ``T_dot``, ``U_dot``, ``L_dot`` (with ``input``); with ``torque_bounds``:
when q' != 0, ``tau_fastest`` (-T_j sign q'_j) and ``E_dot_fastest`` (-sum T_j |q'_j|); at rest,
where E' = 0 for any input, ``tau_fastest`` = (g + k)/2 minimizing E'' = u^T M^-1 u -
(g + k)^T M^-1 u, ``E_ddot_fastest`` (-1/4 g^T M^-1 g), ``T_ddot`` (1/4 g^T M^-1 g),
``U_ddot`` (-1/2 g^T M^-1 g); with ``newton_euler``: ``NE_y`` (M q' / 2) and ``T_newton_euler``; with ``hamiltonian``: ``H``,
``dH_dp`` (M^-1 p), ``dH_dq`` (1/2 col(p^T dM^-1/dq_i p) + g), ``dMinv_dq`` (one matrix per
coordinate, = -M^-1 dM/dq_i M^-1), ``hamilton_equations`` (q' and p' = -dH/dq + u - f), and
``hamilton_consistent`` (p' from Hamilton's equations equals d/dt (M q') along the Lagrangian model).

>>> from app.core.exercise import parse_exercise, solve
>>> ex = parse_exercise({"id": "x", "robot": "cartesian_pp_payload", "question": "?", "tasks": [
...     {"kind": "energy", "velocity": {"q1": 0, "q2": 0}, "torque_bounds": ["T1", "T2"]}]})
>>> solve(ex).answers["E_ddot_fastest"]
-g0**2*(m2 + m_p)/4
"""
from __future__ import annotations

import sympy as sp

from ..exercise import ExerciseError
from ..expressions import symbol
from ..steps import to_latex
from . import task
from .context import TaskView


def _state(m: TaskView, spec, key, symbols):
    raw = spec.get(key) or {}
    if not isinstance(raw, dict) or not set(map(str, raw)) <= set(m.coords):
        raise ExerciseError(f"energy.{key}: a mapping coordinate -> value ({', '.join(m.coords)})")
    return sp.Matrix([m.ctx.expr(raw[c], f"energy.{key}.{c}") if c in raw else s for c, s in zip(m.coords, symbols)])


def _vector(m: TaskView, raw, key):
    if not isinstance(raw, list) or len(raw) != len(m.coords):
        raise ExerciseError(f"energy.{key}: a list of {len(m.coords)} values, one per coordinate")
    return sp.Matrix([m.ctx.expr(v, f"energy.{key}") for v in raw])


@task("energy")
def energy_task(ctx, spec):
    """Energy rates, fastest energy decrease, kinetic energy by Newton-Euler (module docstring)."""
    m = TaskView(ctx)
    sfx = str(spec.get("suffix", ""))
    fixed = m.mapping_of_parameters(spec.get("substitute"), "energy.substitute")
    q, dq = _state(m, spec, "at", list(m.q)), _state(m, spec, "velocity", list(m.dq))
    state = {**dict(zip(m.q, q)), **dict(zip(m.dq, dq))}
    at = lambda x: m.tidy_matrix(sp.Matrix(x).subs(fixed).subs(state, simultaneous=True))
    g, f = at(m.dyn.g + m.dyn.spring), at(m.dyn.friction)
    L = m.L
    bodies = [b.name for b in m.robot.bodies]
    simp = lambda e: sp.nsimplify(sp.simplify(e), [sp.pi]) if not sp.sympify(e).free_symbols else sp.simplify(e)
    if spec.get("input") is not None:
        u = _vector(m, spec["input"], "input")
        rates = {"E_dot": (dq.T * (u - f))[0], "T_dot": (dq.T * (u - g - f))[0], "U_dot": (dq.T * g)[0]}
        rates["L_dot"] = rates["T_dot"] - rates["U_dot"]
        rates = {k: simp(v) for k, v in rates.items()}
        ctx.step("Power balance", rf"\dot E = \dot q^T(u - f) = {L(rates['E_dot'])},\quad \dot T = \dot q^T(u - g - f) = "
                 rf"{L(rates['T_dot'])},\quad \dot U = \dot q^T g = {L(rates['U_dot'])},\quad \dot L = \dot T - \dot U = {L(rates['L_dot'])}",
                 "Only the input (and friction) changes the total energy; gravity moves energy between T and U.",
                 bodies=bodies, joints=bodies)
        for k, v in rates.items():
            ctx.answer(k + sfx, v)
    if spec.get("torque_bounds") is not None:
        T = _vector(m, spec["torque_bounds"], "torque_bounds")
        if any(v != 0 for v in dq):
            tau = sp.Matrix([-T[j] * sp.sign(dq[j]) for j in range(len(dq))])
            e_dot = simp(-sum(T[j] * sp.Abs(dq[j]) for j in range(len(dq))))
            ctx.step("Fastest decrease while moving", rf"\dot E = \dot q^T u\ \Rightarrow\ u_j = -T_j\,\mathrm{{sign}}\,\dot q_j = {L(tau)},"
                     rf"\quad \dot E = {L(e_dot)}",
                     r"$\dot E$ is linear in $u$: each torque at its bound against its joint velocity (any value where $\dot q_j = 0$).",
                     joints=bodies)
            ctx.answer("tau_fastest" + sfx, tau)
            ctx.answer("E_dot_fastest" + sfx, e_dot)
        else:
            Minv = m.tidy_matrix(at(m.M).inv())
            tau = g / 2
            gMg = simp((g.T * Minv * g)[0])
            ctx.step(r"At rest $\dot E = 0$ for any input: look at $\ddot E$",
                     rf"\ddot E = \ddot q^T u = u^T M^{{-1}} u - g^T M^{{-1}} u\ \Rightarrow\ u = \tfrac12 g = {L(tau)},\quad "
                     rf"\ddot E = -\tfrac14 g^T M^{{-1}} g = {L(-gMg / 4)}",
                     r"A convex quadratic in $u$, smallest at $g/2$ (within the bounds when $|g_j| \le 2 T_j$).", joints=bodies)
            ctx.step("Kinetic and potential parts", rf"\ddot T = \ddot q^T M \ddot q = \tfrac14 g^T M^{{-1}} g = {L(gMg / 4)},\quad "
                     rf"\ddot U = \ddot E - \ddot T = {L(-gMg / 2)}",
                     "The robot starts moving (T grows) while its potential energy falls twice as fast.")
            ctx.answer("tau_fastest" + sfx, tau)
            ctx.answer("E_ddot_fastest" + sfx, -gMg / 4)
            ctx.answer("T_ddot" + sfx, gMg / 4)
            ctx.answer("U_ddot" + sfx, -gMg / 2)
    if spec.get("hamiltonian"):
        _hamiltonian(ctx, m, fixed, sfx)
    if spec.get("newton_euler"):
        # NE_0(q, 0, a): the inverse dynamics with zero velocity and without gravity, a = q'/2
        ne = (m.M * m.ddq + m.n - m.dyn.g - m.dyn.spring).subs(fixed)
        call = {**dict(zip(m.q, q)), **{d: 0 for d in m.dq}, **dict(zip(m.ddq, dq / 2))}
        y = m.tidy_matrix(ne.subs(call, simultaneous=True))
        T_ne = simp((dq.T * y)[0])
        ctx.step("Kinetic energy with one Newton-Euler call",
                 rf"y = NE_0(q, 0, \tfrac12\dot q) = \tfrac12 M(q)\dot q = {L(y)},\quad T = \dot q^T y = {L(T_ne)}",
                 "With zero velocity and no gravity the routine returns M(q) times the acceleration passed to it.",
                 bodies=bodies)
        ctx.answer("NE_y" + sfx, y)
        ctx.answer("T_newton_euler" + sfx, T_ne)


def _hamiltonian(ctx, m: TaskView, fixed, sfx: str) -> None:
    """H = 1/2 p^T M^-1 p + U with p = M q', its gradients, and Hamilton's equations checked against
    the Lagrangian model (p' = M q'' + M' q' with q'' = M^-1 (u - n)) at random points (seed 0)."""
    import numpy as np
    n = len(m.coords)
    p = sp.Matrix([symbol(f"p{i + 1}") for i in range(n)])
    u = sp.Matrix([symbol(f"u{i + 1}") for i in range(n)])
    M = m.M.subs(fixed)
    Minv = M.inv().applyfunc(sp.cancel)
    U = sum(m.dyn.potential.values(), sp.Integer(0)).subs(fixed)
    g = (m.dyn.g + m.dyn.spring).subs(fixed)
    H = (p.T * Minv * p)[0] / 2 + U
    dMinv = [Minv.diff(qk).applyfunc(sp.factor) for qk in m.q]
    dH_dp = (Minv * p).applyfunc(sp.factor)
    dH_dq = (sp.Matrix([(p.T * dMinv[i] * p)[0] / 2 for i in range(n)]) + g).applyfunc(sp.factor)
    f = m.dyn.friction.subs(fixed).subs(dict(zip(m.dq, dH_dp)), simultaneous=True)
    p_dot = -dH_dq + u - f
    # the same p' from the Lagrangian model, at random points: p = M q', q'' = M^-1 (u - n)
    rng = np.random.default_rng(0)
    syms = sorted((M.free_symbols | g.free_symbols | p_dot.free_symbols | m.n.subs(fixed).free_symbols | set(p) | set(u))
                  - set(m.dq), key=lambda x: x.name)
    gaps = []
    for _ in range(3):
        vals = {x: float(rng.uniform(0.3, 1.7)) for x in syms}
        Mv = np.array(M.subs(vals), dtype=float)
        dqv = np.linalg.solve(Mv, np.array(p.subs(vals), dtype=float).reshape(-1))
        st = {**vals, **dict(zip(m.dq, dqv))}
        ddq = np.linalg.solve(Mv, np.array((u - m.n.subs(fixed)).subs(st), dtype=float).reshape(-1))
        Mdot = sum((np.array(M.diff(qk).subs(vals), dtype=float) * dqv[k] for k, qk in enumerate(m.q)), np.zeros((n, n)))
        gaps.append(np.max(np.abs(Mv @ ddq + Mdot @ dqv - np.array(p_dot.subs(vals), dtype=float).reshape(-1))))
        gaps.append(max(np.max(np.abs(np.array((dMinv[i] + Minv * M.diff(m.q[i]) * Minv).subs(vals), dtype=float)))
                        for i in range(n)))
    consistent = max(gaps) < 1e-9
    L = m.L
    ctx.step("Hamiltonian", rf"p = M(q)\dot q,\quad H(q, p) = \tfrac12 p^T M^{{-1}}(q) p + U(q) = {L(H)}",
             "The total energy written with the generalized momentum.")
    ctx.step("Its gradients", rf"\nabla_p H = M^{{-1}} p = {L(dH_dp)},\quad \nabla_q H = \tfrac12\,\mathrm{{col}}"
             rf"\{{p^T \tfrac{{\partial M^{{-1}}}}{{\partial q_i}} p\}} + g = {L(dH_dq)}",
             r"With $\partial M^{-1}/\partial q_i = -M^{-1} (\partial M/\partial q_i) M^{-1}$.")
    ctx.step("Hamilton's equations", rf"\dot q = \nabla_p H,\quad \dot p = -\nabla_q H + u = {L(p_dot)}",
             r"They agree with $\frac{d}{dt}(M \dot q)$ along the Lagrangian model (checked at random points)." if consistent
             else "They do not agree with the Lagrangian model at random points.")
    ctx.answer("H" + sfx, H)
    ctx.answer("dH_dp" + sfx, dH_dp)
    ctx.answer("dH_dq" + sfx, dH_dq)
    ctx.answer("dMinv_dq" + sfx, dMinv)
    ctx.answer("hamilton_equations" + sfx, sp.Matrix.vstack(dH_dp, p_dot))
    ctx.answer("hamilton_consistent" + sfx, bool(consistent))
