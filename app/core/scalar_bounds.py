"""The largest (or smallest) value of a scalar s > 0 -- a gain, a payload, a time-scaling factor, a
sampling time -- for which quantities q_i(s) stay within their bounds lo_i <= q_i(s) <= hi_i.

Each quantity gives its own limit s_i (a root of q_i(s) = lo_i or hi_i, in closed form when sympy
finds one; the side that is feasible is decided at the numbers of the exercise); the answer is the
most restrictive one: max_i s_i for the smallest feasible s (e.g. a time scaling k >= s_i for
every joint), min_i s_i for the largest (e.g. a gain). A pair of roots c, -c (from a symmetric
bound |q_i| <= b) is written |c|.

>>> k, A = sp.symbols("k A", positive=True)
>>> v = sp.Symbol("v", real=True)
>>> res = scalar_limit([-2*v/k], [-A], [A], k, {v: 3.0, A: 2.0}, "smallest")
>>> res.exact, f"{res.value:.3f}"
(2*Abs(v)/A, '3.000')
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Dict, List, Optional, Sequence

import sympy as sp


class ScalarBoundError(ValueError):
    """No value of the scalar satisfies the bounds, or the bounds never restrict it."""


@dataclass
class Limit:
    exact: Optional[sp.Expr]        # closed form (None when only numeric)
    value: float                    # at the exercise's numbers (0 or inf: no restriction)
    index: int = -1                 # 0-based index of the quantity that sets the overall limit
    per_quantity: Optional[List["Limit"]] = None


def _num(expr, numbers) -> complex:
    return complex(sp.N(sp.sympify(expr).subs(numbers)))


def _feasible(expr, lo, hi, s, value, numbers) -> bool:
    v = _num(expr.subs(s, value), numbers)
    if abs(v.imag) > 1e-9 * max(1.0, abs(v.real)):
        return False
    tol = 1e-9 * max(1.0, abs(v.real))
    return (lo is None or v.real >= _num(lo, numbers).real - tol) and (hi is None or v.real <= _num(hi, numbers).real + tol)


def _candidates(expr, lo, hi, s, numbers):
    """Positive real roots of expr = lo and expr = hi: (value, closed form), sorted by value."""
    roots = []
    for b in (lo, hi):
        if b is None:
            continue
        try:
            roots += sp.solve(sp.Eq(expr, b), s)
        except NotImplementedError:
            pass
    out = []
    for r in roots:
        v = _num(r, numbers)
        if abs(v.imag) < 1e-9 * max(1.0, abs(v.real)) and v.real > 0:
            # a pair c, -c of roots (the two sides of |q| <= b) reads |c|
            twin = any(sp.simplify(r + o) == 0 for o in roots)
            out.append((v.real, sp.Abs(r) if twin else r))
    return sorted(out, key=lambda x: x[0])


def quantity_limit(expr, lo, hi, s, numbers, find: str) -> Limit:
    """The limit that one quantity puts on s (see the module docstring)."""
    cands = _candidates(expr, lo, hi, s, numbers)
    feas = lambda x: _feasible(expr, lo, hi, s, x, numbers)
    if not cands:
        if feas(1.0):
            return Limit(sp.Integer(0) if find == "smallest" else sp.oo, 0.0 if find == "smallest" else float("inf"))
        raise ScalarBoundError(f"{expr} never satisfies its bounds for s > 0")
    vals = [v for v, _r in cands]
    if find == "smallest":
        if not feas(vals[-1] * 1.5 + 1e-9):
            raise ScalarBoundError(f"{expr} violates its bounds for large {s}: no smallest feasible value")
        j = len(vals) - 1
        while j > 0 and feas((vals[j - 1] + vals[j]) / 2):
            j -= 1
        if j == 0 and feas(vals[0] / 2):
            return Limit(sp.Integer(0), 0.0)
    else:
        if not feas(vals[0] / 2):
            raise ScalarBoundError(f"{expr} violates its bounds for small {s}: no largest feasible value")
        j = 0
        while j < len(vals) - 1 and feas((vals[j] + vals[j + 1]) / 2):
            j += 1
        if j == len(vals) - 1 and feas(vals[-1] * 1.5 + 1e-9):
            return Limit(sp.oo, float("inf"))
    return Limit(cands[j][1], vals[j])


def scalar_limit(exprs: Sequence, lows: Sequence, highs: Sequence, s: sp.Symbol, numbers: Dict,
                 find: str = "largest") -> Limit:
    """The overall limit of s over all quantities (``find``: 'largest' or 'smallest' feasible s)."""
    if find not in ("largest", "smallest"):
        raise ScalarBoundError("find: 'largest' or 'smallest'")
    per = [quantity_limit(sp.sympify(e), lo, hi, s, numbers, find) for e, lo, hi in zip(exprs, lows, highs)]
    pick = max if find == "smallest" else min
    index = pick(range(len(per)), key=lambda i: per[i].value)
    forms = [p.exact for p in per]
    exact = (sp.Max if find == "smallest" else sp.Min)(*forms) if len(forms) > 1 else forms[0]
    return Limit(exact, per[index].value, index, per)
