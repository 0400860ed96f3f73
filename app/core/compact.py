"""Compact, student-like forms of the engine's canonical trigonometric polynomials.

``pretty`` writes a TrigPoly term by term with each coefficient grouped by masses and factored
(``nice_coefficient``: D**2*m3 - 2*D*L3*m3 + L3**2*m3 + I3 -> I3 + m3*(D - L3)**2) and, for
spatial robots, also over products of sines and cosines of the links' own angles, keeping the
shorter form. ``tidy`` and ``collect_trig`` write kinematic expressions. The sympy algorithms
behind them (factor_terms, collect, factor) are slow; the fast paths here give the very same trees.

>>> from app.core.expressions import symbol
>>> m3, D, L3, I3 = (symbol(s) for s in ("m3", "D", "L3", "I3"))
>>> nice_coefficient(sp.expand(I3 + m3*(D - L3)**2), [m3])
I3 + m3*(D - L3)**2
"""
from __future__ import annotations

import math
from functools import reduce
from typing import Dict, List, Optional, Sequence, Tuple

import sympy as sp
from sympy.core.mul import _keep_coeff

from .kinematics import Kinematics
from .trig import Sparse, TrigPoly, polynomial_terms

_NICE_CACHE: Dict[Tuple[sp.Expr, tuple], sp.Expr] = {}


def nice_coefficient(coeff, masses=()) -> sp.Expr:
    """A coefficient as a student writes it: grouped by masses, each group factored,
    e.g. D**2*m3 - 2*D*L3*m3 + L3**2*m3 + I3 -> I3 + m3*(D - L3)**2 (shortest form kept)."""
    key = (coeff, tuple(masses))
    hit = _NICE_CACHE.get(key)
    if hit is not None:
        return hit
    if not isinstance(coeff, sp.Add):
        return coeff
    plain = factor_terms(coeff)
    expanded = coeff if polynomial_terms(coeff) is not None else sp.expand(coeff)
    present = [m for m in masses if expanded.has(m)]
    out = plain
    if present and isinstance(expanded, sp.Add) and len(expanded.args) > 2:
        grouped = collect_factored(expanded, present)
        if sp.count_ops(grouped) < sp.count_ops(plain):
            out = grouped
    if len(_NICE_CACHE) > 20000:
        _NICE_CACHE.clear()
    _NICE_CACHE[key] = out
    return out


def pretty(tp: TrigPoly, angles: Sequence[Dict[sp.Symbol, int]] = (), masses=()) -> sp.Expr:
    """A compact, student-like sympy expression of a canonical trigonometric polynomial.

    Terms are grouped by basis function. When double angles appear (spatial robots), the terms are
    also rewritten as products of sines and cosines of the ``angles`` (the links' own angles, e.g.
    q2 and q2 + q3), reduced with sin^2 + cos^2 = 1, and the shorter form is kept:
    cos(q3) + cos(2 q2 + q3) becomes 2 cos(q2) cos(q2 + q3)."""
    base = sp.Add(*[nice_coefficient(c, masses) * TrigPoly.basis_function(k) for k, c in tp.terms.items()])
    natural = [dict(a) for a in angles]
    if not natural or all(not freq or {s: n for s, n in freq} in natural for (freq, _k) in tp.terms):
        return base
    limit = sp.count_ops(base)
    alt = _product_form(tp, list(angles), masses, limit)
    return base if alt is None else alt


def tidy(expr, angles=(), masses=()) -> sp.Expr:
    """The shorter of the grouped form and the canonical (pretty) form of a kinematic expression."""
    grouped = collect_trig(expr)
    if not expr.has(sp.sin, sp.cos):
        return grouped
    canon = pretty(TrigPoly.from_expr(expr), angles, masses)   # grouped form is already the product form
    return canon if sp.count_ops(canon) < sp.count_ops(grouped) else grouped


def _product_form(tp: TrigPoly, angles, masses=(), limit: Optional[int] = None):
    """Rewrite every term over products of cos/sin of ``angles``: the shorter of the two reductions
    (sin^2 -> 1 - cos^2 or the reverse), or None when impossible or when no form has fewer than
    ``limit`` operations. A form whose lower bound on operations (one per sum and per distinct sine
    or cosine) reaches the limit is not built: it could not be chosen."""
    m = len(angles)
    vecs = [dict(a) for a in angles]

    def as_dict(freq):
        return {s: n for s, n in freq}

    def find(freq):
        """Express freq as +-angle_i (+-angle_j): returns list of (index, sign)."""
        target = as_dict(freq)
        for i, a in enumerate(vecs):
            if a == target:
                return [(i, 1)]
        for i, a in enumerate(vecs):
            for j in range(i, m):
                b = vecs[j]
                for sb in (1, -1):
                    keys = set(a) | set(b) | set(target)
                    if all(a.get(k, 0) + sb * b.get(k, 0) == target.get(k, 0) for k in keys):
                        return [(i, 1), (j, sb)]
                    if all(-a.get(k, 0) + sb * b.get(k, 0) == target.get(k, 0) for k in keys):
                        return [(i, -1), (j, sb)]
        return None

    # polynomial in (C_0..C_m-1, S_0..S_m-1) as {exponents: coefficient}
    def mul(p, q):
        out = {}
        for e1, c1 in p.items():
            for e2, c2 in q.items():
                e = tuple(a + b for a, b in zip(e1, e2))
                out[e] = out.get(e, 0) + c1 * c2
        return out

    def unit(index, sign=1):
        e = [0] * (2 * m)
        e[index] = 1
        return {tuple(e): sign}

    zero = tuple([0] * (2 * m))
    total: Dict[tuple, sp.Expr] = {}
    sparse = {key: Sparse.of(c) for key, c in tp.terms.items()}
    exact = all(v is not None for v in sparse.values())   # fast sums and scalings of polynomials
    for (freq, kind), coeff in tp.terms.items():
        if exact:
            coeff = sparse[(freq, kind)]
        if not freq:
            total[zero] = total.get(zero, 0) + coeff
            continue
        parts = find(freq)
        if parts is None:
            return None
        c, s_ = {zero: 1}, {}   # cos and sin of the running sum
        for idx, sign in parts:
            ci, si = unit(idx), unit(m + idx, sign)
            c, s_ = _padd(mul(c, ci), mul(s_, si), -1), _padd(mul(s_, ci), mul(c, si), 1)
        for e, v in (c if kind == "c" else s_).items():
            total[e] = total.get(e, 0) + coeff * v
    back = [sp.cos(_angle_expr(v)) for v in vecs] + [sp.sin(_angle_expr(v)) for v in vecs]
    best, best_ops = None, limit
    for reduce_sin in (True, False):
        poly = dict(total)
        for i in range(m):
            x, y = (m + i, i) if reduce_sin else (i, m + i)   # x^2 -> 1 - y^2
            poly = _reduce_square(poly, x, y)
        poly = {e: c for e, c in ((e, c if exact else sp.expand(c)) for e, c in poly.items()) if c != 0}
        bound = len(poly) - 1 + sum(1 for e in poly for k in e if k)
        if best_ops is not None and bound >= best_ops:
            continue
        if exact:
            poly = {e: c.to_expr() for e, c in poly.items()}
        out = sp.Add(*[nice_coefficient(c, masses) * sp.Mul(*[b ** k for b, k in zip(back, e)])
                       for e, c in poly.items()])
        ops = sp.count_ops(out)
        if best_ops is None or ops < best_ops:
            best, best_ops = out, ops
    return best


def _padd(p, q, sign):
    out = dict(p)
    for e, c in q.items():
        out[e] = out.get(e, 0) + sign * c
    return out


def _reduce_square(poly, x, y):
    """Replace X**2 by 1 - Y**2 in a polynomial {exponents: coefficient} (X, Y: sin/cos of one
    angle, at positions x and y of the exponent tuples)."""
    out: Dict[tuple, sp.Expr] = {}
    for e, c in poly.items():
        k, r = divmod(e[x], 2)
        for j in range(k + 1):   # (1 - Y^2)^k = sum_j binom(k, j) (-1)^j Y^(2j)
            f = list(e)
            f[x] = r
            f[y] = e[y] + 2 * j
            f = tuple(f)
            out[f] = out.get(f, 0) + c * (math.comb(k, j) * (-1) ** j)
    return out


def _angle_expr(vec):
    return sp.Add(*[n * s for s, n in vec.items()])


def collect_trig(expr) -> sp.Expr:
    """Group an expanded expression by its sines and cosines: -l1 s1 dq1 - d2 s12 (dq1 + dq2)."""
    expr = sp.expand(expr)
    atoms = sorted(expr.atoms(sp.sin, sp.cos), key=sp.default_sort_key)
    if not atoms:
        return factor_terms(expr)
    return sp.collect(expr, atoms, func=factor_terms)


def natural_angles(kin: Kinematics) -> List[Dict[sp.Symbol, int]]:
    """The links' own angles (merged rotation angles of the body frames, e.g. q2 + q3), as
    frequency vectors; used to write spatial results with products like cos(q2) cos(q2 + q3)."""
    coords = set(kin.q)
    out: List[Dict[sp.Symbol, int]] = []
    for frames in kin.frames.values():
        rots = frames["body"].rotations or []
        for _axis, angle in rots:
            angle = sp.expand(angle)
            vec = {}
            ok = True
            for term in sp.Add.make_args(angle):
                coeff, rest = term.as_coeff_Mul()
                if rest in coords and coeff.is_Integer:
                    vec[rest] = vec.get(rest, 0) + int(coeff)
                elif not term.free_symbols:
                    continue
                else:
                    ok = False
            if ok and vec and vec not in out and {s: -n for s, n in vec.items()} not in out:
                out.append(vec)
    return out


# ------------------------------------------------------------------------------ fast exact paths
def factor_terms(expr) -> sp.Expr:
    """``sympy.factor_terms`` (content and common monomial taken out), computed directly for an
    expanded polynomial with rational coefficients; the same tree, several times faster.

    >>> from app.core.expressions import symbol
    >>> a, b, c = symbol("a"), symbol("b"), symbol("c")
    >>> factor_terms(-2*a*b - 4*a*c)
    -2*a*(b + 2*c)
    """
    parts = polynomial_terms(expr) if isinstance(expr, sp.Add) else None
    if parts is None:
        return sp.factor_terms(expr)
    con = sp.Rational(reduce(math.gcd, (abs(c.p) for c, _ in parts)),
                      reduce(lambda a, b: a * b // math.gcd(a, b), (c.q for c, _ in parts)))
    prim = [(c / con, p) for c, p in parts]
    if not con.is_Integer and any((c / con.q).is_Integer for c, _ in prim):
        # Add.as_content_primitive(clear=False) keeps the denominator inside in this case
        prim = [(c / con.q, p) for c, p in prim]
        con = sp.Integer(con.p)
    if all(c.is_negative for c, _ in prim):
        con, prim = -con, [(-c, p) for c, p in prim]
    common = {s: low for s in prim[0][1] if (low := min(p.get(s, 0) for _, p in prim))}
    inner = sp.Add(*[c * sp.Mul(*[s ** (e - common.get(s, 0)) for s, e in p.items()]) for c, p in prim])
    body = sp.Mul(*[s ** e for s, e in common.items()]) * inner if common else inner
    return _keep_coeff(con, body, clear=False, sign=True)


def collect_factored(expr, syms: Sequence[sp.Symbol]) -> sp.Expr:
    """``sympy.collect(expr, syms, func=sympy.factor)`` computed directly for an expanded polynomial:
    each term goes to the power of the first of ``syms`` it contains (or to 1), and each group's
    sum is factored.

    >>> from app.core.expressions import symbol
    >>> m, a, b, c = symbol("m"), symbol("a"), symbol("b"), symbol("c")
    >>> collect_factored(m*a**2 + 2*m*a*b + m*b**2 + c, [m])
    c + m*(a + b)**2
    """
    parts = polynomial_terms(expr)
    if parts is None:
        return sp.collect(expr, syms, func=_factor)
    groups: Dict[sp.Expr, list] = {}
    for c, powers in parts:
        key = sp.S.One
        for sym in syms:
            if powers.get(sym):
                key = sym ** powers[sym]
                break
        rest = c * sp.Mul(*[s ** e for s, e in powers.items() if key is sp.S.One or s != key.as_base_exp()[0]])
        groups.setdefault(key, []).append(rest)
    return sp.Add(*[key * _factor(sp.Add(*rest)) for key, rest in groups.items()])


_FACTOR_CACHE: Dict[sp.Expr, sp.Expr] = {}
#: a group of more terms than this only has its common factors taken out: sympy's factor took
#: 20-60 ms for each of the few hundred such groups of a 6R arm with full inertia tensors, a fifth
#: of its derivation; no shipped robot has a group of more than 9 terms
FACTOR_TERMS = 12


def _factor(expr) -> sp.Expr:
    """``sympy.factor``, remembered by the primitive part (the same group coefficients recur
    across a model, often times a number: -2*(a*b + a*c) is factored as a*b + a*c)."""
    if not isinstance(expr, sp.Add):
        return expr if polynomial_terms(expr) is not None else sp.factor(expr)
    content, primitive = expr.as_content_primitive()
    if primitive.could_extract_minus_sign():
        content, primitive = -content, -primitive
    hit = _FACTOR_CACHE.get(primitive)
    if hit is None:
        if len(_FACTOR_CACHE) > 50000:
            _FACTOR_CACHE.clear()
        long = len(primitive.args) > FACTOR_TERMS
        hit = _FACTOR_CACHE[primitive] = sp.factor_terms(primitive) if long else sp.factor(primitive)
    return _keep_coeff(content, hit) if content != 1 else hit


def forget() -> None:
    """Empty the memories of this module (for cold benchmarks)."""
    _NICE_CACHE.clear()
    _FACTOR_CACHE.clear()
