"""Bounds on a scalar and trajectories from boundary conditions.

``scalar_bound``: the largest (or smallest) value of a scalar s > 0 -- a gain, a payload, a time
scaling factor, a sampling time -- for which quantities that depend on it stay within bounds
(app/core/scalar_bounds.py). Options: ``scalar`` (its name), ``quantities`` (a list of
expressions, or the name of an earlier answer: a vector, one quantity per entry, e.g. the joint
accelerations), ``substitute`` (name -> expression applied to the quantities first, e.g.
``{T: k*T}`` for a time scaling), ``bounds`` (``{max: [...]}`` for |q_i| <= max_i, or
``{lower: [...], upper: [...]}``; one value for all or one per quantity), ``find``
(``largest``, default, or ``smallest``), ``name`` (answer prefix, default the scalar's name).
Answers: ``<name>_max`` or ``<name>_min`` (closed form: Min/Max over the quantities),
``<name>_per_quantity`` (each quantity's own limit: per joint), ``<name>_value`` (at the
exercise's numbers), ``<name>_limiting`` (1-based index of the quantity that sets it).
The side of each root that is feasible is decided at the exercise's numbers (``given`` and the
robot's parameters), so every symbol needs a number.

``boundary_polynomial``: the polynomial in t of lowest degree meeting conditions on its value and
derivatives at t = 0 and t = T (one polynomial per component). Options: ``name`` (default q_d),
``duration`` (T, an expression), ``start`` and ``end`` (mappings ``position``, ``velocity``,
``acceleration``, ``jerk`` -> a list of expressions, one per component, or one value for all),
``size`` (number of components, default from the lists). Answers: ``<name>`` (of t),
``<name>_dot``, ``<name>_ddot``, ``<name>_end`` (value at T), ``<name>_ddot_start``
(acceleration at 0), ``<name>_degree``.

>>> from app.core.exercise import parse_exercise, solve
>>> ex = parse_exercise({"id": "x", "robot": "planar_2r", "question": "?", "given": {"v": 2, "A": 1, "T": 1},
...     "tasks": [{"kind": "boundary_polynomial", "duration": "T", "start": {"position": 0, "velocity": "v"},
...                "end": {"velocity": 0, "acceleration": 0}, "size": 1},
...               {"kind": "scalar_bound", "scalar": "k", "quantities": "q_d_ddot_start",
...                "substitute": {"T": "k*T"}, "bounds": {"max": "A"}, "find": "smallest"}]})
>>> ans = solve(ex).answers
>>> ans["k_min"], f"{ans['k_value']:.3f}"
(2*Abs(v/(A*T)), '4.000')
"""
from __future__ import annotations

import sympy as sp

from ..exercise import ExerciseError
from ..expressions import symbol
from ..scalar_bounds import ScalarBoundError, scalar_limit
from ..steps import to_latex
from . import task

_ORDERS = {"position": 0, "velocity": 1, "acceleration": 2, "jerk": 3}


def _numbers(ctx):
    """The exercise's scalar numbers (robot parameters, then ``given``) as a substitution."""
    out = {p.symbol: p.value for p in ctx.robot.parameters.values()}
    for k, v in ctx.given.items():
        if isinstance(v, (int, float, str)) and str(k).isidentifier():
            try:
                out[symbol(str(k))] = ctx.expr(v, f"given.{k}")
            except ExerciseError:
                continue
    return out


def _vector(ctx, raw, where: str):
    """A list of expressions, one expression, or the name of an earlier (vector) answer."""
    if isinstance(raw, str) and raw in ctx.answers:
        val = ctx.answers[raw]
        return list(sp.Matrix(val)) if not isinstance(val, (int, float)) else [sp.sympify(val)]
    items = raw if isinstance(raw, list) else [raw]
    return [ctx.expr(e, where) for e in items]


@task("scalar_bound")
def scalar_bound_task(ctx, spec):
    """Largest or smallest scalar keeping quantities within bounds (see the module docstring)."""
    name = spec.get("scalar")
    if not isinstance(name, str) or not name.isidentifier():
        raise ExerciseError("scalar_bound.scalar: the name of the scalar to bound (e.g. k)")
    find = spec.get("find", "largest")
    if find not in ("largest", "smallest"):
        raise ExerciseError("scalar_bound.find: 'largest' or 'smallest'")
    if "quantities" not in spec:
        raise ExerciseError("scalar_bound.quantities: expressions of the scalar, or an earlier answer")
    s_real, s = symbol(name), sp.Symbol(name, positive=True)
    sub = {symbol(str(k)): ctx.expr(v, f"scalar_bound.substitute.{k}") for k, v in (spec.get("substitute") or {}).items()}
    qs = [e.subs(sub, simultaneous=True).subs(s_real, s) for e in _vector(ctx, spec["quantities"], "scalar_bound.quantities")]
    if not any(s in e.free_symbols for e in qs):
        raise ExerciseError(f"scalar_bound: no quantity depends on {name}")
    bounds = spec.get("bounds") or {}
    n = len(qs)
    expand = lambda raw, where: (lambda v: v * n if len(v) == 1 else v)(_vector(ctx, raw, where)) if raw is not None else [None] * n
    if "max" in bounds:
        hi = expand(bounds["max"], "scalar_bound.bounds.max")
        lo = [-b for b in hi]
    else:
        lo, hi = expand(bounds.get("lower"), "scalar_bound.bounds.lower"), expand(bounds.get("upper"), "scalar_bound.bounds.upper")
    if len(lo) != n or len(hi) != n or all(b is None for b in lo + hi):
        raise ExerciseError(f"scalar_bound.bounds: {{max: ...}} or {{lower, upper}}, one value or {n}")
    numbers = _numbers(ctx)
    missing = sorted({x.name for e in qs + [b for b in lo + hi if b is not None] for x in e.free_symbols} - {name}
                     - {k.name for k in numbers})
    if missing:
        raise ExerciseError(f"scalar_bound: give numbers for {', '.join(missing)} (they decide which root bounds {name})")
    try:
        res = scalar_limit(qs, lo, hi, s, numbers, find)
    except ScalarBoundError as exc:
        raise ExerciseError(f"scalar_bound: {exc}") from None
    out = spec.get("name", name)
    tag = "min" if find == "smallest" else "max"
    back = {s: s_real}
    exact = sp.sympify(res.exact).xreplace(back)
    per = [sp.sympify(p.exact).xreplace(back) for p in res.per_quantity]
    L = lambda e: to_latex(e, list(ctx.robot.coordinates))
    inf = r"\infty"
    bound = lambda b, sign: L(b) if b is not None else sign + inf
    rows = r",\quad ".join(rf"{bound(b_lo, '-')} \le {L(q.xreplace(back))} \le {bound(b_hi, '')}"
                           for q, b_lo, b_hi in zip(qs, lo, hi))
    ctx.step(f"Bounds that depend on ${L(s_real)}$", rows, f"Each quantity as a function of ${L(s_real)}$ with its bounds.")
    ctx.step(f"Each quantity's limit on ${L(s_real)}$",
             r",\quad ".join(rf"{name}_{{{i + 1}}} = {L(p)} = {res.per_quantity[i].value:.4g}" for i, p in enumerate(per)),
             "Where each quantity reaches its bound (the feasible side decided at the exercise's numbers).")
    ctx.step(f"The {find} feasible ${L(s_real)}$", rf"{name}^* = {L(exact)} = {res.value:.4g}",
             f"Quantity {res.index + 1} is the limiting one.")
    ctx.answer(f"{out}_{tag}", exact)
    ctx.answer(f"{out}_per_quantity", per)
    ctx.answer(f"{out}_value", res.value)
    ctx.answer(f"{out}_limiting", res.index + 1)


@task("boundary_polynomial")
def boundary_polynomial_task(ctx, spec):
    """Polynomial trajectory from boundary conditions at 0 and T (see the module docstring)."""
    name = spec.get("name", "q_d")
    T = ctx.expr(spec.get("duration", "T"), "boundary_polynomial.duration")
    t = symbol("t")
    conds = []
    for side, at in (("start", sp.Integer(0)), ("end", T)):
        raw = spec.get(side) or {}
        if not isinstance(raw, dict) or not set(raw) <= set(_ORDERS):
            raise ExerciseError(f"boundary_polynomial.{side}: a mapping of {', '.join(_ORDERS)} -> values")
        for key, vals in raw.items():
            conds.append((at, _ORDERS[key], _vector(ctx, vals, f"boundary_polynomial.{side}.{key}")))
    if not conds:
        raise ExerciseError("boundary_polynomial: give conditions at the start and/or end")
    size = int(spec.get("size", max(len(v) for _a, _o, v in conds)))
    N = len(conds)
    coeffs = sp.symbols(f"c0:{N}")
    poly = sum((c * t ** j for j, c in enumerate(coeffs)), sp.Integer(0))
    out = []
    for i in range(size):
        eqs = []
        for at, order, vals in conds:
            v = vals[0] if len(vals) == 1 else vals[i]
            eqs.append(sp.Eq(poly.diff(t, order).subs(t, at), v))
        sol = sp.solve(eqs, coeffs, dict=True)
        if len(sol) != 1:
            raise ExerciseError("boundary_polynomial: the conditions do not fix a unique polynomial")
        out.append(sp.expand(poly.subs(sol[0])))
    q = sp.Matrix(out)
    dq, ddq = q.diff(t), q.diff(t, 2)
    simp = lambda m: m.applyfunc(lambda e: sp.factor(sp.simplify(e)))
    L = lambda e: to_latex(e, list(ctx.robot.coordinates))
    ctx.step("Polynomial through the boundary conditions",
             rf"{name}(t) = {L(q)},\quad \ddot {name}(t) = {L(simp(ddq))}",
             f"Degree {N - 1}: one coefficient per condition ({N}), solved per component.")
    ctx.step("At the end and at the start", rf"{name}(T) = {L(simp(q.subs(t, T)))},\quad \ddot {name}(0) = {L(simp(ddq.subs(t, 0)))}",
             "The configuration reached and the initial acceleration.")
    ctx.answer(name, q)
    ctx.answer(f"{name}_dot", dq)
    ctx.answer(f"{name}_ddot", simp(ddq))
    ctx.answer(f"{name}_end", simp(q.subs(t, T)))
    ctx.answer(f"{name}_ddot_start", simp(ddq.subs(t, 0)))
    ctx.answer(f"{name}_degree", N - 1)
