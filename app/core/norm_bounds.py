"""Symbolic upper bounds of functions of the configuration and of the norm of a matrix of them.

A term of an expanded expression is  c * prod(params) * prod(sin/cos(...)^k) * prod(q_j^k):
|sin|, |cos| <= 1 and |q_j| <= max(|lo_j|, |hi_j|) over the range of a prismatic coordinate give
an upper bound of |term|; summing them bounds |expression| everywhere in the range. The physical
parameters are taken positive. For a symmetric positive semidefinite 2x2 matrix
[[a1, a2], [a2, a3]],

    lambda_max = (a1 + a3 + sqrt((a1 - a3)^2 + 4 a2^2)) / 2,

which does not decrease when a1, a3 or |a2| grow: bounds of the entries give a bound of
lambda_max (for n x n, Gershgorin's max_i sum_j |a_ij| is used). So ||A(q)|| <= alpha =
sqrt(bound of lambda_max(A^T A)).

>>> q, m, g0 = sp.symbols("q m g0", real=True)
>>> abs_bound(m*g0*sp.sin(q)*sp.cos(q) + m*g0*sp.cos(q)**2, {}, [m, g0])
2*g0*m
"""
from __future__ import annotations

from typing import Dict, Sequence, Tuple

import sympy as sp

from .errors import UserError


class BoundError(UserError):
    """A quantity the bound cannot handle (with the reason)."""


def abs_bound(expr, ranges: Dict[sp.Symbol, Tuple[sp.Expr, sp.Expr]], positive: Sequence[sp.Symbol]) -> sp.Expr:
    """An upper bound of |expr| for every angle and every coordinate in ``ranges`` (lo, hi)."""
    pos = {s: sp.Symbol(s.name, positive=True) for s in positive}
    back = {v: k for k, v in pos.items()}
    expr = sp.expand(sp.sympify(expr).xreplace(pos))
    ranges = {s: (sp.sympify(lo).xreplace(pos), sp.sympify(hi).xreplace(pos)) for s, (lo, hi) in ranges.items()}
    total = sp.Integer(0)
    for term in sp.Add.make_args(expr):
        factor = sp.Integer(1)
        for f in sp.Mul.make_args(term):
            base, power = (f.base, f.exp) if f.is_Pow else (f, sp.Integer(1))
            if isinstance(base, (sp.sin, sp.cos)):
                continue                                # |sin|, |cos| <= 1
            if base in ranges:
                lo, hi = ranges[base]
                top = hi if sp.sympify(lo).is_nonnegative else (-lo if sp.sympify(hi).is_nonpositive else sp.Max(sp.Abs(lo), sp.Abs(hi)))
                factor *= top ** power
            elif base.free_symbols - set(pos.values()):
                missing = sorted(s.name for s in base.free_symbols - set(pos.values()))
                raise BoundError(f"no range for {', '.join(missing)}: give it (range: {{coordinate: [lo, hi]}})")
            else:
                factor *= sp.Abs(f)
        total += factor
    return sp.simplify(total).xreplace(back)


def lambda_max_2x2(S: sp.Matrix) -> sp.Expr:
    """Largest eigenvalue of a symmetric 2x2 matrix."""
    a1, a2, a3 = S[0, 0], S[0, 1], S[1, 1]
    return (a1 + a3 + sp.sqrt((a1 - a3) ** 2 + 4 * a2 ** 2)) / 2


def norm_bound(A: sp.Matrix, ranges, positive) -> Tuple[sp.Matrix, sp.Expr]:
    """(entry bounds of A^T A, alpha >= max ||A(q)||_2 over the ranges)."""
    S = (A.T * A).applyfunc(sp.expand)
    B = S.applyfunc(lambda e: abs_bound(e, ranges, positive))
    if S.shape == (2, 2):
        lam = lambda_max_2x2(B)
    else:
        lam = sp.Max(*[sum(B[i, j] for j in range(B.cols)) for i in range(B.rows)])
    return B, sp.sqrt(lam)
