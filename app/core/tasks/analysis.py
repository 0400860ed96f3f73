"""Analysis of a robot's model: gravity balancing, factorizations of the Coriolis
terms, changes of coordinates, Cartesian quantities of a point and numeric evaluations. Everything
is computed from the robot file through app.core.dynamics; an exercise only says what to compute.

Every task accepts ``suffix`` (appended to its answer names, for two uses in one exercise) and
``substitute`` (parameter -> expression, applied to the model first, e.g. ``{alpha: 0}``).

Task kinds (options -> answers):

- ``gravity_balance``: parameter values that make g(q) = 0 for every q. Options: ``solve_for``
  (parameters to choose, e.g. CoM distances), ``zero`` (parameters set to 0 while balancing,
  e.g. a payload). Answers: ``balance`` (values in the order of ``solve_for``),
  ``balance_<name>`` (each value), ``g_balanced`` (g with those values, ``zero`` not applied),
  ``g_zeroed`` (g with the ``zero`` parameters at 0, before balancing).
- ``factorizations``: the Christoffel factorization S and a second one, S', that puts each product
  q'_j q'_k (j <= k) in column k (``alternative: first``: in column j), or S' = S + S0 with a
  given ``plus: S0`` (S0 q' = 0 is checked); whether M' - 2S is skew-symmetric for each. Answers: ``S``,
  ``S_alt``, ``Mdot``, ``Mdot_minus_2S``, ``Mdot_minus_2S_alt``, ``skew_S``, ``skew_S_alt``,
  ``momentum`` (p = M q'), ``ST_dq`` (S^T q', the term of the momentum-based residual).
- ``coordinate_map``: new coordinates theta with q = f(theta) (e.g. relative angles from absolute
  ones). Options: ``map`` (old coordinate -> expression of the new symbols), ``new`` (names of
  the new coordinates, in order), or ``forward`` (new coordinate -> function of q: an expression,
  ``{point, component}`` or ``{angle: body}``; inverted in closed form). Answers: ``T``
  (dq/dtheta), ``q_of_new`` (f), ``J_forward`` (with ``forward``), ``M_new`` (T^T M(f(theta)) T),
  ``g_new`` (T^T g), ``c_new`` (with ``velocity_terms: true``: T^T (c + M T' theta')), ``force_map``
  (T^T: tau_theta = T^T tau_q), ``force_map_inverse`` (T^-T, when T is invertible: tau_q = T^-T
  tau_theta). With fewer new coordinates than old ones (``new``/``map`` only), the map embeds
  holonomic constraints solved for the old coordinates, e.g. the passive tilt of a closed chain as
  a function of the actuated joints: the result is the model on the constraint.
- ``point_kinematics``: a point of the robot (a named point, or ``{body, at}`` whose position may
  hold free symbols such as a contact abscissa). Options: ``point``, ``components`` (default
  [0, 1]: x, y), ``force`` (a force at the point, list of expressions), ``name`` (answer label,
  default the point's name or "point"). Answers: ``p_<name>``, ``J_<name>``, ``det_<name>``
  (square J), ``minors_<name>`` (determinants of J without column k, when J has one column more
  than rows), ``tau_<name>`` (J^T F).
- ``cartesian_inertia``: M_p = J^-T M J^-1 of a point with a square Jacobian, or
  M_p = (J M^-1 J^T)^-1 at ``at`` for a redundant task (fewer components than coordinates). Options:
  ``point``, ``components``, ``at`` (configuration for the numeric values, parameters from
  ``given``). Answers: ``J``, ``det_J`` and ``M_p`` (square J), ``J_at``, ``M_at``, ``M_p_at``,
  ``M_p_inv_at``, ``M_p_eig_at`` (eigenvalues, largest first).
- ``rest_acceleration``: accelerations from rest, q'' = M^-1 (u - g), and of a point, p'' = J q''.
  Options: ``inputs`` (names of the generalized forces, one per coordinate; default tau1..tauN),
  ``point`` (optional), ``components``. Answers: ``ddq_rest``, ``pdd_rest``, ``pdd_rest_norm2``.
- ``gravity_gradient_bound``: alpha = max over q of ||dg/dq|| (spectral norm), written as a
  parameter factor times the maximum of the rest at the parameters' numbers. Options:
  ``use_balance`` (apply the values of a preceding ``gravity_balance``), ``kp_min`` (a gain, to
  find the largest value of ``solve_for`` with alpha < kp_min). Answers: ``dg_dq``, ``alpha``,
  ``alpha_at`` (a maximizing configuration), ``<solve_for>_max``.
- ``evaluate``: numbers at a state, parameters from ``given``. Options: ``at`` (coordinate ->
  value), ``velocity`` (coordinate -> value), ``acceleration`` (coordinate -> value). Answers:
  ``M_at``, ``M_inv_at``, ``g_at``, ``c_at``, ``tau_at`` (M q'' + c + g + k + friction, when ``acceleration``
  is given), ``T_at`` (kinetic energy).
- ``kinetic_energy_decay``: the torque tau = -(gamma/2) M(q) q' that gives T' = q'^T tau = -gamma T
  without potential forces. Options: ``gamma`` (a number or a symbol, default ``gamma_``), ``at``,
  ``velocity``.
  Answers: ``tau_decay``, ``tau_decay_at``.
"""
from __future__ import annotations

import itertools
import math
from typing import List, Tuple

import numpy as np
import sympy as sp

from ..coordinates import in_coordinates
from ..exercise import ExerciseError
from ..expressions import symbol
from ..mathtext import symbols_text
from ..numeric import numeric_function
from ..steps import to_latex
from ..trig import TrigPoly
from . import task
from .context import TaskView, is_zero, tidy_cancelled


# ====================================================================== gravity balancing
def _coefficient_conditions(vector, variables) -> List[sp.Expr]:
    """Every coefficient (of each trigonometric function and each monomial of ``variables``) of the
    entries of a vector; they all vanish exactly when the vector is zero for every q."""
    conds = []
    for e in vector:
        tp = TrigPoly.from_expr(sp.expand(e)).expand()
        for coeff in tp.terms.values():
            poly = sp.Poly(coeff, *variables) if variables else None
            for c in (poly.coeffs() if poly is not None else [coeff]):
                c = sp.factor(c)
                if c != 0 and c not in conds:
                    conds.append(c)
    return conds


@task("gravity_balance")
def gravity_balance_task(ctx, spec):
    """Parameters that cancel gravity for every configuration (see the module docstring)."""
    a = TaskView(ctx, spec, "gravity_balance")
    names = spec.get("solve_for")
    if not isinstance(names, list) or not names:
        raise a.fail("solve_for", "expected a list of parameters to choose (e.g. CoM distances)")
    for n in names:
        if n not in a.robot.parameters:
            raise a.fail("solve_for", f"'{n}' is not a parameter of {a.robot.name}")
    unknowns = [symbol(n) for n in names]
    zero = {symbol(str(n)): 0 for n in (spec.get("zero") or [])}
    for s in zero:
        if s.name not in a.robot.parameters:
            raise a.fail("zero", f"'{s.name}' is not a parameter of {a.robot.name}")
    g = a.g.subs(zero) if zero else a.g
    conds = _coefficient_conditions(g, list(a.q))
    a.ctx.step("Gravity as a combination of functions of q",
               rf"g(q) = {a.L(g)}" + (rf"\quad ({', '.join(a.L(s) + ' = 0' for s in zero)})" if zero else ""),
               "$g(q)$ vanishes for every $q$ exactly when every coefficient of each independent function of q vanishes.",
               bodies=[b.name for b in a.robot.bodies])
    a.ctx.step("Balancing conditions", r"\begin{cases}" + r"\\ ".join(f"{a.L(c)} = 0" for c in conds) + r"\end{cases}",
               f"Solve them for {symbols_text(names)}.")
    sols = sp.solve(conds, unknowns, dict=True)
    if not sols:
        raise ExerciseError(f"{a.where('solve_for')}: gravity cannot be balanced by choosing {', '.join(names)}")
    sol = sols[0]
    free = [s.name for s in unknowns if s not in sol]
    if free:
        raise ExerciseError(f"{a.where('solve_for')}: the conditions do not fix {', '.join(free)}")
    values = [sp.factor(sol[s]) for s in unknowns]
    a.ctx.step("Balanced parameters", r",\quad ".join(f"{a.L(s)} = {a.L(v)}" for s, v in zip(unknowns, values)),
               "Negative CoM distances mean counter-masses beyond the joint axis.",
               bodies=[b.name for b in a.robot.bodies])
    g_bal = a.tidy_cancelled_matrix(a.g.subs(dict(zip(unknowns, values))))
    if zero:
        a.answer("g_zeroed", a.tidy_cancelled_matrix(g))
    if zero:
        a.ctx.step("Gravity of the balanced robot", rf"g(q) = {a.L(g_bal)}",
                   "What remains once the links are balanced: only the terms of "
                   + symbols_text(s.name for s in zero) + ".")
    a.answer("balance", sp.Matrix(values))
    for s, v in zip(unknowns, values):
        a.answer(f"balance_{s.name}", v)
    a.answer("g_balanced", g_bal)
    ctx.balance = dict(zip(unknowns, values))


# ====================================================================== factorizations
@task("factorizations")
def factorizations_task(ctx, spec):
    """Christoffel and non-skew factorizations of c(q, q') (see the module docstring)."""
    a = TaskView(ctx, spec, "factorizations")
    n = len(a.coords)
    Ck = [a.apply(Ci) for Ci in a.dyn.christoffel]
    S = a.tidy_cancelled_matrix(a.C)
    S_alt, how = _other_factorization(a, Ck, S)
    Mdot = a.tidy_cancelled_matrix(sum((a.M.diff(a.q[k]) * a.dq[k] for k in range(n)), sp.zeros(n, n)))
    N1 = a.tidy_cancelled_matrix(Mdot - 2 * S)
    N2 = a.tidy_cancelled_matrix(Mdot - 2 * S_alt)
    skew1 = all(is_zero(N1[i, j] + N1[j, i]) for i in range(n) for j in range(i, n))
    skew2 = all(is_zero(N2[i, j] + N2[j, i]) for i in range(n) for j in range(i, n))
    assert all(is_zero(e) for e in S_alt * a.dq - a.c), "internal error: S' q' != c"
    p = a.tidy_cancelled_matrix(a.M * a.dq)
    ST = a.tidy_cancelled_matrix(S.T * a.dq)
    bodies = [b.name for b in a.robot.bodies]
    a.ctx.step("Christoffel factorization", rf"S(q,\dot q) = \begin{{pmatrix}} \dot q^T C_1 \\ \vdots \\ \dot q^T C_n \end{{pmatrix}} = {a.L(S)}",
               r"Row $i$ is $\dot q^T C_i$ with the Christoffel matrices $C_i$.", bodies=bodies)
    a.ctx.step("Skew-symmetry check", rf"\dot M - 2S = {a.L(N1)}",
               r"Skew-symmetric: $\dot q^T (\dot M - 2S)\, \dot q = 0$, the property used by passivity-based laws." if skew1
               else "Not skew-symmetric.")
    a.ctx.step("Another factorization", rf"S'(q,\dot q) = {a.L(S_alt)},\quad S'\dot q = c(q,\dot q)", how)
    a.ctx.step("Skew-symmetry check of $S'$", rf"\dot M - 2S' = {a.L(N2)}",
               "Also skew-symmetric (here the two factorizations give the same property)." if skew2
               else r"Not skew-symmetric: $S'$ also gives $c = S' \dot q$, but $\dot M - 2S'$ is not skew.")
    a.ctx.step("Generalized momentum", rf"p = M(q)\dot q = {a.L(p)},\quad S^T(q,\dot q)\dot q = {a.L(ST)}",
               r"The momentum-based residual uses $\dot p = \tau + S^T \dot q - g - \tau_f$: no accelerations needed.",
               bodies=bodies)
    a.answer("S", S)
    a.answer("S_alt", S_alt)
    a.answer("Mdot", Mdot)
    a.answer("Mdot_minus_2S", N1)
    a.answer("Mdot_minus_2S_alt", N2)
    a.answer("skew_S", skew1)
    a.answer("skew_S_alt", skew2)
    a.answer("momentum", p)
    a.answer("ST_dq", ST)


def _other_factorization(a: TaskView, Ck, S):
    """A second factorization c = S' q' and how it was built: each product q'_j q'_k (j <= k) of
    c_i in column k (``alternative: last``, default) or in column j (``first``), or S' = S + S0 with
    a given S0(q') such that S0 q' = 0 (``plus``)."""
    n = len(a.coords)
    if a.spec.get("plus") is not None:
        raw = a.spec["plus"]
        if not isinstance(raw, list) or len(raw) != n or any(not isinstance(r, list) or len(r) != n for r in raw):
            raise a.fail("plus", f"expected a {n}x{n} matrix of expressions of the velocities")
        S0 = sp.Matrix([[a.expr(e, "plus") for e in row] for row in raw])
        if not all(is_zero(e) for e in S0 * a.dq):
            raise a.fail("plus", "S0 q' must vanish for every q' (otherwise S + S0 no longer factorizes c)")
        return a.tidy_cancelled_matrix(S + S0), (rf"$S' = S + S_0$ with $S_0 = {a.L(S0)}$: $S_0 \dot q = 0$, so $S' \dot q = c$ as well.")
    first = {"first": True, "last": False}.get(a.spec.get("alternative", "last"))
    if first is None:
        raise a.fail("alternative", "expected 'first' or 'last' (the column of each product q'_j q'_k)")
    S_alt = sp.zeros(n, n)
    for i in range(n):
        for j in range(n):
            for k in range(j, n):
                coeff = (2 if j < k else 1) * Ck[i][j, k]
                if first:
                    S_alt[i, j] += coeff * a.dq[k]
                else:
                    S_alt[i, k] += coeff * a.dq[j]
    col = "j" if first else "k"
    return a.tidy_cancelled_matrix(S_alt), (r"Each product $\dot q_j \dot q_k$ ($j \le k$) of $c_i$ is written as its coefficient "
                                  f"times the other velocity, in column ${col}$.")


# ====================================================================== changes of coordinates
@task("coordinate_map")
def coordinate_map_task(ctx, spec):
    """Model in new coordinates theta with q = f(theta) (see the module docstring)."""
    a = TaskView(ctx, spec, "coordinate_map")
    if spec.get("forward") is not None:
        new, f = _invert_forward_map(a)
    else:
        new = spec.get("new")
        if not isinstance(new, list) or not 0 < len(new) <= len(a.coords) or not all(isinstance(x, str) and x.isidentifier() for x in new):
            raise a.fail("new", f"expected a list of at most {len(a.coords)} new coordinate names")
        raw = spec.get("map")
        if not isinstance(raw, dict) or set(map(str, raw)) != set(a.coords):
            raise a.fail("map", f"expected one expression of the new coordinates for each of {', '.join(a.coords)}")
        f = sp.Matrix([a.expr(raw[c], f"map.{c}") for c in a.coords])
    theta = [symbol(x) for x in new]
    stray = set().union(*[e.free_symbols for e in f]) & (set(a.q) - set(theta))
    if stray:
        raise a.fail("map", f"the expressions must use the new coordinates, not {sorted(s.name for s in stray)}")
    try:
        change = in_coordinates(a.q, a.dyn.dq, a.M, a.c, a.g, a.k, f, theta)
    except ValueError as exc:
        raise a.fail("map", str(exc)) from None
    T = change.T
    M_new = a.tidy_cancelled_matrix(change.M).applyfunc(lambda e: _partial_fractions(e, theta))
    g_new = a.tidy_cancelled_matrix(change.g)
    c_new = a.tidy_cancelled_matrix(change.c) if spec.get("velocity_terms") else None
    th = sp.Matrix(theta)
    a.ctx.step("Change of coordinates", rf"q = f(\theta) = {a.L(f)},\quad T = \frac{{\partial f}}{{\partial \theta}} = {a.L(T)}",
               r"Velocities map as $\dot q = T \dot\theta$; the kinetic energy keeps its value.")
    a.ctx.step("Inertia matrix in the new coordinates", rf"M_\theta(\theta) = T^T M(f(\theta))\, T = {to_latex(M_new, new)}",
               r"From $T = \frac{1}{2} \dot\theta^T (T^T M T)\, \dot\theta$.", bodies=[b.name for b in a.robot.bodies])
    a.ctx.step("Forces in the new coordinates", rf"\tau_\theta = T^T \tau_q,\quad T^T = {a.L(T.T)},\quad g_\theta = {to_latex(g_new, new)}",
               r"Virtual work: $\tau_\theta^T \dot\theta = \tau_q^T \dot q$.")
    if c_new is not None:
        a.ctx.step("Velocity terms in the new coordinates",
                   rf"c_\theta = T^T\left(c(f, T\dot\theta) + M \dot T \dot\theta\right) = {to_latex(c_new, new)}",
                   r"From $\ddot q = T \ddot\theta + \dot T \dot\theta$ substituted in the old model, premultiplied by $T^T$.")
        a.answer("c_new", c_new)
    a.answer("T", T)
    a.answer("q_of_new", f)
    a.answer("M_new", M_new)
    a.answer("g_new", g_new)
    a.answer("force_map", T.T)
    if T.rows == T.cols and not is_zero(a.tidy_cancelled(T.det())):
        inv = a.tidy_cancelled_matrix(T.T.inv())
        a.ctx.step("Forces on the old coordinates", rf"\tau_q = T^{{-T}} \tau_\theta = {a.L(inv)}\,\tau_\theta",
                   "Inverting the virtual-work relation ($T$ is invertible).")
        a.answer("force_map_inverse", inv)


def _partial_fractions(entry, coordinates):
    """A rational entry whose denominator depends on the coordinates, as partial fractions in the
    first of them (constant terms apart, as a textbook writes m1 + m3/4 + Iy b(q)); others unchanged.

    >>> q1, q2, a, b = sp.symbols("q1 q2 a b")
    >>> _partial_fractions((a*(q1**2 + 1) + b)/(q1**2 + 1), [q1, q2])
    a + b/(q1**2 + 1)
    """
    den = sp.fraction(sp.together(entry))[1]
    var = next((c for c in coordinates if den.has(c)), None)
    if var is None or not entry.is_rational_function(*coordinates):
        return entry
    return sp.apart(sp.cancel(entry), var)


def _forward_entry(a: TaskView, name: str, raw) -> sp.Expr:
    """A new coordinate as a function of q: an expression, ``{point, component}`` (x, y or z of a
    named point) or ``{angle: body}`` (the orientation of a link of a planar robot)."""
    from ..jacobians import planar_angle
    where = f"forward.{name}"
    if isinstance(raw, dict) and "angle" in raw:
        if raw["angle"] not in [b.name for b in a.robot.bodies]:
            raise a.fail(where, f"unknown body '{raw['angle']}'")
        return planar_angle(a.robot, raw["angle"])
    if isinstance(raw, dict) and "point" in raw:
        pt = a.robot.points.get(raw["point"])
        comp = {"x": 0, "y": 1, "z": 2}.get(raw.get("component"))
        if pt is None or comp is None:
            raise a.fail(where, "expected {point: NAME, component: x|y|z} with a named point of the robot")
        return a.tidy_cancelled(a.kin.point_position(pt.body, pt.position)[comp])
    return a.expr(raw, where)


def _invert_forward_map(a: TaskView):
    """New coordinates given as functions of q (``forward``): their names, and q as functions of them
    (solved in closed form; one solution is required)."""
    raw = a.spec["forward"]
    if not isinstance(raw, dict) or len(raw) != len(a.coords) or not all(str(k).isidentifier() for k in raw):
        raise a.fail("forward", f"expected {len(a.coords)} new coordinates, each name: function of q")
    new = [str(k) for k in raw]
    h = [_forward_entry(a, k, v) for k, v in raw.items()]
    try:
        sols = sp.solve([symbol(k) - e for k, e in zip(new, h)], list(a.q), dict=True)
    except NotImplementedError:
        sols = []
    if len(sols) != 1 or set(sols[0]) != set(a.q):
        raise a.fail("forward", f"cannot invert the map in closed form ({len(sols)} solution(s)): give q as "
                     "functions of the new coordinates with new/map")
    f = sp.Matrix([a.tidy_cancelled(sols[0][qk]) for qk in a.q])
    Jf = sp.Matrix(h).jacobian(a.q)
    a.ctx.step("New coordinates", rf"{to_latex(sp.Matrix([symbol(k) for k in new]), new)} = {a.L(sp.Matrix(h))},\quad "
               rf"J = \frac{{\partial h}}{{\partial q}} = {a.L(a.tidy_cancelled_matrix(Jf))}",
               "Solved for $q$ below (closed form); $J$ is invertible where the new coordinates are valid.")
    a.answer("J_forward", a.tidy_cancelled_matrix(Jf))
    return new, f


# ====================================================================== points
def _point_data(a: TaskView):
    body, local, label = a.point()
    label = str(a.spec.get("name", label))
    comp = a.components()
    p3 = a.kin.point_position(body, local)
    p = sp.Matrix([a.tidy_cancelled(p3[c]) for c in comp])
    J = sp.Matrix([[a.tidy_cancelled(sp.diff(p3[c], qk)) for qk in a.q] for c in comp])
    return body, label, p, J


@task("point_kinematics")
def point_kinematics_task(ctx, spec):
    """Position, Jacobian and generalized force of a point (see the module docstring)."""
    a = TaskView(ctx, spec, "point_kinematics")
    body, label, p, J = _point_data(a)
    bodies = [body] if body else []
    a.ctx.step(f"Position of {label}", rf"p_{{{label}}} = {a.L(p)}", "Forward kinematics of the point.", bodies=bodies)
    a.ctx.step(f"Jacobian of {label}", rf"J_{{{label}}} = \frac{{\partial p}}{{\partial q}} = {a.L(J)}",
               r"$\dot p = J \dot q$.", bodies=bodies)
    a.answer(f"p_{label}", p)
    a.answer(f"J_{label}", J)
    if J.cols == J.rows:
        det = a.tidy_cancelled(J.det())
        a.ctx.step("Determinant of the Jacobian", rf"\det J_{{{label}}} = {a.L(det)}",
                   "J is singular where it vanishes.", bodies=bodies)
        a.answer(f"det_{label}", det)
    if J.cols == J.rows + 1:
        minors = sp.Matrix([a.tidy_cancelled(J[:, [j for j in range(J.cols) if j != k]].det()) for k in range(J.cols)])
        a.ctx.step("Minors of the Jacobian", r",\quad ".join(rf"\det J_{{-{k + 1}}} = {a.L(m)}" for k, m in enumerate(minors)),
                   "J loses rank exactly where all these minors vanish together.")
        a.answer(f"minors_{label}", minors)
    if spec.get("force") is not None:
        force = spec["force"]
        if not isinstance(force, list) or len(force) != J.rows:
            raise a.fail("force", f"expected a list of {J.rows} expressions (one per component)")
        F = sp.Matrix([a.expr(v, "force") for v in force])
        tau = a.tidy_cancelled_matrix(J.T * F)
        a.ctx.step(f"Generalized force of a force at {label}", rf"\tau = J^T F = {a.L(J.T)} {a.L(F)} = {a.L(tau)}",
                   "Virtual work of the force on the point, one component per coordinate.",
                   bodies=bodies)
        a.answer(f"tau_{label}", tau)


@task("cartesian_inertia")
def cartesian_inertia_task(ctx, spec):
    """Cartesian inertia of a point, M_p = J^-T M J^-1 (see the module docstring)."""
    a = TaskView(ctx, spec, "cartesian_inertia")
    body, label, p, J = _point_data(a)
    if J.rows > J.cols:
        raise a.fail("components", f"the Jacobian is {J.rows}x{J.cols}: more task components than coordinates")
    a.answer("J", J)
    if J.rows == J.cols:
        det = a.tidy_cancelled(J.det())
        Jinv = J.inv()
        Mp = sp.Matrix(J.rows, J.cols, lambda i, j: sp.factor(sp.cancel(sp.together((Jinv.T * a.M * Jinv)[i, j]))))
        Mp = a.tidy_cancelled_matrix(Mp)
        a.ctx.step(f"Jacobian of {label}", rf"p = {a.L(p)},\quad J = {a.L(J)},\quad \det J = {a.L(det)}",
                   r"$M_p$ exists away from the singularities $\det J = 0$.", bodies=[body] if body else [])
        a.ctx.step("Cartesian inertia", rf"M_p(q) = J^{{-T}} M J^{{-1}} = {a.L(Mp)}",
                   r"Kinetic energy in task coordinates: $T = \frac{1}{2} \dot p^T M_p \dot p$.", bodies=[b.name for b in a.robot.bodies])
        a.answer("det_J", det)
        a.answer("M_p", Mp)
    else:
        a.ctx.step(f"Jacobian of {label}", rf"p = {a.L(p)},\quad J = {a.L(J)}",
                   r"A redundant task: $M_p = (J M^{-1} J^T)^{-1}$, the inertia felt at the point when the joints move "
                   "with the dynamically consistent inverse (it exists where $J$ has full row rank).",
                   bodies=[body] if body else [])
    at = a.coordinate_values("at")
    if at:
        values = {**a.parameter_values(), **at}
        missing = set(a.q) - set(at)
        if missing:
            raise a.fail("at", f"give every coordinate (missing {sorted(s.name for s in missing)})")
        Mv = np.array(a.M.subs(values), dtype=float)
        Jv = np.array(J.subs(values), dtype=float)
        Mp_inv = Jv @ np.linalg.solve(Mv, Jv.T)
        if np.linalg.matrix_rank(Mp_inv) < Jv.shape[0]:
            raise a.fail("at", "the Jacobian loses rank there: no Cartesian inertia")
        Mpv = np.linalg.inv(Mp_inv)
        eig = np.sort(np.linalg.eigvalsh((Mpv + Mpv.T) / 2))[::-1]
        a.ctx.step("At the given configuration",
                   rf"J(q^*) = {a.L(sp.Matrix(np.round(Jv, 6)))},\quad M(q^*) = {a.L(sp.Matrix(np.round(Mv, 6)))},\quad "
                   rf"M_p(q^*) = (J M^{{-1}} J^T)^{{-1}} = {a.L(sp.Matrix(np.round(Mpv, 6)))},\quad "
                   rf"\lambda(M_p) = {a.L(sp.Matrix(np.round(eig, 4)).T)}",
                   r"With the exercise's numbers; a force $F$ at rest gives $\ddot p = M_p^{-1} F$.")
        a.answer("J_at", Jv)
        a.answer("M_at", Mv)
        a.answer("M_p_at", Mpv)
        a.answer("M_p_inv_at", Mp_inv)
        a.answer("M_p_eig_at", eig)


@task("rest_acceleration")
def rest_acceleration_task(ctx, spec):
    """Joint and point accelerations from rest (see the module docstring)."""
    a = TaskView(ctx, spec, "rest_acceleration")
    n = len(a.coords)
    names = spec.get("inputs") or [f"tau{i + 1}" for i in range(n)]
    if not isinstance(names, list) or len(names) != n:
        raise a.fail("inputs", f"expected {n} names of generalized forces")
    u = sp.Matrix([a.expr(x, "inputs") for x in names])
    rhs = u - a.g - a.k
    ddq = a.tidy_cancelled_matrix(a.M.LUsolve(rhs))
    a.ctx.step("Accelerations from rest", rf"\ddot q_0 = M^{{-1}}(q)\,(u - g(q)) = {a.L(ddq)}",
               r"With $\dot q = 0$ the velocity terms vanish.", bodies=[b.name for b in a.robot.bodies])
    a.answer("ddq_rest", ddq)
    if spec.get("point") is not None:
        body, label, p, J = _point_data(a)
        pdd = a.tidy_cancelled_matrix(J * ddq)
        norm2 = a.tidy_cancelled((pdd.T * pdd)[0])
        a.ctx.step(f"Acceleration of {label}", rf"\ddot p_0 = J(q)\,\ddot q_0 = {a.L(pdd)}",
                   r"The term $\dot J(q)\, \dot q$ vanishes at rest.", bodies=[body] if body else [])
        a.ctx.step("Its squared norm", rf"\|\ddot p_0\|^2 = {a.L(norm2)}", "")
        a.answer("pdd_rest", pdd)
        a.answer("pdd_rest_norm2", norm2)


# ====================================================================== gravity gradient
def _common_factor(entries, variables) -> sp.Expr:
    """The product of the factors free of ``variables`` shared by all nonzero entries.

    >>> x, m, g = symbol("x"), symbol("m"), symbol("g")
    >>> _common_factor([-2*g*m*sp.cos(x), g*m**2*sp.sin(x)], [x])
    g*m
    """
    common = None
    for e in entries:
        if e == 0:
            continue
        factors = {}
        for f in sp.Mul.make_args(sp.factor(e)):
            if f.is_number or f.free_symbols & set(variables):
                continue
            base, exp = (f.base, f.exp) if f.is_Pow and f.exp.is_Integer else (f, 1)
            factors[base] = factors.get(base, 0) + exp
        if common is None:
            common = factors
        else:
            common = {b: min(x, factors[b]) for b, x in common.items() if b in factors}
    if not common:
        return sp.Integer(1)
    return sp.Mul(*[b ** x for b, x in common.items()])


def _max_spectral_norm(f, lows, highs, seed: int = 0) -> Tuple[float, np.ndarray]:
    """Maximum of ||f(q)||_2 over a box (grid and random starts, then local refinement)."""
    from scipy.optimize import minimize
    m = len(lows)
    if m == 0:
        return float(np.linalg.norm(f(np.zeros(0)), 2)), np.zeros(0)
    per = max(3, int(round(20000 ** (1.0 / m))))
    axes = [np.linspace(lo, hi, per) for lo, hi in zip(lows, highs)]
    best, best_q = -1.0, None
    for point in itertools.product(*axes):
        val = np.linalg.norm(f(np.array(point)), 2)
        if val > best:
            best, best_q = val, np.array(point)
    res = minimize(lambda x: -np.linalg.norm(f(x), 2), best_q, bounds=list(zip(lows, highs)), method="L-BFGS-B")
    if -res.fun > best:
        best, best_q = -res.fun, res.x
    return float(best), best_q


@task("gravity_gradient_bound")
def gravity_gradient_bound_task(ctx, spec):
    """alpha = max ||dg/dq|| and the gain it requires (see the module docstring)."""
    a = TaskView(ctx, spec, "gravity_gradient_bound")
    g = a.g
    if spec.get("use_balance"):
        bal = getattr(ctx, "balance", None)
        if not bal:
            raise a.fail("use_balance", "needs a preceding gravity_balance task")
        g = g.subs(bal)
    dg = a.tidy_cancelled_matrix(g.jacobian(a.q))
    k = _common_factor(list(dg), list(a.q))
    B = dg.applyfunc(lambda e: sp.cancel(e / k))
    values = a.parameter_values()
    Bn = B.subs(values)
    qs = sorted(set().union(*[e.free_symbols for e in Bn]) & set(a.q), key=list(a.q).index)
    lows, highs = [], []
    for s in qs:
        lim = a.robot.limits.get(s.name)
        if s in a.angle_coordinates():
            lows.append(-math.pi)
            highs.append(math.pi)
        elif lim is not None and lim.position is not None:
            lows.append(lim.position[0])
            highs.append(lim.position[1])
        else:
            raise a.fail("", f"dg/dq grows without bound with {s.name}: give it position limits")
    fB = numeric_function([qs], Bn, "numpy")
    peak, q_star = _max_spectral_norm(lambda x: np.array(fB(list(x)), dtype=float), lows, highs)
    near = sp.nsimplify(peak, tolerance=1e-10, rational=False)
    peak_expr = near if (near.is_Rational and abs(float(near) - peak) < 1e-10) else sp.Float(peak, 15)
    alpha = _positive(k) * peak_expr
    a.ctx.step("Gradient of gravity", rf"\frac{{\partial g}}{{\partial q}} = {a.L(dg)}",
               "Its norm bounds how fast $g$ changes between two configurations.",
               bodies=[b.name for b in a.robot.bodies])
    a.ctx.step("Its largest norm", rf"\alpha = \max_q \left\|\frac{{\partial g}}{{\partial q}}\right\| = {a.L(alpha)}",
               rf"Spectral norm of $\partial g/\partial q$ divided by ${to_latex(k)}$, maximised over the configurations "
               "with the exercise's numbers; PD control with a constant gravity compensation $g(q_d)$ is globally "
               r"asymptotically stable when the smallest proportional gain exceeds $\alpha$.")
    a.answer("dg_dq", dg)
    a.answer("alpha", alpha)
    a.answer("alpha_at", sp.Matrix([float(x) for x in q_star]) if len(q_star) else sp.zeros(0, 1))
    if spec.get("kp_min") is not None:
        kp = a.constant(spec["kp_min"], "kp_min")
        name = spec.get("solve_for")
        if not name or name not in a.robot.parameters:
            raise a.fail("solve_for", "give the parameter to bound (a parameter of the robot)")
        s = symbol(name)
        others = {k2: v for k2, v in values.items() if k2 != s}
        sols = [r for r in sp.solve(sp.Eq(alpha.subs(others), kp), s) if r.is_real and r > 0]
        if not sols:
            raise a.fail("solve_for", f"alpha does not reach {kp:g} for any positive {name}")
        bound = float(min(sols))
        a.ctx.step(f"Largest ${a.L(s)}$", rf"\alpha({a.L(s)}) < {kp:g} \;\Leftrightarrow\; {a.L(s)} < {bound:.4f}",
                   r"The condition $K_{P,\min} > \alpha$, solved for the parameter.")
        a.answer(f"{name}_max", bound)


def _positive(k):
    """|k| for a product of (positive) physical parameters: drop a leading minus sign."""
    c, rest = sp.factor(k).as_coeff_Mul()
    return abs(c) * rest


# ====================================================================== numbers at a state
@task("evaluate")
def evaluate_task(ctx, spec):
    """Numeric model terms at a state (see the module docstring)."""
    a = TaskView(ctx, spec, "evaluate")
    q = a.coordinate_values("at")
    if set(q) != set(a.q):
        raise a.fail("at", f"give every coordinate ({', '.join(a.coords)})")
    dq = a.coordinate_values("velocity", prefix="d")
    values = {**a.parameter_values(), **q, **{s: 0.0 for s in a.dq}, **dq}
    num = lambda m: np.array(sp.Matrix(m).subs(values).evalf(), dtype=float)
    M, g, c = num(a.M), num(a.g + a.k), num(a.c)
    a.ctx.step("Model at the state", rf"M = {a.L(sp.Matrix(np.round(M, 6)))},\quad g = {a.L(sp.Matrix(np.round(g, 6)))},"
               rf"\quad c = {a.L(sp.Matrix(np.round(c, 6)))}", "With the exercise's numbers.",
               bodies=[b.name for b in a.robot.bodies])
    a.answer("M_at", M)
    a.answer("M_inv_at", np.linalg.inv(M))
    a.answer("g_at", g.reshape(-1))
    a.answer("c_at", c.reshape(-1))
    dqv = np.array([values[s] for s in a.dq], dtype=float)
    a.answer("T_at", float(dqv @ M @ dqv / 2))
    if spec.get("acceleration") is not None:
        ddq = a.coordinate_values("acceleration", prefix="dd")
        ddqv = np.array([ddq.get(s, 0.0) for s in a.ddq])
        fr = num(a.apply(a.dyn.friction)).reshape(-1)
        tau = M @ ddqv + c.reshape(-1) + g.reshape(-1) + fr
        a.ctx.step("Torques", rf"\tau = M\ddot q + c + g = {a.L(sp.Matrix(np.round(tau, 6)))}", "Inverse dynamics.")
        a.answer("tau_at", tau)


@task("kinetic_energy_decay")
def kinetic_energy_decay_task(ctx, spec):
    """The torque that makes the kinetic energy decay exponentially (see the module docstring)."""
    a = TaskView(ctx, spec, "kinetic_energy_decay")
    gamma = a.expr(spec.get("gamma", "gamma_"), "gamma")
    tau = a.tidy_cancelled_matrix(-gamma / 2 * a.M * a.dq)
    a.ctx.step("Power balance", r"\dot T = \dot q^T \tau \;(\text{no potential forces}),\quad "
               r"-\gamma T = -\tfrac{\gamma}{2}\dot q^T M(q)\dot q",
               "The kinetic energy changes only through the power of the torques.")
    a.ctx.step("A torque that achieves it", rf"\tau = -\frac{{\gamma}}{{2}} M(q)\dot q = {a.L(tau)}",
               r"One solution of $\dot q^T \tau = -\gamma T$ (any torque orthogonal to $\dot q$ may be added).",
               bodies=[b.name for b in a.robot.bodies])
    a.answer("tau_decay", tau)
    q = a.coordinate_values("at")
    if q:
        dq = a.coordinate_values("velocity", prefix="d")
        values = {**a.parameter_values(), **q, **{s: 0.0 for s in a.dq}, **dq}
        tv = np.array(tau.subs(values).evalf(), dtype=float).reshape(-1)
        a.ctx.step("At the initial state", rf"\tau(0) = {a.L(sp.Matrix(np.round(tv, 4)))}", "With the exercise's numbers [N m].")
        a.answer("tau_decay_at", tv)
