"""Model-based control laws: linear parametrization in given coefficients, the Slotine-Li adaptive
law with its update law, computed torque, the nominal torque along a trajectory and regulation
laws. Everything is computed from the robot's model (app.core.dynamics.derive).

Symbols of the laws: e_i = q_i,d - q_i (``e1``), its derivative ``de1``, desired ``q1_d``,
``dq1_d``, ``ddq1_d``, reference ``dq1_r``, ``ddq1_r``, diagonal gains ``kp1``, ``kd1``,
``gamma1``, ``lambda1``, estimates ``ahat1``; time ``t``.

Task kinds (options -> answers):

- ``parametrization``: tau = Y a in coefficients chosen by the exercise (e.g. those of the printed
  solution). Options: ``coefficients`` (list of expressions of the robot's parameters; default:
  the engine's minimal set), ``known`` (parameters treated as known; default: lengths, gravity,
  angles), ``terms`` (which parts of the model: any of inertia, coriolis, gravity, spring,
  friction; default all), ``input_gain`` (a parameter or symbol k with tau = k u: the model is
  divided by k), ``suffix`` (appended to the answer names). Answers: ``Y``, ``Y_r`` (Slotine-Li
  regressor, q'' -> q''_r and C q' -> C q'_r), ``a``, ``regressor_count``, ``minimal_count`` (the
  smallest possible number for these terms), ``tau_known`` (terms that depend on no unknown
  parameter, if any).
- ``adaptive_law``: u = Y_r a_hat (+ the known part) + K_P e + K_D e', a_hat' = Gamma Y_r^T (q'_r - q').
  Options: those of ``parametrization`` and ``estimate`` (1-based indices of the coefficients that
  are adapted; default all), ``known_terms`` (model terms outside ``terms`` that are known and
  computed on the reference motion, e.g. [inertia, coriolis] when only gravity is adapted),
  ``lambda`` (``"KP/KD"``, the default, or ``"free"``). Answers:
  ``u``, ``update``, ``dq_r``, ``ddq_r``, ``Y_r``, ``a``, ``dimension``, ``V_dot`` (the Lyapunov
  derivative with Lambda = K_D^-1 K_P).
- ``computed_torque``: ``form`` feedback_linearization (default: u = M (q''_d + K_D e' + K_P e) + n)
  or passivity (u = M q''_d + C q'_d + g + k + F_v q'_d + K_P e + K_D e'); ``name`` (default u).
  Answers: ``<name>``.
- ``desired_torque``: nominal input along q_d(t). Options: ``trajectory`` (coordinate ->
  expression of t, or a rest-to-rest motion ``{start, delta, duration, profile: cubic|quintic}``),
  ``at`` (an instant t), ``substitute`` (parameter -> value applied to the model first, e.g.
  ``{g0: 0}`` for a horizontal plane). Answers: ``q_d``, ``dq_d``, ``ddq_d``, ``tau_d``, and at ``at``:
  ``q_d_at``, ``dq_d_at``, ``ddq_d_at``, ``tau_d_at`` (numbers, parameters from ``given``) and
  the same names with ``_expr`` (symbolic).
- ``regulation``: laws for a constant q_d. Answers: ``u_pd_gravity`` (PD + g(q)), ``dg_dq``,
  ``alpha`` (a bound on ||dg/dq||, sum of the absolute coefficients of each entry, combined in
  the Frobenius norm), ``u_pd_constant`` (PD + g(q_d), needs K_P > alpha), ``u_fl`` (feedback
  linearization, exponential).

>>> from app.core.exercise import parse_exercise, solve
>>> ex = parse_exercise({"id": "x", "robot": "planar_2r", "question": "?",
...                      "tasks": [{"kind": "parametrization", "known": ["l1", "g0"]}]})
>>> solve(ex).answers["regressor_count"]   # l1 known: m2 l1 d2 and g0 m2 d2 share one coefficient
4
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Dict, List, Optional, Sequence

import numpy as np
import sympy as sp

from ..dynamics import _complexity, _independent_columns
from ..exercise import ExerciseError
from ..expressions import symbol
from ..mathtext import symbols_text
from ..robot import KNOWN_KINDS
from ..steps import to_latex
from ..trig import TrigPoly
from . import task
from .context import TaskView

TERMS = ("inertia", "coriolis", "gravity", "spring", "friction")


def _names(prefix: str, coords: Sequence[str], suffix: str = "") -> List[sp.Symbol]:
    return [symbol(f"{prefix}{c}{suffix}") for c in coords]


def law_symbols(coords: Sequence[str]) -> Dict[str, sp.Matrix]:
    """Vectors of the symbols used by the control laws (errors, desired values, gains)."""
    idx = [re.sub(r"^\D*", "", c) or str(i + 1) for i, c in enumerate(coords)]
    vec = lambda fmt: sp.Matrix([symbol(fmt.format(c=c, i=i)) for c, i in zip(coords, idx)])
    return {"e": vec("e{i}"), "de": vec("de{i}"), "q_d": vec("{c}_d"), "dq_d": vec("d{c}_d"),
            "ddq_d": vec("dd{c}_d"), "dq_r": vec("d{c}_r"), "ddq_r": vec("dd{c}_r"),
            "kp": vec("kp{i}"), "kd": vec("kd{i}"), "lam": vec("lambda{i}")}


def latex_law(m: TaskView, expr) -> str:
    """LaTeX with dots on error derivatives and hats on estimates."""
    extra = [s.name for s in sp.sympify(expr).free_symbols if re.fullmatch(r"e\d+", s.name)]
    out = to_latex(expr, list(m.coords) + extra)
    return re.sub(r"ahat_\{(\d+)\}", r"\\hat a_{\1}", out)


# ====================================================================== parametrization
@dataclass
class LinearParametrization:
    a: List[sp.Expr]
    Y: sp.Matrix
    Y_r: sp.Matrix
    known_part: sp.Matrix
    known_part_r: sp.Matrix
    known: List[str]
    minimal: int            # the smallest number of coefficients for these terms


def _monomials(expr, gens) -> Dict[tuple, sp.Expr]:
    expr = sp.expand(expr)
    if not gens:
        return {(): expr} if expr != 0 else {}
    try:
        poly = sp.Poly(expr, *gens)
    except sp.PolynomialError:
        raise ExerciseError(f"parametrization: {expr} is not polynomial in the unknown parameters") from None
    return {mono: c for mono, c in poly.terms()}


def parametrize(m: TaskView, coefficients: Optional[Sequence] = None, known: Optional[Sequence[str]] = None,
                terms: Sequence[str] = TERMS, input_gain=None) -> LinearParametrization:
    """Y, Y_r with Y a = the chosen terms of the model (divided by the input gain, if any)."""
    robot = m.robot
    bad = [t for t in terms if t not in TERMS]
    if bad:
        raise ExerciseError(f"parametrization.terms: unknown term(s) {bad} (use {', '.join(TERMS)})")
    if known is None:
        known = [p.name for p in robot.parameters.values() if p.kind in KNOWN_KINDS]
    unknown_names = [k for k in known if k not in robot.parameters]
    if unknown_names:
        raise ExerciseError(f"parametrization.known: {unknown_names} are not parameters of {robot.name}")
    a = None if coefficients is None else [m.ctx.expr(c, "parametrization.coefficients") for c in coefficients]
    dyn = m.dyn
    dqr, ddqr = (sp.Matrix(v) for v in robot.reference_symbols())
    fric_r = dyn.friction.subs(dict(zip(m.dq, dqr)), simultaneous=True)
    parts = {"inertia": (m.M * m.ddq, m.M * ddqr), "coriolis": (m.C * m.dq, m.C * dqr),
             "gravity": (dyn.g, dyn.g), "spring": (dyn.spring, dyn.spring), "friction": (dyn.friction, fric_r)}
    n = len(m.coords)
    target = sp.zeros(n, 1)
    target_r = sp.zeros(n, 1)
    for t in terms:
        target += parts[t][0]
        target_r += parts[t][1]
    gain = None
    if input_gain is not None:
        gain = m.ctx.expr(input_gain, "parametrization.input_gain")
        target, target_r = target / gain, target_r / gain
    params = {p.symbol for p in robot.parameters.values()}
    unknown = [p.symbol for p in robot.parameters.values() if p.name not in known]
    if gain is not None:
        unknown += sorted(gain.free_symbols - params - set(unknown), key=lambda s: s.name)
    if a is not None:
        stray = set().union(*[e.free_symbols for e in a]) - params - set(unknown)
        if stray:
            raise ExerciseError(f"parametrization.coefficients: unknown name(s) {sorted(s.name for s in stray)}")
    gens = [s for s in unknown if any(s in e.free_symbols for e in list(a or []) + list(target))]
    if gain is not None:
        gens += [1 / s for s in gain.free_symbols if s in unknown]
    T, T_r = _columns_by_monomial(target, gens), _columns_by_monomial(target_r, gens)
    one = tuple(0 for _ in gens)
    known_part = [tp.expand() for tp in T.pop(one, [TrigPoly() for _ in range(n)])]
    known_part_r = [tp.expand() for tp in T_r.pop(one, [TrigPoly() for _ in range(n)])]
    # the minimal set, as the engine's own regressor chooses it
    cols = [(sp.Mul(*[g ** e for g, e in zip(gens, mono)]), vec) for mono, vec in T.items()]
    cols.sort(key=lambda col: _complexity(col[1]))
    _basis, coeffs = _independent_columns(cols, set(known)) if cols else ([], [])
    if a is None:
        a = [sp.factor_terms(sp.expand(c)) for c in coeffs]
    R_rows = [_monomials(e, gens) for e in a]
    for k, row in enumerate(R_rows):
        for mono, c in row.items():
            if c.free_symbols & (set(unknown) | set(m.q) | set(m.dq)):
                raise ExerciseError(f"parametrization: coefficient {a[k]} is not a combination of unknown-parameter products")
    monos = list(dict.fromkeys([mo for row in R_rows for mo in row] + list(T) + list(T_r)))
    p = len(a)
    R = sp.Matrix(p, len(monos), lambda k, j: R_rows[k].get(monos[j], 0))
    chosen = _independent_monomials(R, p)
    Rinv = R.extract(list(range(p)), chosen).inv()
    Y = _regressor_of(m, T, R, Rinv, chosen, monos, gens)
    Y_r = _regressor_of(m, T_r, R, Rinv, chosen, monos, gens)
    kp = sp.Matrix([m.tidy(tp.to_expr()) for tp in known_part])
    kpr = sp.Matrix([m.tidy(tp.to_expr()) for tp in known_part_r])
    return LinearParametrization(a, Y, Y_r, kp, kpr, list(known), len(coeffs))


def _columns_by_monomial(rows: sp.Matrix, gens) -> Dict[tuple, List[TrigPoly]]:
    """The model rows split by monomial of the unknown parameters: monomial -> column of
    canonical polynomials."""
    n = rows.rows
    cols: Dict[tuple, List[TrigPoly]] = {}
    for i in range(n):
        tp = TrigPoly.from_expr(sp.expand(rows[i])).expand()
        for key, coeff in tp.terms.items():
            for mono, c in _monomials(coeff, gens).items():
                vec = cols.setdefault(mono, [TrigPoly() for _ in range(n)])
                vec[i] = vec[i] + TrigPoly({key: c})
    return cols


def _independent_monomials(R: sp.Matrix, p: int) -> List[int]:
    """p independent monomial columns of R (chosen numerically at seeded values, to invert exactly)."""
    rng = np.random.default_rng(5)
    known_syms = sorted(R.free_symbols, key=lambda s: s.name)
    vals = {s: rng.uniform(0.5, 1.5) for s in known_syms}
    Rn = np.array(R.subs(vals).evalf(), dtype=float) if R.shape[1] else np.zeros((p, 0))
    chosen: List[int] = []
    for j in range(R.shape[1]):
        trial = chosen + [j]
        if np.linalg.matrix_rank(Rn[:, trial], tol=1e-9) == len(trial):
            chosen = trial
        if len(chosen) == p:
            break
    if len(chosen) < p:
        raise ExerciseError("parametrization.coefficients: the coefficients are not independent "
                            "(one is a combination of the others)")
    return chosen


def _regressor_of(m: TaskView, cols, R, Rinv, chosen, monos, gens) -> sp.Matrix:
    """Y with Y a = the model columns ``cols``, checked term by term against a = R monomials."""
    n, p = len(m.coords), R.shape[0]
    Y = [[TrigPoly() for _ in range(p)] for _ in range(n)]
    for i in range(n):
        for k in range(p):
            acc = TrigPoly()
            for jj, j in enumerate(chosen):
                vec = cols.get(monos[j])
                if vec is not None and vec[i].terms and Rinv[jj, k] != 0:
                    acc = acc + vec[i].scale(Rinv[jj, k])
            Y[i][k] = acc.expand()
    for j, mono in enumerate(monos):
        vec = cols.get(mono, [TrigPoly() for _ in range(n)])
        for i in range(n):
            acc = TrigPoly()
            for k in range(p):
                if R[k, j] != 0 and Y[i][k].terms:
                    acc = acc + Y[i][k].scale(R[k, j])
            if not (acc - vec[i]).expand().is_zero():
                raise ExerciseError(
                    "parametrization.coefficients: these coefficients do not parametrize the model "
                    f"(row {i + 1} is not a combination of them: term "
                    f"{sp.Mul(*[g ** e for g, e in zip(gens, mono)])})")
    return sp.Matrix(n, p, lambda i, k: m.tidy(Y[i][k].to_expr()))


def _options(spec):
    return dict(coefficients=spec.get("coefficients"), known=spec.get("known"),
                terms=spec.get("terms", TERMS), input_gain=spec.get("input_gain"))


@task("parametrization")
def parametrization_task(ctx, spec):
    """Linear parametrization in given coefficients (see the module docstring)."""
    m = TaskView(ctx)
    par = parametrize(m, **_options(spec))
    sfx = str(spec.get("suffix", ""))
    a = sp.Matrix(par.a)
    lhs = " + ".join({"inertia": r"M(q)\ddot q", "coriolis": r"C(q,\dot q)\dot q", "gravity": "g(q)",
                      "spring": "k(q)", "friction": r"F\dot q"}[t] for t in spec.get("terms", TERMS))
    if spec.get("input_gain") is not None:
        lhs = rf"\left({lhs}\right) / {to_latex(ctx.expr(spec['input_gain']))}"
    ctx.step("Dynamic coefficients", rf"a{sfx} = {m.L(a)}",
             f"{len(par.a)} coefficients (known: {symbols_text(par.known)}); each is a product "
             "(or a sum of products) of unknown parameters; "
             + ("this is the minimal number." if len(par.a) == par.minimal else
                f"the minimal number is {par.minimal}."))
    known_txt = ""
    if any(e != 0 for e in par.known_part):
        known_txt = rf" + {m.L(par.known_part)}"
    ctx.step("Regressor", rf"{lhs} = Y{sfx} a{sfx}{known_txt},\quad Y{sfx} = {m.L(par.Y)}",
             "Each column collects what multiplies one coefficient; the match is exact.")
    ctx.step("Adaptive regressor", rf"Y{sfx}(q,\dot q,\dot q_r,\ddot q_r) = {m.L(par.Y_r)}",
             r"Replace $\ddot q$ by $\ddot q_r$ and $C(q, \dot q)\, \dot q$ by $C(q, \dot q)\, \dot q_r$ (friction on $\dot q_r$).")
    ctx.answer(f"Y{sfx}", par.Y)
    ctx.answer(f"Y{sfx}_r", par.Y_r)
    ctx.answer(f"a{sfx}", a)
    ctx.answer(f"regressor_count{sfx}", len(par.a))
    ctx.answer(f"minimal_count{sfx}", par.minimal)
    if any(e != 0 for e in par.known_part):
        ctx.answer(f"tau_known{sfx}", par.known_part)


# ====================================================================== adaptive law
@task("adaptive_law")
def adaptive_law_task(ctx, spec):
    """Slotine-Li adaptive tracking law (see the module docstring)."""
    m = TaskView(ctx)
    par = parametrize(m, **_options(spec))
    p = len(par.a)
    est = spec.get("estimate")
    if est is None:
        est = list(range(1, p + 1))
    if not isinstance(est, list) or any(not isinstance(k, int) or not 1 <= k <= p for k in est):
        raise ExerciseError(f"adaptive_law.estimate: expected a list of coefficient indices 1..{p}")
    est = [k - 1 for k in est]
    fixed = [k for k in range(p) if k not in est]
    s = law_symbols(m.coords)
    e, de, kp, kd = s["e"], s["de"], s["kp"], s["kd"]
    n = len(m.coords)
    free_lambda = spec.get("lambda", "KP/KD") == "free"
    lam = s["lam"] if free_lambda else sp.Matrix([kp[i] / kd[i] for i in range(n)])
    ahat = sp.Matrix([symbol(f"ahat{k + 1}") for k in est])
    gamma = [symbol(f"gamma{k + 1}") for k in est]
    Y_est = par.Y_r.extract(list(range(n)), est) if est else sp.zeros(n, 0)
    known_terms = par.known_part_r
    extra = spec.get("known_terms") or []
    bad = [t for t in extra if t not in TERMS or t in spec.get("terms", TERMS)]
    if bad:
        raise ExerciseError(f"adaptive_law.known_terms: {bad} are not model terms outside 'terms'")
    if extra:
        dqr, ddqr = (sp.Matrix(v) for v in m.robot.reference_symbols())
        ref = {"inertia": m.M * ddqr, "coriolis": m.C * dqr, "gravity": m.dyn.g, "spring": m.dyn.spring,
               "friction": m.dyn.friction.subs(dict(zip(m.dq, dqr)), simultaneous=True)}
        for t in extra:
            known_terms = known_terms + ref[t]
    if fixed:
        known_terms = known_terms + par.Y_r.extract(list(range(n)), fixed) * sp.Matrix([par.a[k] for k in fixed])
    known_terms = m.tidy_matrix(known_terms)
    u = Y_est * ahat + known_terms + sp.diag(*kp) * e + sp.diag(*kd) * de
    svec = s["dq_r"] - m.dq
    update = sp.diag(*gamma) * Y_est.T * svec if est else sp.zeros(0, 1)
    dq_r = s["dq_d"] + sp.diag(*lam) * e
    ddq_r = s["ddq_d"] + sp.diag(*lam) * de
    # Lyapunov V = 1/2 s^T M s + e^T K_P e + 1/2 atilde^T Gamma^-1 atilde along the closed loop
    # M s' = -C s - Y_r atilde... gives V' = -(e' + Lambda e)^T (K_P e + K_D e') + 2 e^T K_P e'
    sv = de + sp.diag(*lam) * e
    V_dot = sp.expand((-(sv.T * (sp.diag(*kp) * e + sp.diag(*kd) * de)) + 2 * e.T * sp.diag(*kp) * de)[0])
    a_est = sp.Matrix([par.a[k] for k in est])
    L = lambda x: latex_law(m, x)
    ctx.step("Reference velocity", rf"\dot q_r = \dot q_d + \Lambda e = {L(dq_r)},\quad \ddot q_r = {L(ddq_r)}",
             r"$e = q_d - q$; with $\Lambda = K_D^{-1} K_P$ the PD term equals $K_D (\dot q_r - \dot q)$."
             if not free_lambda else r"$e = q_d - q$ and $\Lambda > 0$ diagonal.")
    ctx.step("Adaptive regressor", rf"Y(q,\dot q,\dot q_r,\ddot q_r) = {m.L(par.Y_r)},\quad a = {m.L(sp.Matrix(par.a))}",
             "The model evaluated on the reference motion, linear in the coefficients.")
    ctx.step("Control law", rf"u = {L(u)}",
             f"Estimates of {len(est)} coefficient(s)" + (f"; the known ones ({len(fixed)}) enter with their values." if fixed else ".")
             + r" Gains $K_P, K_D > 0$ diagonal.", joints=[b.name for b in m.robot.bodies])
    ctx.step("Update law", rf"\dot{{\hat a}} = \Gamma Y^T (\dot q_r - \dot q) = {L(update)}",
             f"The controller has {len(est)} state(s): the estimates ${L(a_est)}$.")
    ctx.step("Lyapunov analysis",
             r"V = \tfrac12 s^T M s + e^T K_P e + \tfrac12 \tilde a^T \Gamma^{-1} \tilde a,\quad "
             rf"\dot V = {L(V_dot)} \le 0",
             r"With $s = \dot q_r - \dot q$, $\dot M - 2C$ skew-symmetric and the update law, $\dot V$ is negative "
             r"semidefinite; Barbalat's lemma gives $e, \dot e \to 0$.")
    ctx.answer("u", u)
    ctx.answer("update", update)
    ctx.answer("dq_r", dq_r)
    ctx.answer("ddq_r", ddq_r)
    ctx.answer("Y_r", par.Y_r)
    ctx.answer("a", sp.Matrix(par.a))
    ctx.answer("dimension", len(est))
    ctx.answer("V_dot", V_dot)


# ====================================================================== computed torque
@task("computed_torque")
def computed_torque_task(ctx, spec):
    """Computed-torque tracking law (see the module docstring)."""
    m = TaskView(ctx)
    s = law_symbols(m.coords)
    form = spec.get("form", "feedback_linearization")
    Kp, Kd = sp.diag(*s["kp"]), sp.diag(*s["kd"])
    dyn = m.dyn
    if form == "feedback_linearization":
        u = m.M * (s["ddq_d"] + Kd * s["de"] + Kp * s["e"]) + m.n
        text = r"Cancel the nonlinear terms and impose $\ddot e + K_D \dot e + K_P e = 0$ (exponential, decoupled)."
        latex = r"u = M(q)\left(\ddot q_d + K_D \dot e + K_P e\right) + c(q,\dot q) + g(q)"
    elif form == "passivity":
        fric_d = dyn.friction.subs(dict(zip(m.dq, s["dq_d"])), simultaneous=True)
        u = m.M * s["ddq_d"] + m.C * s["dq_d"] + dyn.g + dyn.spring + fric_d + Kp * s["e"] + Kd * s["de"]
        text = ("Model-based feedforward on the desired motion plus PD; with the skew-symmetric "
                r"factorization $C$ the tracking error converges (Lyapunov with $\dot M - 2C$ skew).")
        latex = r"u = M(q)\ddot q_d + C(q,\dot q)\dot q_d + g(q) + K_P e + K_D \dot e"
    else:
        raise ExerciseError(f"computed_torque.form: expected feedback_linearization or passivity, got {form!r}")
    u = u.applyfunc(sp.expand)
    ctx.step("Control law", rf"{latex} = {latex_law(m, u)}", text, joints=[b.name for b in m.robot.bodies])
    ctx.answer(str(spec.get("name", "u")), u)


# ====================================================================== nominal torque along a trajectory
@task("desired_torque")
def desired_torque_task(ctx, spec):
    """Nominal torque along q_d(t) (see the module docstring)."""
    m = TaskView(ctx)
    traj = spec.get("trajectory")
    if not isinstance(traj, dict) or set(traj) != set(m.coords):
        raise ExerciseError(f"desired_torque.trajectory: give an expression of t for each of {m.coords}")
    t = symbol("t")
    qd = sp.Matrix([_trajectory_entry(ctx, traj[c], f"desired_torque.trajectory.{c}", t) for c in m.coords])
    dqd, ddqd = qd.diff(t), qd.diff(t, 2)
    sub = dict(zip(m.q, qd))
    sub.update(zip(m.dq, dqd))
    sub.update(zip(m.ddq, ddqd))
    fixed = m.mapping_of_parameters(spec.get("substitute"), "desired_torque.substitute")
    tau = _tidy_or_plain(m, (m.M * m.ddq + m.n).subs(fixed).subs(sub, simultaneous=True))
    ctx.step("Desired motion", rf"q_d(t) = {m.L(qd)},\quad \dot q_d = {m.L(dqd)},\quad \ddot q_d = {m.L(ddqd)}",
             "Differentiate the desired trajectory twice.")
    ctx.step("Nominal torque", rf"\tau_d(t) = M(q_d)\ddot q_d + c(q_d,\dot q_d) + g(q_d) = {m.L(tau)}",
             "Inverse dynamics along the trajectory: the torque that reproduces it exactly in nominal conditions.",
             joints=[b.name for b in m.robot.bodies])
    ctx.answer("q_d", qd)
    ctx.answer("dq_d", dqd)
    ctx.answer("ddq_d", ddqd)
    ctx.answer("tau_d", tau)
    if spec.get("at") is not None:
        t0 = ctx.expr(spec["at"], "desired_torque.at")
        values = {p.symbol: p.value for p in m.robot.parameters.values()}
        values.update({symbol(k): ctx.expr(v, f"given.{k}") for k, v in ctx.given.items()
                       if isinstance(v, (int, float, str))})
        exact = {"q_d_at": qd, "dq_d_at": dqd, "ddq_d_at": ddqd, "tau_d_at": tau}
        exact = {k: _tidy_or_plain(m, v.subs(t, t0)) for k, v in exact.items()}
        nums = {k: np.array(sp.N(v.subs(values).subs(values)), dtype=float).reshape(-1) for k, v in exact.items()}
        ctx.step(f"At $t = {m.L(t0)}$", rf"\tau_d({m.L(t0)}) = {m.L(exact['tau_d_at'])} = {m.L(sp.Matrix(np.round(nums['tau_d_at'], 4)))}",
                 "The same expressions at the given instant, then with the exercise's numbers.",
                 joints=[b.name for b in m.robot.bodies])
        for k, v in exact.items():
            ctx.answer(k.replace("_at", "_at_expr"), v)
            ctx.answer(k, nums[k])


def _tidy_or_plain(m, mat) -> sp.Matrix:
    """The compact trigonometric form when the angles are sums of symbols (tidy), else as it is
    (e.g. cos of a polynomial in t)."""
    try:
        return m.tidy_matrix(mat)
    except sp.PolynomialError:
        return sp.Matrix(mat)


def _trajectory_entry(ctx, raw, where: str, t):
    """An expression of t, or a rest-to-rest motion {start, delta, duration, profile: cubic|quintic}
    (the normalized polynomial of the profile, held at start + delta after the duration)."""
    from .underactuated import _PROFILES
    if not isinstance(raw, dict):
        return ctx.expr(raw, where)
    unknown = set(raw) - {"start", "delta", "duration", "profile"}
    if unknown or not {"start", "delta", "duration"} <= set(raw):
        raise ExerciseError(f"{where}: expected {{start, delta, duration, profile}} (got {sorted(raw)})")
    profile = _PROFILES.get(raw.get("profile", "cubic"))
    if profile is None:
        raise ExerciseError(f"{where}.profile: one of {', '.join(_PROFILES)}")
    start, delta, T = (ctx.expr(raw[k], f"{where}.{k}") for k in ("start", "delta", "duration"))
    return start + delta * profile(t / T)


# ====================================================================== regulation
def _abs_bound(expr) -> sp.Expr:
    """Sum of the absolute values of the coefficients of a trigonometric polynomial (|sin|, |cos| <= 1)."""
    tp = TrigPoly.from_expr(sp.expand(expr)).expand()
    return sp.Add(*[sp.Abs(sp.factor(c)) for c in tp.terms.values()])


@task("regulation")
def regulation_task(ctx, spec):
    """Regulation laws for a constant q_d (see the module docstring)."""
    m = TaskView(ctx)
    s = law_symbols(m.coords)
    Kp, Kd = sp.diag(*s["kp"]), sp.diag(*s["kd"])
    e = s["q_d"] - m.q
    g = m.dyn.g + m.dyn.spring
    sub_d = dict(zip(m.q, s["q_d"]))
    u1 = Kp * e - Kd * m.dq + g
    u2 = Kp * e - Kd * m.dq + g.subs(sub_d, simultaneous=True)
    dg = m.tidy_matrix(g.jacobian(m.q))
    positive = {sym: sp.Symbol(sym.name, positive=True) for sym in
                set().union(*[x.free_symbols for x in dg]) if sym.name in m.robot.parameters
                and m.robot.parameters[sym.name].kind in ("mass", "inertia", "stiffness", "gravity", "length", "com")}
    back = {v: k for k, v in positive.items()}
    alpha = sp.sqrt(sum(_abs_bound(x.subs(positive)) ** 2 for x in dg)).xreplace(back)
    alpha = sp.simplify(alpha)
    u3 = m.M * (Kp * e - Kd * m.dq) + m.n
    L = lambda x: latex_law(m, x)
    ctx.step("PD + gravity compensation", rf"u = K_P (q_d - q) - K_D \dot q + g(q) = {L(u1)}",
             r"Any $K_P, K_D > 0$: global asymptotic stability (Lyapunov $V = T + \frac{1}{2} e^T K_P e$ and LaSalle).")
    ctx.step("Gradient of gravity", rf"\frac{{\partial g}}{{\partial q}} = {m.L(dg)},\quad \alpha = {m.L(alpha)}",
             r"$\alpha$ bounds the norm of the gravity gradient everywhere ($|\sin|, |\cos| \le 1$).")
    ctx.step("PD + constant gravity compensation", rf"u = K_P (q_d - q) - K_D \dot q + g(q_d) = {L(u2)}",
             r"Global asymptotic stability if $\lambda_{\min}(K_P) > \alpha$; otherwise spurious equilibria may appear.")
    ctx.step("Feedback linearization", rf"u = M(q)\left(K_P (q_d - q) - K_D \dot q\right) + c + g = {L(u3.applyfunc(sp.expand))}",
             "Exact cancellation: decoupled linear error dynamics, global exponential convergence (nominal model).")
    ctx.step("Other laws", "",
             "PID (local asymptotic stability, gains from Routh conditions) and iterative gravity "
             "compensation (PD plus the torque of the previous rest configuration, with $K_P$ large with "
             r"respect to $\alpha$) also regulate without knowing $g(q)$ exactly.")
    ctx.answer("u_pd_gravity", u1)
    ctx.answer("dg_dq", dg)
    ctx.answer("alpha", alpha)
    ctx.answer("u_pd_constant", u2)
    ctx.answer("u_fl", u3.applyfunc(sp.expand))
