"""Linear closed loops of lumped mechanical systems (force control, impedance, PD/PI laws):
Laplace transfer functions, characteristic polynomial, Routh criterion, equilibria, Lyapunov
function, numeric poles along a gain.

A loop is a list of equations ``e_k = 0`` linear in the coordinates q, their first and second
derivatives, first-order controller states z (an integral of an error, with derivative dz) and
constant inputs r (a desired force F_d). Constant terms (a spring's rest position) shift the
equilibrium and drop out of the transfer functions, which relate deviations.

>>> from app.core.expressions import symbol
>>> x, dx, ddx, m, k, b, Fd, kf = (symbol(n) for n in "x dx ddx m k b F_d k_f".split())
>>> loop = LinearLoop([m*ddx + b*dx + k*x - kf*(Fd - k*x)], [x], [], [Fd])
>>> sp.expand(loop.characteristic_polynomial())
b*s + k*k_f + k + m*s**2
>>> routh_column(sp.Poly(m*s**3 + b*s**2 + k*s + kf, s))[2]
(b*k - k_f*m)/b
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np
import sympy as sp

from .errors import UserError
from .expressions import symbol

s = sp.Symbol("s")


class LinearLoopError(UserError):
    """The system is not linear, or an equilibrium/transfer function does not exist."""


def derivative_symbol(name: str, order: int) -> sp.Symbol:
    """dq / ddq naming of the lab (velocities ``d<name>``, accelerations ``dd<name>``)."""
    return symbol("d" * order + name)


# ====================================================================== Routh criterion
def routh_table(poly: sp.Poly) -> List[List[sp.Expr]]:
    """Rows of the Routh table of a polynomial (highest power first). A zero in the first column
    is replaced by a small epsilon symbol ``eps`` (the classical device) so the table completes.

    >>> [row[0] for row in routh_table(sp.Poly(s**2 + 3*s + 2, s))]
    [1, 3, 2]
    """
    coeffs = [sp.sympify(c) for c in poly.all_coeffs()]
    n = len(coeffs)
    width = (n + 1) // 2
    rows = [coeffs[0::2] + [0] * (width - len(coeffs[0::2])),
            coeffs[1::2] + [0] * (width - len(coeffs[1::2]))]
    eps = sp.Symbol("eps", positive=True)
    for _ in range(n - 2):
        up, low = rows[-2], rows[-1]
        pivot = low[0] if sp.cancel(low[0]) != 0 else eps
        new = [sp.cancel((pivot * up[j + 1] - up[0] * low[j + 1]) / pivot) for j in range(width - 1)] + [0]
        rows.append(new)
    return rows[:n]


def routh_column(poly: sp.Poly) -> List[sp.Expr]:
    """First column of the Routh table: all roots lie in the open left half plane iff every
    entry has the sign of the first one."""
    return [row[0] for row in routh_table(poly)]


def _positive_symbols(expr, positive: Sequence[sp.Symbol]):
    """expr with the positive symbols replaced by positive dummies (for sympy's sign reasoning)."""
    reps = {p: sp.Symbol(p.name, positive=True) for p in positive}
    return expr.xreplace(reps), {v: k for k, v in reps.items()}


def strip_positive_factors(expr, positive: Sequence[sp.Symbol]) -> sp.Expr:
    """The factor of ``expr`` whose sign decides the sign of ``expr`` when the ``positive``
    symbols are positive (positive factors and denominators removed).

    >>> a, b, k = symbol("a"), symbol("b"), symbol("k")
    >>> strip_positive_factors(a*(k - 2)/(a + b), [a, b])
    k - 2
    """
    expr = sp.factor(sp.together(expr))
    if expr == 0:
        return expr
    pos_expr, back = _positive_symbols(expr, positive)
    sign = 1
    kept = []
    for factor in sp.Mul.make_args(pos_expr):
        base, exp = factor.as_base_exp()
        if factor.is_positive:
            continue
        if factor.is_negative:
            sign = -sign
            continue
        if exp.is_integer and exp < 0:
            if exp.is_odd:
                kept.append(base)        # 1/x has the sign of x
            continue                     # 1/x^2 > 0 where defined
        kept.append(factor)
    out = sign * sp.Mul(*kept)
    return sp.expand(out.xreplace(back))


@dataclass
class GainBound:
    gain: sp.Symbol
    relation: str            # ">" or "<"
    bound: sp.Expr


def solve_linear_condition(condition: sp.Expr, gain: sp.Symbol, positive: Sequence[sp.Symbol]) -> Optional[GainBound]:
    """condition > 0, affine in ``gain`` with a coefficient of known sign -> gain > bound or gain < bound.

    >>> k, m = symbol("k"), symbol("m")
    >>> b = solve_linear_condition(1 + k - m, k, [m])
    >>> b.relation, b.bound
    ('>', m - 1)
    """
    poly = sp.Poly(sp.expand(condition), gain)
    if poly.degree() != 1:
        return None
    a, c = poly.all_coeffs()
    pa, _ = _positive_symbols(a, positive)
    if pa.is_positive:
        rel = ">"
    elif pa.is_negative:
        rel = "<"
    else:
        return None
    return GainBound(gain, rel, sp.factor(sp.cancel(-c / a)))


def routh_conditions(poly: sp.Poly, positive: Sequence[sp.Symbol]) -> Tuple[List[sp.Expr], List[sp.Expr]]:
    """(first column, conditions): each first-column entry reduced to the factor that must be
    positive, in order; a condition that is a lone symbol (``k_i > 0``) is assumed in the later
    entries. Entries positive by assumption are left out of the conditions."""
    column = [sp.factor(sp.cancel(c)) for c in routh_column(poly)]
    positive = list(positive)
    lead, _ = _positive_symbols(column[0], positive)
    flip = -1 if lead.is_negative else 1
    conditions = []
    for entry in column:
        reduced = strip_positive_factors(flip * entry, positive)
        pos, _ = _positive_symbols(reduced, positive)
        if pos.is_positive:
            continue
        conditions.append(reduced)
        if isinstance(reduced, sp.Symbol):
            positive.append(reduced)
    return column, conditions


# ====================================================================== the loop
@dataclass
class Equilibrium:
    values: Dict[sp.Symbol, sp.Expr]        # coordinates (and controller states) at rest
    velocities: Dict[sp.Symbol, sp.Expr]    # constant velocities of a free motion (else empty)


class LinearLoop:
    """Equations e_k(q, q', q'', z, z', r) = 0, linear, with as many equations as unknowns."""

    def __init__(self, equations: Sequence[sp.Expr], coordinates: Sequence[sp.Symbol],
                 states: Sequence[sp.Symbol], inputs: Sequence[sp.Symbol]):
        self.equations = [sp.expand(e) for e in equations]
        self.q = list(coordinates)
        self.z = list(states)
        self.r = list(inputs)
        self.dq = [derivative_symbol(c.name, 1) for c in self.q]
        self.ddq = [derivative_symbol(c.name, 2) for c in self.q]
        self.dz = [derivative_symbol(c.name, 1) for c in self.z]
        if len(self.equations) != len(self.q) + len(self.z):
            raise LinearLoopError(f"{len(self.equations)} equations for {len(self.q) + len(self.z)} unknowns")
        variables = self.q + self.dq + self.ddq + self.z + self.dz + self.r
        for e in self.equations:
            try:
                poly = sp.Poly(e, *variables)
            except sp.PolynomialError:
                raise LinearLoopError(f"not linear (functions of the coordinates) in {e}") from None
            if poly.total_degree() > 1:
                raise LinearLoopError(f"not linear in the coordinates and inputs: {e}")
            if any(v.has(*variables) for v in poly.coeffs()):
                raise LinearLoopError(f"not linear (functions of the coordinates) in {e}")
        self._variables = variables

    # ---------------------------------------------------------------- Laplace form
    def laplace(self, exprs=None) -> Tuple[sp.Matrix, sp.Matrix]:
        """(A(s), B(s)) with A X = B R for X = (Q, Z), constants dropped (deviations)."""
        exprs = self.equations if exprs is None else exprs
        unknowns = len(self.q) + len(self.z)
        A = sp.zeros(len(exprs), unknowns)
        B = sp.zeros(len(exprs), len(self.r))
        for i, e in enumerate(exprs):
            for j, (q, dq, ddq) in enumerate(zip(self.q, self.dq, self.ddq)):
                A[i, j] = e.coeff(q) + s * e.coeff(dq) + s ** 2 * e.coeff(ddq)
            for j, (z, dz) in enumerate(zip(self.z, self.dz)):
                A[i, len(self.q) + j] = e.coeff(z) + s * e.coeff(dz)
            for j, r in enumerate(self.r):
                B[i, j] = -e.coeff(r)
        return A.applyfunc(sp.expand), B

    def output_row(self, output: sp.Expr) -> Tuple[sp.Matrix, sp.Matrix]:
        """(C(s), d) with Y = C X + d R for an output linear in q, q', z and r."""
        output = sp.expand(output)
        C = sp.zeros(1, len(self.q) + len(self.z))
        for j, (q, dq) in enumerate(zip(self.q, self.dq)):
            C[0, j] = output.coeff(q) + s * output.coeff(dq)
        for j, z in enumerate(self.z):
            C[0, len(self.q) + j] = output.coeff(z)
        d = sp.Matrix([[output.coeff(r) for r in self.r]])
        return C, d

    def characteristic_polynomial(self) -> sp.Expr:
        """det A(s), with the sign that makes the leading coefficient positive for positive symbols."""
        A, _ = self.laplace()
        det = sp.expand(A.det(method="berkowitz"))
        if det == 0:
            raise LinearLoopError("the closed loop is degenerate (det A(s) = 0)")
        lead = sp.Poly(det, s).LC()
        test = lead.xreplace({x: sp.Integer(1) for x in lead.free_symbols})
        return -det if test.is_number and test < 0 else det

    def transfer(self, output: sp.Expr, input_index: int = 0) -> Tuple[sp.Expr, sp.Expr]:
        """(numerator, denominator) of Y(s)/R_i(s), denominator the characteristic polynomial."""
        A, B = self.laplace()
        C, d = self.output_row(output)
        det = sp.expand(A.det(method="berkowitz"))
        num = sp.expand((C * A.adjugate(method="berkowitz") * B[:, input_index])[0] + d[0, input_index] * det)
        char = self.characteristic_polynomial()
        if sp.expand(char + det) == 0:
            num = -num
        return sp.factor(num), char

    # ---------------------------------------------------------------- steady states
    def equilibrium(self) -> Equilibrium:
        """Rest (q' = q'' = z' = 0), or, when the positions of some coordinates do not appear, the
        free motion at constant velocity of those coordinates (q'' = 0)."""
        rest = {v: 0 for v in self.dq + self.ddq + self.dz}
        eqs = [e.xreplace(rest) for e in self.equations]
        unknowns = self.q + self.z
        sol = _solve_linear(eqs, unknowns)
        if sol is not None:
            return Equilibrium(sol, {})
        free = [i for i, q in enumerate(self.q) if all(e.coeff(q) == 0 for e in self.equations)]
        if not free:
            raise LinearLoopError("no unique equilibrium")
        moving = {self.dq[i] for i in free}
        subs = {v: 0 for v in self.ddq + self.dz}
        subs.update({v: 0 for v in self.dq if v not in moving})
        eqs = [e.xreplace(subs) for e in self.equations]
        unknowns = [q for i, q in enumerate(self.q) if i not in free] + self.z + sorted(moving, key=self.dq.index)
        sol = _solve_linear(eqs, unknowns, allow_underdetermined=True)
        if sol is None:
            raise LinearLoopError("no unique equilibrium or steady motion")
        return Equilibrium({k: v for k, v in sol.items() if k not in moving},
                           {k: v for k, v in sol.items() if k in moving})

    # ---------------------------------------------------------------- Lyapunov
    def second_order_matrices(self):
        """(M, D, K) of the coordinates' rows when the loop has no controller states."""
        n = len(self.q)
        M, D, K = (sp.zeros(n, n) for _ in range(3))
        for i, e in enumerate(self.equations):
            for j in range(n):
                M[i, j], D[i, j], K[i, j] = e.coeff(self.ddq[j]), e.coeff(self.dq[j]), e.coeff(self.q[j])
        return M, D, K

    def lyapunov(self, eq: Equilibrium) -> Optional[Tuple[sp.Expr, sp.Expr]]:
        """V = 1/2 q'^T M q' + 1/2 (q - q_e)^T K (q - q_e) and its derivative along the loop, when
        there are no controller states and M, K are symmetric (None otherwise)."""
        if self.z or eq.velocities:
            return None
        M, D, K = self.second_order_matrices()
        if M != M.T or any(sp.expand(x) != 0 for x in K - K.T):
            return None
        dq = sp.Matrix(self.dq)
        e = sp.Matrix([q - sp.factor(eq.values[q]) for q in self.q])
        V = (dq.T * M * dq)[0] / 2 + (e.T * K.applyfunc(sp.factor) * e)[0] / 2
        rest = sp.Matrix([-e.xreplace({a: 0 for a in self.ddq}) for e in self.equations])
        accel = M.LUsolve(rest)
        V_dot = sum(V.diff(q) * d for q, d in zip(self.q, self.dq)) + sum(V.diff(d) * a for d, a in zip(self.dq, accel))
        return V, sp.factor(sp.cancel(sp.expand(V_dot)))


def _solve_linear(eqs, unknowns, allow_underdetermined=False) -> Optional[Dict[sp.Symbol, sp.Expr]]:
    """Unique solution of linear equations (more equations than unknowns only when consistent and
    ``allow_underdetermined``), None when there is none or it is not unique."""
    A, b = sp.linear_eq_to_matrix([sp.expand(e) for e in eqs], unknowns)
    m = len(unknowns)
    if A.rows < m or (A.rows > m and not allow_underdetermined):
        return None
    for rows in itertools.combinations(range(A.rows), m):
        As = A.extract(list(rows), list(range(m)))
        if sp.cancel(As.det(method="berkowitz")) == 0:
            continue
        x = As.LUsolve(b.extract(list(rows), [0]))
        sol = {u: sp.factor(sp.cancel(v)) for u, v in zip(unknowns, x)}
        residual = A * sp.Matrix([sol[u] for u in unknowns]) - b
        if all(sp.cancel(r) == 0 for r in residual):
            return sol
        return None
    return None


def second_order_gains(error: sp.Expr, t: sp.Symbol) -> Tuple[sp.Expr, sp.Expr]:
    """(k_P, k_D) with e'' + k_D e' + k_P e = 0 for every t, for a prescribed error transient e(t)
    (a solution of some such equation: sums of exponentials, times powers of t for double poles).

    >>> t = symbol("t")
    >>> second_order_gains(symbol("e0") * (2*sp.exp(-5*t) - sp.exp(-10*t)), t)
    (50, 15)
    """
    kp, kd = sp.Symbol("k_P"), sp.Symbol("k_D")
    residual = error.diff(t, 2) + kd * error.diff(t) + kp * error
    samples = [sp.expand(residual.subs(t, v)) for v in (0, 1, 2, 3)]
    sol = sp.solve(samples, [kp, kd], dict=True)
    if len(sol) != 1 or kp not in sol[0] or kd not in sol[0]:
        raise LinearLoopError("no gains make this transient a solution of e'' + k_D e' + k_P e = 0")
    gains = sp.simplify(sol[0][kp]), sp.simplify(sol[0][kd])
    if sp.simplify(residual.subs({kp: gains[0], kd: gains[1]})) != 0:
        raise LinearLoopError("this transient does not solve e'' + k_D e' + k_P e = 0 for any constant gains")
    return gains


# ====================================================================== numbers
def max_real_part(coefficients: Sequence[float]) -> float:
    """Largest real part of the roots of a polynomial (coefficients, highest power first).

    >>> f"{max_real_part([1, 3, 2]):.4f}"
    '-1.0000'
    """
    c = np.trim_zeros(np.asarray(coefficients, float), "f")
    return float(np.max(np.roots(c).real)) if c.size > 1 else float("-inf")


def stability_boundaries(char: sp.Expr, gain: sp.Symbol, values: Dict[sp.Symbol, float],
                         upper: float = 1e9) -> List[Tuple[float, float, bool]]:
    """Intervals [a, b) of gain >= 0 with their stability, for a characteristic polynomial whose
    other symbols all have values. The ends are the positive real roots of the numerators of the
    Routh column (where a pole can cross the imaginary axis) and of the constant coefficient."""
    num = sp.Poly(sp.expand(char.xreplace(values)), s)
    if num.free_symbols - {s, gain}:
        raise LinearLoopError(f"no value for {', '.join(sorted(x.name for x in num.free_symbols - {s, gain}))}")
    ends = set()
    for entry in routh_column(num) + [num.all_coeffs()[-1]]:
        p = sp.fraction(sp.together(entry))[0]
        if not p.has(gain):
            continue
        for root in sp.Poly(p, gain).nroots():
            if abs(sp.im(root)) < 1e-9 and 0 < float(sp.re(root)) < upper:
                ends.add(float(sp.re(root)))
    cuts = [0.0] + sorted(ends) + [upper]
    out = []
    for a, b in zip(cuts, cuts[1:]):
        mid = (a + b) / 2 if b < upper else a + 1.0
        coeffs = [float(c.subs(gain, mid)) for c in num.all_coeffs()]
        out.append((a, b, max_real_part(coeffs) < 0))
    return out
