"""Dynamics under holonomic constraints h(q) = 0 (k constraints on n coordinates):

    M(q) q'' + n(q, q') = S u + A^T(q) lambda,     A = dh/dq.

Completing A with rows D(q) to a nonsingular matrix gives the pseudo-velocities v = D q' and
[A; D]^-1 = [E F], so that on the constraint q' = F v, q'' = F v' + F' v, and

    F^T M F v' + F^T (M F' v + n) = F^T S u       (reduced dynamics: no multiplier),
    lambda = E^T (M (F v' + F' v) + n - S u)        (the multiplier, from the same equation).

The input u = M (F a + F' v) + n - A^T b (every coordinate actuated) decouples the two:
v' = a and lambda = b (hybrid force/velocity control of the constrained robot). All functions take
and return sympy matrices; ``tidy`` is the caller's simplifier.

>>> from app.core.expressions import symbol
>>> q1, q2 = symbol("q1"), symbol("q2")
>>> E, F, det = completion(sp.Matrix([[1, 1]]), sp.Matrix([[0, 1]]))
>>> F.T, det
(Matrix([[-1, 1]]), 1)
"""
from __future__ import annotations

from typing import Callable, List, Sequence, Tuple

import sympy as sp

from .errors import UserError
from .trig import TrigPoly


class ConstraintError(UserError):
    """A constraint or a completion that cannot be used (singular, wrong sizes)."""


def _identity(x):
    return x


def time_derivative(mat: sp.Matrix, q: Sequence[sp.Symbol], dq: Sequence[sp.Symbol]) -> sp.Matrix:
    """d/dt of a matrix of q along q' (sum of partial derivatives times q'_k)."""
    out = sp.zeros(*mat.shape)
    for qk, dk in zip(q, dq):
        out += mat.diff(qk) * dk
    return out


def is_zero(expr) -> bool:
    num = sp.fraction(sp.together(sp.sympify(expr)))[0]
    try:
        return TrigPoly.from_expr(sp.expand(num)).is_zero()
    except Exception:   # not a trigonometric polynomial: sympy decides
        return sp.simplify(num) == 0


def completion(A: sp.Matrix, D: sp.Matrix, tidy: Callable = _identity) -> Tuple[sp.Matrix, sp.Matrix, sp.Expr]:
    """(E, F, det [A; D]) with [A; D]^-1 = [E F]."""
    k, n = A.shape
    if D.cols != n or D.rows + k != n:
        raise ConstraintError(f"D needs {n - k} row(s) of {n} entries")
    AD = A.col_join(D)
    det = tidy(AD.det())
    if is_zero(det):
        raise ConstraintError("[A; D] is singular: D does not complete the constraint Jacobian")
    EF = (AD.adjugate() / AD.det()).applyfunc(tidy)
    return EF[:, :k], EF[:, k:], det


def generic_inertia(n: int, symbol: Callable) -> Tuple[sp.Matrix, sp.Matrix]:
    """A symmetric inertia matrix of symbols m_ij (i <= j) and a vector of symbols n_i."""
    M = sp.zeros(n, n)
    for i in range(n):
        for j in range(i, n):
            M[i, j] = M[j, i] = symbol(f"m{i + 1}{j + 1}")
    return M, sp.Matrix([symbol(f"n{i + 1}") for i in range(n)])


def solve_linear_constraints(h: sp.Matrix, unknowns: Sequence[sp.Symbol]) -> dict:
    """Solve h(q) = 0 for the given coordinates when it is linear in them."""
    try:
        A, b = sp.linear_eq_to_matrix(list(h), list(unknowns))
    except (sp.PolynomialError, ValueError):
        raise ConstraintError("the constraint is not linear in the coordinates to eliminate") from None
    if A.rows != len(unknowns) or is_zero(A.det()):
        raise ConstraintError("the constraint does not fix the coordinates to eliminate")
    return dict(zip(unknowns, list(A.LUsolve(b).applyfunc(sp.expand))))


def hybrid_input(M, n, A, F, F_dot_v, a: sp.Matrix, b: sp.Matrix) -> sp.Matrix:
    """u = M (F a + F' v) + n - A^T b: v' = a and lambda = b when every coordinate is actuated."""
    return M * (F * a + F_dot_v) + n - A.T * b


def min_norm_rows(B_v: sp.Matrix) -> List[List[int]]:
    """Groups of reduced equations that share inputs (connected components of B_v's rows)."""
    rows = list(range(B_v.rows))
    groups: List[List[int]] = []
    for r in rows:
        cols = {j for j in range(B_v.cols) if B_v[r, j] != 0}
        merged = [g for g in groups if any(any(B_v[x, j] != 0 for j in cols) for x in g)]
        new = [r] + [x for g in merged for x in g]
        groups = [g for g in groups if g not in merged] + [sorted(new)]
    return sorted(groups)
