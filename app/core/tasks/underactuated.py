"""Underactuated mechanical systems: partial feedback linearization, linearization about an
equilibrium, steady rotations, changes of coordinates and accelerations at a state (reduced
dynamics under holonomic constraints: ``constrained``). Everything is computed from the robot's
Lagrangian model

    M(q) q'' + n(q, q') = S u,     n = c + g + k + F_v q' (+ Coulomb),

where S selects the actuated coordinates (the robot file's ``actuated``, or the task's ``passive``).

Task kinds (options -> answers):

- ``pfl``: partial feedback linearization, collocated or not, for any set of passive coordinates.
  Options: ``passive`` (default: the robot's non-actuated coordinates), ``linearize`` (the
  coordinates that get q''_i = a_i, as many as the inputs; default: the actuated ones, i.e.
  collocated), ``inputs`` (names of the new inputs; default a<i> for coordinate i), ``outer``
  (mapping input -> expression: an outer loop substituted into the law), ``rest`` (mapping
  linearized coordinate -> value: the residual dynamics with those coordinates at rest there).
  Answers: ``u`` (the law, one entry per actuated coordinate), ``M_reduced``, ``n_reduced``,
  ``reduced_equation`` (M_reduced q''_L + n_reduced, equal to u), ``closed_loop`` (q'' of every
  coordinate as a function of q, q', a), ``u_outer``, ``residual`` (q'' of the other coordinates
  at rest) and ``u_rest``; ``suffix`` is appended to every answer name (two PFL designs in one
  exercise).
- ``linearization``: small motions about an equilibrium. Options: ``at`` (coordinate -> value;
  velocities are zero). Answers: ``u0`` (equilibrium input on every coordinate), ``M0``, ``D``,
  ``K`` (M0 dq'' + D dq' + K dq = S du), ``A``, ``B`` (state x = (dq, dq')).
- ``steady_rotation``: constant-speed rotations. Options: ``spin`` (coordinate -> constant speed,
  e.g. ``{q1: Omega}``), ``free`` (coordinates that stay constant and are solved for; default all
  the others), ``zero`` (coordinates whose generalized force must vanish; default the passive
  ones). Answers: ``torque`` (generalized forces needed along the rotation, as functions of the
  constant coordinates), ``equilibria`` (one row per solution of the ``zero`` rows, sorted).
- ``coordinate_change``: linear change of coordinates p = J q. Options: ``map`` (new coordinate ->
  expression of q), or ``torque_map`` (the generalized forces as expressions of the actuator
  torques tau1..taun: then p is the set of coordinates on which the torques work component-wise)
  with ``new`` (names, default p1..pn). Answers: ``J``, ``J_inv``, ``q_of_p``, ``M_p``, ``c_p``,
  ``g_p``, ``tau_q`` (J^T tau).
- ``accelerations``: q'' = M^-1 (S u - n) at a state. Options: ``state`` (coordinate or velocity
  -> value), ``inputs`` (actuated coordinate -> value or expression). Answers: ``ddq``.
- ``elastic_joints``: robots whose motor coordinates (rotor inertia B) drive the links through
  springs on theta - q, linear K (theta - q) or nonlinear (e.g. ``expr: (theta - q)**2``, a force
  k_n (theta - q)^3). Option ``q_d`` (link coordinate -> value: where the real root of a nonlinear
  spring is chosen; default the exercise's configuration). Answers: ``K`` (linear stiffness), ``B``,
  ``link_equations`` (M q'' + c + g + tau_K, = 0), ``motor_equations`` (B theta'' - tau_K, = u),
  ``theta_d`` (q_d + K^-1 g(q_d); with nonlinear springs q_d + the real root delta of the link
  equations at rest, e.g. k delta + k_n delta^3 = g(q_d)),
  ``u`` (motor PD with constant gravity compensation, gains kp<i>, kd<i>), ``V`` and ``V_dot``
  (Lyapunov function and its derivative along the closed loop, from the model itself).

>>> from app.core.expressions import symbol
>>> q2 = symbol("q2")
>>> tidy_quotient((sp.cos(q2)**2 + sp.sin(q2)**2) / symbol("m"))
1/m
"""
from __future__ import annotations

from typing import Dict

import sympy as sp

from ..coordinates import in_coordinates
from ..exercise import ExerciseError
from ..expressions import symbol
from ..mathtext import symbols_text
from ..steps import to_latex
from ..trig import TrigPoly
from . import task
from .context import TaskView, tidy_quotient


# ====================================================================== shared helpers
_PROFILES = {   # rest-to-rest timing laws s(sigma) / Delta, sigma = t / T in [0, 1]
    "cubic": lambda s: 3 * s ** 2 - 2 * s ** 3,
    "quintic": lambda s: 10 * s ** 3 - 15 * s ** 4 + 6 * s ** 5,
}


def _given_values(ctx) -> Dict[sp.Symbol, sp.Expr]:
    """The exercise's numbers (robot parameters and task data) as a substitution."""
    out = {}
    for k, v in ctx.given.items():
        out[symbol(k)] = ctx.expr(v, f"given.{k}")
    return out


def _time_derivative(mat: sp.Matrix, q, dq) -> sp.Matrix:
    out = sp.zeros(*mat.shape)
    for qk, dk in zip(q, dq):
        out += mat.diff(qk) * dk
    return out


def _inverse(mat: sp.Matrix) -> sp.Matrix:
    """Exact inverse through the adjugate (small matrices)."""
    det = sp.expand(mat.det())
    if TrigPoly.from_expr(det).is_zero():
        raise ExerciseError("the matrix to invert is singular everywhere")
    return mat.adjugate() / det


# ====================================================================== PFL
@task("pfl")
def pfl_task(ctx, spec):
    """Partial feedback linearization (see the module docstring for options and answers)."""
    m = TaskView(ctx)
    n = len(m.coords)
    if "passive" in spec:
        passive = m.indices(spec["passive"], "pfl.passive")
    else:
        passive = [i for i, a in enumerate(m.robot.actuated) if not a]
    if not passive:
        raise ExerciseError("pfl: the robot is fully actuated; name the passive coordinates with 'passive'")
    act = [i for i in range(n) if i not in passive]
    lin = m.indices(spec["linearize"], "pfl.linearize") if "linearize" in spec else list(act)
    if len(lin) != len(act):
        raise ExerciseError(f"pfl.linearize: {len(act)} input(s) can linearize exactly {len(act)} coordinate(s), "
                            f"got {len(lin)}")
    oth = [i for i in range(n) if i not in lin]
    names = spec.get("inputs") or [f"a{i + 1}" for i in lin]
    if len(names) != len(lin):
        raise ExerciseError("pfl.inputs: one name per linearized coordinate")
    a = sp.Matrix(m.new_symbols(names, "pfl.inputs"))
    collocated = sorted(lin) == sorted(act)
    M, nv = m.M, m.n
    blk = lambda rows, cols: M.extract(rows, cols)
    M_PO, M_PL = blk(passive, oth), blk(passive, lin)
    M_AL, M_AO = blk(act, lin), blk(act, oth)
    det = sp.expand(M_PO.det())
    if TrigPoly.from_expr(det).is_zero():
        raise ExerciseError("pfl: the passive equations do not involve the remaining accelerations "
                            "(the inertia block is singular): this choice cannot be linearized")
    inv = M_PO.adjugate() / det
    X = -inv * M_PL
    y = -inv * nv.extract(passive, [0])
    M_red = m.tidy_matrix(M_AL + M_AO * X)
    n_red = m.tidy_matrix(nv.extract(act, [0]) + M_AO * y)
    u = m.tidy_matrix(M_red * a + n_red)
    ddq = sp.zeros(n, 1)
    for k, i in enumerate(lin):
        ddq[i] = a[k]
    ddq_o = m.tidy_matrix(X * a + y)
    for k, i in enumerate(oth):
        ddq[i] = ddq_o[k]
    qn = lambda idx: symbols_text(m.coords[i] for i in idx)
    ddq_L = sp.Matrix([m.ddq[i] for i in lin])
    ddq_O = sp.Matrix([m.ddq[i] for i in oth])
    passive_bodies = m.bodies_of(passive)
    kind = "collocated" if collocated else "non-collocated"
    ctx.step("Actuated and passive equations",
             rf"M_{{AL}} {m.L(ddq_L)} + M_{{AO}} {m.L(ddq_O)} + n_A = u,\quad "
             rf"M_{{PL}} {m.L(ddq_L)} + M_{{PO}} {m.L(ddq_O)} + n_P = 0,\quad M_{{PO}} = {m.L(M_PO)}",
             f"Split the model into the rows of the actuated ({qn(act)}) and passive ({qn(passive)}) "
             rf"coordinates; {kind} PFL imposes $\ddot q = a$ on {qn(lin)}.",
             bodies=passive_bodies, joints=passive_bodies)
    cond = m.tidy(det)
    ctx.step("Accelerations of the other coordinates",
             rf"{m.L(ddq_O)} = -M_{{PO}}^{{-1}}\left(M_{{PL}} {m.L(a)} + n_P\right) = {m.L(ddq_o)}",
             "Solve the passive equations for the remaining accelerations"
             + ("." if not cond.free_symbols & set(m.q) else
                rf"; this needs $\det M_{{PO}} = {m.L(cond)} \ne 0$ (strong inertial coupling)."),
             bodies=m.bodies_of(oth))
    ctx.step("Reduced equation",
             rf"{m.L(M_red)} {m.L(ddq_L)} + {m.L(n_red)} = u",
             r"Substitute them into the actuated equations: the inputs now act on $\ddot q_L$ through "
             "this reduced inertia.", bodies=m.bodies_of(lin), joints=m.bodies_of(act))
    ctx.step("Linearizing feedback",
             rf"u = {m.L(M_red)} {m.L(a)} + {m.L(n_red)} = {m.L(u)}",
             rf"Choosing $u$ this way gives $\ddot q = a$ on {qn(lin)} exactly and globally (wherever it is defined).",
             joints=m.bodies_of(act))
    ctx.step("Closed loop", rf"\ddot q = {m.L(ddq)}",
             f"The linearized coordinates follow $a$; {qn(oth)} obey the remaining (zero) dynamics.",
             bodies=m.bodies_of(oth))
    sfx = str(spec.get("suffix", ""))
    ctx.answer("u" + sfx, u)
    ctx.answer("M_reduced" + sfx, M_red)
    ctx.answer("n_reduced" + sfx, n_red)
    ctx.answer("reduced_equation" + sfx, m.tidy_matrix(M_red * ddq_L + n_red))
    ctx.answer("closed_loop" + sfx, ddq)
    _pfl_outer_loop(ctx, m, spec, u, names, sfx)
    _pfl_residual(ctx, m, spec, u, a, lin, oth, ddq_o, sfx)


def _pfl_outer_loop(ctx, m: TaskView, spec, u, names, sfx: str) -> None:
    """The law with an outer loop substituted for the new inputs (option ``outer``)."""
    outer = spec.get("outer")
    if outer:
        if not isinstance(outer, dict) or not set(outer) <= set(names):
            raise ExerciseError(f"pfl.outer: expected a mapping input -> expression for the inputs {names}")
        sub = {symbol(k): ctx.expr(v, f"pfl.outer.{k}") for k, v in outer.items()}
        u_outer = m.tidy_matrix(u.subs(sub))
        ctx.step("Outer loop", ", ".join(rf"{m.L(k)} = {m.L(v)}" for k, v in sub.items())
                 + rf",\quad u = {m.L(u_outer)}",
                 "A stabilizing choice of the new inputs, substituted into the law.")
        ctx.answer("u_outer" + sfx, u_outer)


def _pfl_residual(ctx, m: TaskView, spec, u, a, lin, oth, ddq_o, sfx: str) -> None:
    """The other coordinates' dynamics with the linearized ones at rest (option ``rest``)."""
    ddq_O = sp.Matrix([m.ddq[i] for i in oth])
    rest = spec.get("rest")
    if rest:
        at = m.mapping(rest, "pfl.rest")
        if not {m.coords.index(s.name) for s in at} <= set(lin):
            raise ExerciseError("pfl.rest: only linearized coordinates can be put at rest")
        sub = dict(at)
        for s in at:
            i = m.coords.index(s.name)
            sub[m.dq[i]] = 0
            sub[a[lin.index(i)]] = 0
        residual = m.tidy_matrix(ddq_o.subs(sub))
        u_rest = m.tidy_matrix(u.subs(sub))
        ctx.step("Residual dynamics",
                 rf"{m.L(ddq_O)} = {m.L(residual)},\quad u = {m.L(u_rest)}",
                 "With the linearized coordinates at rest at their targets, the other coordinates "
                 "move under what is left; the input keeps compensating them.",
                 bodies=m.bodies_of(oth))
        ctx.answer("residual" + sfx, residual)
        ctx.answer("u_rest" + sfx, u_rest)


# ====================================================================== linearization
@task("linearization")
def linearization_task(ctx, spec):
    """Linear approximation about an equilibrium (see the module docstring)."""
    m = TaskView(ctx)
    at = m.mapping(spec.get("at"), "linearization.at")
    zero_v = {d: 0 for d in m.dq}
    robot = m.robot
    static = m.dyn.g + m.dyn.spring
    u0 = m.tidy_matrix(static.subs(at))
    for i, a in enumerate(robot.actuated):
        if not a and not TrigPoly.from_expr(u0[i]).is_zero():
            raise ExerciseError(f"linearization: not an equilibrium: the passive coordinate {m.coords[i]} "
                                f"feels the static force {u0[i]}")
    viscous = sp.Matrix(robot.viscous_forces())
    M0 = m.tidy_matrix(m.M.subs(at))
    D = m.tidy_matrix((m.dyn.c + viscous).jacobian(m.dq).subs(zero_v).subs(at))
    K = m.tidy_matrix(static.jacobian(m.q).subs(at))
    S = m.selection(robot.actuated)
    n = len(m.coords)
    Minv = _inverse(M0)
    A = sp.zeros(2 * n, 2 * n)
    A[:n, n:] = sp.eye(n)
    A[n:, :n] = m.tidy_matrix(-Minv * K)
    A[n:, n:] = m.tidy_matrix(-Minv * D)
    B = sp.zeros(2 * n, S.cols)
    B[n:, :] = m.tidy_matrix(Minv * S)
    dq_, dv, da = (sp.Matrix([sp.Symbol(r"\Delta " + to_latex(s, m.coords)) for s in v]) for v in (m.q, m.dq, m.ddq))
    where = ", ".join(f"{m.L(k)} = {m.L(v)}" for k, v in at.items()) or r"\text{the given state}"
    ctx.step("Equilibrium", rf"q_0:\ {where},\quad \dot q_0 = 0,\quad u_0 = g(q_0) + k(q_0) = {m.L(u0)}",
             "At rest, the input only has to balance gravity and springs; passive coordinates must feel none.",
             bodies=[b.name for b in robot.bodies])
    ctx.step("Linearized model",
             rf"{m.L(M0)} \Delta\ddot q + {m.L(D)} \Delta\dot q + {m.L(K)} \Delta q = {m.L(S)} \Delta u",
             "First-order expansion: $M(q_0)$ for the inertia, damping from viscous friction "
             r"(Coriolis terms are quadratic in $\dot q$ and vanish), stiffness from the gradient of $g + k$.")
    ctx.step("State space", rf"\dot x = {m.L(A)} x + {m.L(B)} \Delta u",
             r"With $x = (\Delta q, \Delta\dot q)$.")
    ctx.answer("u0", u0)
    ctx.answer("M0", M0)
    ctx.answer("D", D)
    ctx.answer("K", K)
    ctx.answer("A", A)
    ctx.answer("B", B)


# ====================================================================== steady rotations
def solve_trig(expr, angle):
    """Roots in (-pi, pi] of a polynomial in sin(angle), cos(angle) whose factors are each linear in
    one of them (None when some factor is not): sin = k gives asin(k) and pi - asin(k), cos = k
    gives +-acos(k).

    >>> q = symbol("q"); w, g = sp.symbols("w g", positive=True)
    >>> solve_trig(sp.sin(q) * (g - w * sp.cos(q)), q)
    [0, pi, acos(g/w), -acos(g/w)]
    """
    S, C = sp.Dummy("S"), sp.Dummy("C")
    poly = sp.expand(sp.expand_trig(expr)).subs({sp.sin(angle): S, sp.cos(angle): C})
    if angle in poly.free_symbols:
        return None
    roots = []
    for factor, _mult in sp.factor_list(poly)[1]:
        fs = factor.free_symbols
        if S in fs and C in fs or not fs & {S, C}:
            if S in fs and C in fs:
                return None
            continue
        x = S if S in fs else C
        if sp.degree(factor, x) != 1:
            return None
        k = sp.solve(factor, x)[0]
        if x is S:
            cand = [sp.asin(k), sp.pi - sp.asin(k)]
        else:
            cand = [sp.acos(k), -sp.acos(k)]
        for r in cand:
            r = sp.simplify(r)
            if r.is_number:
                r = sp.pi if r == -sp.pi else r
            if not any(sp.simplify(r - o) == 0 for o in roots):
                roots.append(r)
    return roots


def _sort_solutions(rows, values):
    def key(row):
        try:
            return (0, [float(sp.N(e.subs(values))) for e in row])
        except (TypeError, ValueError):
            return (1, [sp.default_sort_key(e) for e in row])
    return sorted(rows, key=key)


@task("steady_rotation")
def steady_rotation_task(ctx, spec):
    """Steady rotations at constant speed (see the module docstring)."""
    m = TaskView(ctx)
    spin = m.mapping(spec.get("spin"), "steady_rotation.spin")
    if not spin:
        raise ExerciseError("steady_rotation.spin: give at least one coordinate and its constant speed")
    spin_idx = [m.coords.index(s.name) for s in spin]
    free = (m.indices(spec["free"], "steady_rotation.free") if "free" in spec
            else [i for i in range(len(m.coords)) if i not in spin_idx])
    zero = (m.indices(spec["zero"], "steady_rotation.zero") if "zero" in spec
            else [i for i, a in enumerate(m.robot.actuated) if not a])
    sub = {d: 0 for d in m.dq}
    for s, w in spin.items():
        sub[m.dq[m.coords.index(s.name)]] = w
    torque = m.tidy_matrix(m.n.subs(sub))
    spun = ", ".join(rf"\dot {to_latex(s, m.coords)} = {m.L(w)}" for s, w in spin.items())
    ctx.step("Forces along a steady rotation", rf"{spun},\ \ddot q = 0:\quad u = n(q, \dot q) = {m.L(torque)}",
             "With constant speeds and the other coordinates at rest, only velocity, friction, "
             "gravity and spring terms remain.", bodies=m.bodies_of(spin_idx))
    ctx.answer("torque", torque)
    if not zero:
        return
    unknowns = [m.q[i] for i in free]
    eqs = [torque[i] for i in zero]
    rows = None
    if len(unknowns) == 1 and len(eqs) == 1:
        roots = solve_trig(eqs[0], unknowns[0])     # None: not a polynomial in sin, cos
        rows = None if roots is None else [[r] for r in roots]
    if rows is None:
        try:
            sols = sp.solve(eqs, unknowns, dict=True)
        except NotImplementedError:
            sols = []
        rows = [[tidy_quotient(s_.get(u, u)) for u in unknowns] for s_ in sols]
    if not rows:
        raise ExerciseError("steady_rotation: no closed-form solution of the steady-state equations")
    values = {p.symbol: p.value for p in m.robot.parameters.values()}
    values.update({k: v for k, v in ((symbol(k), v) for k, v in ctx.given.items())})
    rows = _sort_solutions(rows, values)
    eq_latex = r",\quad ".join(f"{m.L(e)} = 0" for e in eqs)
    sol_latex = r",\quad ".join(m.L(sp.Matrix(r)) for r in rows)
    ctx.step("Steady configurations", rf"{eq_latex}\ \Rightarrow\ {m.L(sp.Matrix(unknowns))} \in \left\{{{sol_latex}\right\}}",
             "The unactuated (or unloaded) rows must vanish: these are the constant configurations "
             "compatible with the rotation (real only where the arguments are in range).",
             bodies=m.bodies_of(free))
    ctx.answer("equilibria", sp.Matrix(rows))


# ====================================================================== change of coordinates
@task("coordinate_change")
def coordinate_change_task(ctx, spec):
    """Model in new coordinates p = J q (see the module docstring)."""
    m = TaskView(ctx)
    n = len(m.coords)
    tau = sp.Matrix([symbol(f"tau{i + 1}") for i in range(n)])
    if "torque_map" in spec:
        tm = spec["torque_map"]
        if not isinstance(tm, list) or len(tm) != n:
            raise ExerciseError(f"coordinate_change.torque_map: give the {n} generalized forces as expressions of tau1..tau{n}")
        tau_q_given = sp.Matrix([ctx.expr(e, "coordinate_change.torque_map") for e in tm])
        Bt = tau_q_given.jacobian(tau)
        if tau_q_given - Bt * tau != sp.zeros(n, 1) or Bt.free_symbols:
            raise ExerciseError("coordinate_change.torque_map: expected a constant linear map of the torques")
        names = spec.get("new") or [f"p{i + 1}" for i in range(n)]
        mp = dict(zip(names, list(Bt.T * m.q)))
        ctx.step("Coordinates conjugate to the torques", rf"\tau_q = {m.L(tau_q_given)} = J^T \tau \Rightarrow J = {m.L(Bt.T)}",
                 r"The torques do work component-wise on $p = J q$, since $\tau_q^T \dot q = \tau^T J \dot q = \tau^T \dot p$.")
    else:
        mp = spec.get("map")
        tau = sp.Matrix([symbol(f"tau_p{i + 1}") for i in range(n)])
    if not isinstance(mp, dict) or len(mp) != n:
        raise ExerciseError(f"coordinate_change.map: give one new coordinate per old one ({n})")
    p = sp.Matrix(m.new_symbols(list(mp), "coordinate_change.map"))
    m.new_symbols(["d" + str(s) for s in p], "coordinate_change.map")   # the velocities must be free names too
    expr = sp.Matrix([ctx.expr(v, f"coordinate_change.map.{k}") for k, v in mp.items()])
    J = expr.jacobian(m.q)
    if J.free_symbols & (set(m.q) | set(m.dq)) or (expr - J * m.q).free_symbols & set(m.q):
        raise ExerciseError("coordinate_change.map: only linear maps p = J q are supported")
    Jinv = _inverse(J)
    q_of_p = Jinv * (p - (expr - J * m.q))
    change = in_coordinates(m.q, m.dq, m.M, m.dyn.c, m.dyn.g, m.dyn.spring, q_of_p, list(p))
    M_p = m.tidy_matrix(change.M)
    c_p = m.tidy_matrix(change.c)
    g_p = m.tidy_matrix(change.g + change.spring)
    tau_q = J.T * tau
    ctx.step("New coordinates", rf"p = {m.L(expr)} = J q,\quad J = {m.L(J)},\quad q = {m.L(q_of_p)}",
             r"A constant, invertible linear map: $\dot p = J \dot q$ and $\ddot p = J \ddot q$.")
    ctx.step("Generalized forces", rf"\tau_q = J^T \tau_p = {m.L(tau_q)}",
             r"Virtual work: $\tau_q^T \delta q = \tau_p^T \delta p$; each $\tau_{p,i}$ performs work on one $p_i$.")
    ctx.step("Model in the new coordinates", rf"M_p(p) = J^{{-T}} M J^{{-1}} = {m.L(M_p)},\quad c_p = J^{{-T}} c = {m.L(c_p)}",
             r"Substitute $q = J^{-1} p$ and premultiply the equations by $J^{-T}$.")
    ctx.answer("J", J)
    ctx.answer("J_inv", Jinv)
    ctx.answer("q_of_p", q_of_p)
    ctx.answer("M_p", M_p)
    ctx.answer("c_p", c_p)
    ctx.answer("g_p", g_p)
    ctx.answer("tau_q", tau_q)


# ====================================================================== accelerations at a state
@task("accelerations")
def accelerations_task(ctx, spec):
    """q'' = M^-1 (S u - n) at a state (see the module docstring)."""
    m = TaskView(ctx)
    state = m.mapping(spec.get("state"), "accelerations.state", keys="state")
    raw = spec.get("inputs") or {}
    if not isinstance(raw, dict):
        raise ExerciseError("accelerations.inputs: expected a mapping coordinate -> input")
    tau = sp.zeros(len(m.coords), 1)
    for name, val in raw.items():
        i = m.indices([name], "accelerations.inputs")[0]
        if not m.robot.actuated[i]:
            raise ExerciseError(f"accelerations.inputs: {name} is not actuated")
        tau[i] = ctx.expr(val, f"accelerations.inputs.{name}")
    M = m.M.subs(state)
    rhs = (tau - m.n).subs(state)
    ddq = m.tidy_matrix(_inverse(M) * rhs)
    where = ", ".join(f"{m.L(k)} = {m.L(v)}" for k, v in state.items())
    ctx.step("Accelerations", rf"\ddot q = M^{{-1}}(q)\left(\tau - n(q,\dot q)\right) = {m.L(ddq)}",
             f"Forward dynamics at ${where}$." if where else "Forward dynamics at a generic state.", bodies=[b.name for b in m.robot.bodies])
    ctx.answer("ddq", ddq)


# ====================================================================== elastic joints
def _elastic_pairs(m: TaskView):
    """(link index, motor index, springs) for every motor coordinate (one with a rotor inertia)
    tied to one link coordinate by springs whose potential depends on theta - q only: the linear
    spring K (theta - q) and nonlinear ones such as (theta - q)**2 (U = k_n/4 (theta - q)^4)."""
    motors = {m.coords.index(c) for c in m.robot.motor_inertias}
    delta = sp.Dummy("delta")
    pairs: Dict[tuple, list] = {}
    for spring in m.robot.springs:
        if spring.expr is None:
            continue
        e = sp.expand(spring.expr - spring.rest)
        used = [i for i in range(len(m.coords)) if m.q[i] in e.free_symbols]
        mot = [i for i in used if i in motors]
        link = [i for i in used if i not in motors]
        if len(mot) != 1 or len(link) != 1:
            continue
        on_delta = sp.expand(e.subs(m.q[mot[0]], m.q[link[0]] + delta))
        if m.q[link[0]] not in on_delta.free_symbols:
            pairs.setdefault((link[0], mot[0]), []).append((spring, on_delta, delta))
    return [(lk, mt, springs) for (lk, mt), springs in pairs.items()]


def _linear_stiffness(springs) -> sp.Expr:
    """The linear stiffness K of the springs of one joint: the curvature of their potential at
    delta = theta - q = 0 (k for 1/2 k delta^2 or a force law k delta + k3 delta^3, 0 for
    k_n/2 (delta^2)^2)."""
    K = sp.Integer(0)
    for spring, on_delta, delta in springs:
        if sp.Poly(on_delta, delta).degree() == 1:
            K += sp.diff(spring.potential_of_stretch(on_delta), delta, 2).subs(delta, 0)
    return sp.expand(K)


def _motor_reference(ctx, spec, m: TaskView, link, mot, qd, th_d_syms):
    """theta_d solving the link equations at rest, g(q_d) + spring forces = 0: in closed form
    when they are linear in theta (theta_d = q_d + K^-1 g(q_d)); with nonlinear springs the real
    root, chosen at the exercise's numbers (q_d from the task's ``q_d``, else the configuration)."""
    static = m.dyn.g + m.dyn.spring
    at_rest = {m.q[i]: qd[k] for k, i in enumerate(link)}
    at_rest.update({m.q[i]: th_d_syms[k] for k, i in enumerate(mot)})
    eqs = [sp.expand(static[i].subs(at_rest, simultaneous=True)) for i in link]
    linear = all(sp.Poly(e, *th_d_syms).total_degree() <= 1 for e in eqs)
    if linear:
        sol = sp.solve(eqs, th_d_syms, dict=True)
        if len(sol) != 1:
            raise ExerciseError("elastic_joints: the link equations at rest do not fix the motor positions")
        return [sol[0][s] for s in th_d_syms], eqs, False
    values = {p.symbol: p.value for p in m.robot.parameters.values()}
    values.update({k_: v for k_, v in _given_values(ctx).items() if k_.name in m.robot.parameters})
    at = m.mapping(spec.get("q_d"), "elastic_joints.q_d")
    conf = m.mapping(ctx.exercise.configuration, "configuration")
    qd_values = {qd[k]: at.get(m.q[i], conf.get(m.q[i], sp.Float(0.3))) for k, i in enumerate(link)}
    out = []
    for k, e in enumerate(eqs):
        others = [s_ for s_ in th_d_syms if s_ in e.free_symbols and s_ != th_d_syms[k]]
        if others:
            raise ExerciseError("elastic_joints: nonlinear springs coupling several joints at rest are not "
                                "supported (no closed form for theta_d)")
        delta = sp.Dummy("delta")
        on_delta = sp.expand(e.subs(th_d_syms[k], qd[k] + delta))
        real = []
        for r in sp.roots(sp.Poly(on_delta, delta), cubics=True, quartics=True) or sp.solve(on_delta, delta):
            v = complex(sp.N(r.subs(values).subs(qd_values)))
            if abs(v.imag) < 1e-9 * max(1.0, abs(v.real)):
                real.append(r)
        if len(real) != 1:
            raise ExerciseError(f"elastic_joints: the nonlinear spring equation {sp.sstr(e)} = 0 has "
                                f"{len(real)} real solutions for theta_d at the exercise's numbers: "
                                "no unique motor reference")
        out.append(qd[k] + real[0])
    return out, eqs, True


@task("elastic_joints")
def elastic_joints_task(ctx, spec):
    """Elastic-joint robots: link and motor equations, and the motor PD law with constant gravity
    compensation (see the module docstring)."""
    m = TaskView(ctx)
    pairs = _elastic_pairs(m)
    if not pairs:
        raise ExerciseError("elastic_joints: the robot has no elastic joint (a spring on theta - q between "
                            "a motor coordinate with rotor inertia and a link coordinate)")
    link = [p[0] for p in pairs]
    mot = [p[1] for p in pairs]
    qL = sp.Matrix([m.q[i] for i in link])
    th = sp.Matrix([m.q[i] for i in mot])
    dth = sp.Matrix([m.dq[i] for i in mot])
    K = sp.diag(*[_linear_stiffness(p[2]) for p in pairs])
    B = sp.diag(*[m.robot.motor_inertias[m.coords[i]] for i in mot])
    lhs = m.M * m.ddq + m.n
    link_eq = m.tidy_matrix(lhs.extract(link, [0]))
    motor_eq = m.tidy_matrix(lhs.extract(mot, [0]))
    names = [m.coords[i] for i in link]
    qd = sp.Matrix([symbol(f"{c}_d") for c in names])
    th_syms = [sp.Dummy(f"theta_d{k}") for k in range(len(mot))]
    th_sol, rest_eqs, nonlinear = _motor_reference(ctx, spec, m, link, mot, qd, th_syms)
    # a root of a nonlinear spring (cube roots) is no trigonometric polynomial: the law and V are
    # built on placeholders theta_d<i>, replaced by the roots at the end
    theta_d = sp.Matrix(th_syms) if nonlinear else m.tidy_matrix(sp.Matrix(th_sol))
    roots = dict(zip(th_syms, th_sol)) if nonlinear else {}
    # the constant motor torque that holds (q_d, theta_d): the spring force on the motor, equal
    # to the gravity load of its link
    g_d = m.tidy_matrix(m.dyn.g.extract(link, [0]).subs(dict(zip(qL, qd)), simultaneous=True))
    idx = [str(k + 1) for k in range(len(link))]
    kp = sp.diag(*[symbol(f"kp{i}") for i in idx])
    kd = sp.diag(*[symbol(f"kd{i}") for i in idx])
    u = m.tidy_matrix(kp * (theta_d - th) - kd * dth + g_d)
    # V = T + U_g + U_K + 1/2 (theta_d - theta)^T K_P (theta_d - theta) - theta^T g(q_d): its
    # derivative along the closed loop, from the model rows (M q'' = S u - n) without any inverse
    n = len(m.coords)
    Mdot = sp.zeros(n, n)
    for k in range(n):
        Mdot += m.M.diff(m.q[k]) * m.dq[k]
    S = sp.zeros(n, len(mot))
    for k, i in enumerate(mot):
        S[i, k] = 1
    U = sum(m.dyn.potential.values(), sp.Integer(0))
    T = sum(m.dyn.kinetic.values(), sp.Integer(0))
    V = T + U + ((theta_d - th).T * kp * (theta_d - th))[0] / 2 - (th.T * g_d)[0]
    gradU = sp.Matrix([sp.diff(U, qk) for qk in m.q])
    V_dot = (m.dq.T * (S * u - m.n) + m.dq.T * Mdot * m.dq / 2 + gradU.T * m.dq)[0]
    V_dot += (-(dth.T * kp * (theta_d - th)) - dth.T * g_d)[0]
    V_dot = m.tidy(sp.expand(V_dot)).xreplace(roots)
    V = m.tidy(sp.expand(V)).xreplace(roots)
    theta_d, u = theta_d.xreplace(roots), u.xreplace(roots)
    L = lambda x: latex_law_elastic(m, x)
    ctx.step("Link and motor equations",
             rf"M(q)\ddot q + c(q,\dot q) + g(q) + \tau_K(q - \theta) = 0:\ {m.L(link_eq)} = 0,\quad "
             rf"B\ddot\theta + \tau_K(\theta - q) = u:\ {m.L(motor_eq)} = u",
             "Reduced model of elastic joints: the motors drive the links only through the springs.",
             bodies=m.bodies_of(link), joints=m.bodies_of(link))
    if nonlinear:
        rest = sp.Matrix([e.subs(dict(zip(th_syms, th))) for e in rest_eqs])
        ctx.step("Motor reference (nonlinear springs)",
                 rf"{L(rest)} = 0\ \Rightarrow\ \theta = \theta_d = {L(theta_d)}",
                 "At rest the springs must carry the gravity load; with nonlinear springs the deflection "
                 "is the real root of this equation (the only real one at the exercise's numbers).")
    else:
        ctx.step("Motor reference", rf"\theta_d = q_d + K^{{-1}} g(q_d) = {L(theta_d)}",
                 "At the desired rest configuration the springs must carry the gravity load.")
    ctx.step("Motor PD with constant gravity compensation",
             rf"u = K_P(\theta_d - \theta) - K_D\dot\theta + g(q_d) = {L(u)}",
             "Only motor positions and velocities are fed back; with $K$ and $K_P$ large enough with respect "
             r"to the gravity gradient bound, $(q_d, \theta_d)$ is the unique, globally asymptotically "
             "stable equilibrium.")
    ctx.step("Lyapunov function", rf"V = T + U + \tfrac12(\theta_d - \theta)^T K_P(\theta_d - \theta) - \theta^T g(q_d),"
             rf"\quad \dot V = {L(V_dot)} \le 0",
             "The model's energy balance leaves only the motor damping; LaSalle concludes.")
    ctx.answer("K", K)
    ctx.answer("B", B)
    ctx.answer("link_equations", link_eq)
    ctx.answer("motor_equations", motor_eq)
    ctx.answer("theta_d", theta_d)
    ctx.answer("u", u)
    ctx.answer("V", V)
    ctx.answer("V_dot", V_dot)


def latex_law_elastic(m: TaskView, expr) -> str:
    return to_latex(expr, m.coords + [f"{c}_d" for c in m.coords])
