"""Whether a matrix of functions of q can be the inertia matrix of a robot: symmetry, no
dependence on the first coordinate (the base frame is arbitrary), positive definiteness for every
q (Sylvester: the leading minors of each diagonal block stay positive), with the extreme values
of the minors over q in closed form.

Extremes over q are found for expressions that are, apart from a constant,
- a polynomial of degree <= 2 in one trigonometric function t of one angle (t in [-1, 1]; sin^2
  is rewritten as 1 - cos^2), or
- sums of squares k w(q)^2 (k >= 0) whose bases vanish together somewhere (minimum 0);
anything else is refused with a message.

>>> a1, a2, q2 = sp.symbols("a1 a2 q2", real=True)
>>> minimum(a1 + 2*a2*sp.cos(q2), [q2])
a1 - 2*Abs(a2)
>>> maximum(-a2**2*sp.cos(q2)**2, [q2])
0
"""
from __future__ import annotations

import itertools
from typing import List, Optional, Sequence

import sympy as sp

from .errors import UserError


class DefinitenessError(UserError):
    """An expression whose extreme over q has no closed form here (with the reason)."""


def blocks(M: sp.Matrix) -> List[List[int]]:
    """Index sets of the diagonal blocks of M (connected through nonzero off-diagonal entries)."""
    n = M.rows
    parent = list(range(n))

    def root(i):
        while parent[i] != i:
            i = parent[i]
        return i
    for i in range(n):
        for j in range(i + 1, n):
            if sp.simplify(M[i, j]) != 0:
                parent[root(j)] = root(i)
    groups = {}
    for i in range(n):
        groups.setdefault(root(i), []).append(i)
    return [sorted(g) for g in sorted(groups.values())]


def leading_minors(M: sp.Matrix) -> List[sp.Expr]:
    return [M[0, 0]] + [sp.expand(M[:k, :k].det()) for k in range(2, M.rows + 1)]


def _angle_poly(expr, coords):
    """(t, coefficients [c0, c1, c2, ...]) with expr = sum c_k t^k, t = cos or sin of one angle."""
    e = sp.expand(expr)
    atoms = [f for f in e.atoms(sp.sin, sp.cos) if f.free_symbols & set(coords)]
    args = {f.args[0] for f in atoms}
    if len(args) != 1:
        raise DefinitenessError(f"{expr} depends on {len(args)} angles: no closed-form extreme here")
    theta = args.pop()
    s, c = sp.sin(theta), sp.cos(theta)
    t = sp.Dummy("t")
    if e.has(c):
        e = sp.expand(e.xreplace({s: sp.sqrt(1 - t ** 2), c: t}))
        var = c
    else:
        e = sp.expand(e.xreplace({s: t}))
        var = s
    if e.has(sp.sqrt(1 - t ** 2)) or (e.free_symbols & set(coords)):
        raise DefinitenessError(f"{expr} is not a polynomial in one sine or cosine")
    poly = sp.Poly(e, t)
    return var, [poly.coeff_monomial(t ** k) for k in range(poly.degree() + 1)]


def _poly_min(coeffs):
    """Minimum over t in [-1, 1] of c0 + c1 t + c2 t^2 (degree <= 2)."""
    c = list(coeffs) + [0] * (3 - len(coeffs))
    if len(coeffs) > 3:
        raise DefinitenessError("a polynomial of degree above 2 in a sine or cosine: no closed form here")
    c0, c1, c2 = (sp.sympify(x) for x in c[:3])
    if c2 == 0:
        return c0 - sp.Abs(c1)
    if c1 == 0:
        return c0 + (c2 if c2.is_nonpositive else (0 if c2.is_nonnegative else sp.Min(0, c2)))
    ends = [c0 - c1 + c2, c0 + c1 + c2]
    if c2.is_nonpositive:
        return sp.Min(*ends)
    raise DefinitenessError("a quadratic with a linear term and a leading coefficient of unknown sign")


def _vanish_together(bases, coords) -> bool:
    """Whether the bases are all zero at one configuration with angles in {0, pi/2, pi, -pi/2}."""
    grid = [0, sp.pi / 2, sp.pi, -sp.pi / 2]
    for point in itertools.product(grid, repeat=len(coords)):
        at = dict(zip(coords, point))
        if all(sp.simplify(b.xreplace(at)) == 0 for b in bases):
            return True
    return False


def minimum(expr, coords: Sequence[sp.Symbol], positive: Sequence[sp.Symbol] = ()) -> sp.Expr:
    """Minimum over every q of an expression of the forms in the module docstring (``positive``:
    symbols known to be positive)."""
    pos = {s: sp.Symbol(s.name, positive=True) for s in positive}
    if pos:
        back = {v: k for k, v in pos.items()}
        return minimum(sp.sympify(expr).xreplace(pos), coords).xreplace(back)
    coords = list(coords)
    expr = sp.sympify(expr)
    if not expr.free_symbols & set(coords):
        return expr
    const, squares, rest = sp.Integer(0), [], sp.Integer(0)
    for term in sp.Add.make_args(expr):
        if not term.free_symbols & set(coords):
            const += term
            continue
        k, w = term.as_coeff_Mul()
        coeff = sp.Mul(*[f for f in sp.Mul.make_args(w) if not f.free_symbols & set(coords)]) * k
        body = sp.Mul(*[f for f in sp.Mul.make_args(w) if f.free_symbols & set(coords)])
        if body.is_Pow and body.exp.is_even and body.exp > 0 and (coeff.is_nonnegative or coeff.is_positive):
            squares.append(body.base)
            continue
        rest += term
    if squares and rest != 0:
        raise DefinitenessError(f"{expr}: squares and other terms together: no closed-form minimum here")
    if squares:
        if not _vanish_together(squares, coords):
            raise DefinitenessError(f"{expr}: the squared terms do not vanish together at a simple configuration")
        return const
    var, coeffs = _angle_poly(rest, coords)
    return sp.simplify(const + _poly_min(coeffs))


def maximum(expr, coords: Sequence[sp.Symbol], positive: Sequence[sp.Symbol] = ()) -> sp.Expr:
    return sp.simplify(-minimum(-sp.sympify(expr), coords, positive))


def relative_form(M: sp.Matrix, q: Sequence[sp.Symbol], p: Sequence[sp.Symbol]) -> Optional[sp.Matrix]:
    """M in relative coordinates p1 = q1, p_k = q_k - q_(k-1) (from absolute angles):
    T^T M T with q = T p, T lower triangular of ones; None when the change is not linear."""
    n = len(q)
    T = sp.Matrix(n, n, lambda i, j: 1 if j <= i else 0)
    q_of_p = T * sp.Matrix(list(p))
    Mp = (T.T * sp.Matrix(M).xreplace(dict(zip(q, q_of_p))) * T).applyfunc(lambda e: sp.simplify(sp.expand(e)))
    return Mp
