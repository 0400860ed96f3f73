"""Energy of a robot along its motion: rates of the total energy, kinetic and potential energy and
Lagrangian for a given input, the input that makes the total energy decrease fastest, and the
kinetic energy from one Newton-Euler call.

``energy``: Options: ``at`` and ``velocity`` (coordinate -> value or expression; default the
symbols q, q'), ``input`` (list u, one per coordinate), ``torque_bounds`` (list T_j with
|u_j| <= T_j: the fastest decrease of E = T + U), ``newton_euler`` (true: y = NE_0(q, 0, q'/2),
the inverse dynamics without gravity and velocity, and T = q'^T y), ``substitute`` (parameter ->
value, e.g. zero friction), ``suffix``. From M q'' + c + g + k + f = u and the skew-symmetry of
M' - 2C: T' = q'^T (u - g - k - f), U' = q'^T (g + k), E' = q'^T (u - f), L' = T' - U'.
Answers: ``E_dot``, ``T_dot``, ``U_dot``, ``L_dot`` (with ``input``); with ``torque_bounds``:
when q' != 0, ``tau_fastest`` (-T_j sign q'_j) and ``E_dot_fastest`` (-sum T_j |q'_j|); at rest,
where E' = 0 for any input, ``tau_fastest`` = (g + k)/2 minimizing E'' = u^T M^-1 u -
(g + k)^T M^-1 u, ``E_ddot_fastest`` (-1/4 g^T M^-1 g), ``T_ddot`` (1/4 g^T M^-1 g),
``U_ddot`` (-1/2 g^T M^-1 g); with ``newton_euler``: ``NE_y`` (M q' / 2) and ``T_newton_euler``.

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
from .underactuated import Model


def _state(m: Model, spec, key, symbols):
    raw = spec.get(key) or {}
    if not isinstance(raw, dict) or not set(map(str, raw)) <= set(m.coords):
        raise ExerciseError(f"energy.{key}: a mapping coordinate -> value ({', '.join(m.coords)})")
    return sp.Matrix([m.ctx.expr(raw[c], f"energy.{key}.{c}") if c in raw else s for c, s in zip(m.coords, symbols)])


def _vector(m: Model, raw, key):
    if not isinstance(raw, list) or len(raw) != len(m.coords):
        raise ExerciseError(f"energy.{key}: a list of {len(m.coords)} values, one per coordinate")
    return sp.Matrix([m.ctx.expr(v, f"energy.{key}") for v in raw])


@task("energy")
def energy_task(ctx, spec):
    """Energy rates, fastest energy decrease, kinetic energy by Newton-Euler (module docstring)."""
    m = Model(ctx)
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
                     "E' is linear in u: each torque at its bound against its joint velocity (any value where q'_j = 0).",
                     joints=bodies)
            ctx.answer("tau_fastest" + sfx, tau)
            ctx.answer("E_dot_fastest" + sfx, e_dot)
        else:
            Minv = m.tidy_matrix(at(m.M).inv())
            tau = g / 2
            gMg = simp((g.T * Minv * g)[0])
            ctx.step("At rest E' = 0 for any input: look at E''",
                     rf"\ddot E = \ddot q^T u = u^T M^{{-1}} u - g^T M^{{-1}} u\ \Rightarrow\ u = \tfrac12 g = {L(tau)},\quad "
                     rf"\ddot E = -\tfrac14 g^T M^{{-1}} g = {L(-gMg / 4)}",
                     "A convex quadratic in u, smallest at g/2 (within the bounds when |g_j| <= 2 T_j).", joints=bodies)
            ctx.step("Kinetic and potential parts", rf"\ddot T = \ddot q^T M \ddot q = \tfrac14 g^T M^{{-1}} g = {L(gMg / 4)},\quad "
                     rf"\ddot U = \ddot E - \ddot T = {L(-gMg / 2)}",
                     "The robot starts moving (T grows) while its potential energy falls twice as fast.")
            ctx.answer("tau_fastest" + sfx, tau)
            ctx.answer("E_ddot_fastest" + sfx, -gMg / 4)
            ctx.answer("T_ddot" + sfx, gMg / 4)
            ctx.answer("U_ddot" + sfx, -gMg / 2)
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
