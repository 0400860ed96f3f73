"""Lyapunov analysis of a mechanical closed loop  M(q) q'' + C(q, q') q' = F(q, q').

F collects every generalized force but the inertial ones: the control law, external forces, minus
gravity, springs and friction. Along the motion the kinetic energy T = 1/2 q'^T M q' changes by
T' = q'^T F (M' - 2C is skew-symmetric), so for a candidate V = T + P(q)

    V' = q'^T (F(q, q') + grad P(q)).

When the position part F(q, 0) is a gradient field, P = -integral of it makes V' = q'^T (F(q, q') -
F(q, 0)) = -q'^T D q' for a damping matrix D: the energy-shaping candidate. LaSalle: where V' = 0
and D > 0, q' = 0 and then q'' = 0, so the largest invariant set is {F(q, 0) = 0} (the closed-loop
equilibria).

>>> q, dq, kp, kd, qd = sp.symbols("q dq kp kd q_d", real=True)
>>> F = sp.Matrix([kp*(qd - q) - kd*dq])
>>> P = potential(F.subs(dq, 0), [q], {q: qd})
>>> sp.factor(P)
kp*(q - q_d)**2/2
>>> derivative_along(F, [dq], P.diff(q) * sp.ones(1, 1))
-dq**2*kd
>>> dissipation(-dq**2*kd, [dq])
Matrix([[kd]])
"""
from __future__ import annotations

from typing import Dict, List, Optional, Sequence

import sympy as sp

from .errors import UserError
from .trig import TrigPoly


class LyapunovError(UserError):
    """A closed loop or candidate the analysis cannot handle (with the reason)."""


def is_zero(expr) -> bool:
    """Exact zero test of a rational trigonometric expression."""
    num, _den = sp.fraction(sp.cancel(sp.together(sp.sympify(expr))))
    return TrigPoly.from_expr(sp.expand(num)).is_zero()


def is_gradient(field: sp.Matrix, q: Sequence[sp.Symbol]) -> bool:
    """Whether a force field F(q) is (minus) a gradient: its Jacobian is symmetric."""
    Jf = sp.Matrix(field).jacobian(sp.Matrix(list(q)))
    n = len(q)
    return all(is_zero(Jf[i, j] - Jf[j, i]) for i in range(n) for j in range(i + 1, n))


def potential(field: sp.Matrix, q: Sequence[sp.Symbol], at_zero: Optional[Dict[sp.Symbol, sp.Expr]] = None) -> sp.Expr:
    """P(q) with -grad P = F(q) (F must be a gradient field), integrated coordinate by coordinate,
    shifted so that P vanishes at ``at_zero`` (default: at q = 0)."""
    field = sp.Matrix(field)
    q = list(q)
    if not is_gradient(field, q):
        raise LyapunovError("the position-dependent forces of the closed loop are not a gradient field "
                            "(no potential energy gives them): give the candidate explicitly")
    P = sp.Integer(0)
    for i, qi in enumerate(q):
        rest = -field[i] - sp.diff(P, qi)
        rest = sp.expand(sp.simplify(rest)) if not is_zero(rest) else sp.Integer(0)
        if any(sp.diff(rest, qj) != 0 and not is_zero(sp.diff(rest, qj)) for qj in q[:i]):
            raise LyapunovError("internal error: the potential integration left a term in an earlier coordinate")
        P += sp.integrate(rest, qi)
    ref = at_zero if at_zero is not None else {s: 0 for s in q}
    return sp.expand(P - P.subs(ref, simultaneous=True))


def derivative_along(F: sp.Matrix, dq: Sequence[sp.Symbol], grad_P: sp.Matrix) -> sp.Expr:
    """V' = q'^T (F + grad P) for V = T + P(q) along M q'' + C q' = F."""
    v = sp.Matrix(list(dq))
    return sp.expand((v.T * (sp.Matrix(F) + sp.Matrix(grad_P)))[0])


def dissipation(V_dot: sp.Expr, dq: Sequence[sp.Symbol]) -> Optional[sp.Matrix]:
    """D with V' = -q'^T D q' when V' is a quadratic form in the velocities (else None)."""
    dq = list(dq)
    H = sp.hessian(sp.expand(V_dot), dq)
    D = (-H / 2).applyfunc(sp.simplify)
    v = sp.Matrix(dq)
    if not is_zero(sp.expand(V_dot + (v.T * D * v)[0])):
        return None
    return D


def definiteness(D: sp.Matrix, positive: Sequence[sp.Symbol] = ()) -> str:
    """"positive definite", "positive semidefinite" or "indefinite or unknown" for a symmetric
    matrix whose entries may hold symbols assumed positive (gains, friction coefficients)."""
    pos = {s: sp.Symbol(s.name, positive=True) for s in positive}
    Dp = sp.Matrix(D).xreplace(pos)
    minors = [sp.simplify(Dp[:k, :k].det()) for k in range(1, Dp.rows + 1)]
    if all(m.is_positive for m in minors):
        return "positive definite"
    diag = [Dp[i, i] for i in range(Dp.rows)]
    if Dp.is_diagonal() and all(d.is_nonnegative for d in diag):
        return "positive semidefinite"
    return "indefinite or unknown"


def solve_linear_exactly(M: sp.Matrix, rhs: sp.Matrix) -> Optional[sp.Matrix]:
    """x = M^-1 rhs in closed form when adj(M) rhs is exactly divisible by det M as polynomials
    (sines and cosines taken as independent symbols), e.g. when rhs = M a + ...; None otherwise.

    >>> c, a, b = sp.symbols("c a b", real=True)
    >>> M = sp.Matrix([[2 + c, 1], [1, 1]])
    >>> solve_linear_exactly(M, M * sp.Matrix([a, b])).T
    Matrix([[a, b]])
    """
    M, rhs = sp.Matrix(M), sp.Matrix(rhs)
    det = sp.expand(M.det())
    num = (M.adjugate() * rhs).applyfunc(sp.expand)
    trig = set().union(det.atoms(sp.sin, sp.cos), *[e.atoms(sp.sin, sp.cos) for e in num])
    reps = {f: sp.Dummy() for f in trig}
    back = {v: k for k, v in reps.items()}
    D = det.xreplace(reps)
    gens = sorted(D.free_symbols | set().union(*[e.xreplace(reps).free_symbols for e in num]), key=str)
    out = []
    for e in num:
        quo, rem = sp.div(sp.Poly(e.xreplace(reps), *gens), sp.Poly(D, *gens))
        if not rem.is_zero:
            return None
        out.append(quo.as_expr().xreplace(back))
    return sp.Matrix(out)


def solve_in_interval(equation: sp.Expr, x: sp.Symbol, lo, hi) -> List[sp.Expr]:
    """Real solutions of one equation in one unknown with lo < x < hi (numbers everywhere else);
    a rational equation is reduced to its numerator polynomial.

    >>> x = sp.Symbol("x", real=True)
    >>> solve_in_interval(2*(2 - x) + (1/(x - 1) - 2)/(x - 1)**2, x, 1, 1.5)
    []
    """
    num, den = sp.fraction(sp.cancel(sp.together(equation)))
    if num.free_symbols - {x}:
        raise LyapunovError(f"give numbers for {sorted(s.name for s in num.free_symbols - {x})} to locate the equilibria")
    if num == 0:
        raise LyapunovError("the equation holds for every value in the interval (a continuum of equilibria)")
    out = []
    for r in sp.Poly(num, x).nroots(n=15):
        if abs(sp.im(r)) < 1e-12:
            v = float(sp.re(r))
            if float(lo) < v < float(hi) and abs(float(den.subs(x, v))) > 1e-12:
                out.append(sp.Float(v, 12))
    return out
