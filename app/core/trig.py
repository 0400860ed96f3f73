"""Exact canonical form of trigonometric polynomials: sums of ``coefficient * cos(n.theta)`` and
``coefficient * sin(n.theta)`` with integer frequency vectors ``n``.

Products of sines and cosines are turned into sums by the product-to-sum identities, so that
``sin(q1)*sin(q1+q2) + cos(q1)*cos(q1+q2)`` becomes ``cos(q2)`` without any search. Coefficients
are polynomials in every other symbol (masses, lengths, prismatic coordinates, velocities ...).
Because the basis functions are linearly independent, two expressions are equal exactly when
their canonical forms are equal: this is how the engine simplifies and how it finds linear
dependencies in regressors.

>>> from app.core.expressions import symbol
>>> q1, q2 = symbol("q1"), symbol("q2")
>>> TrigPoly.from_expr(sp.sin(q1)*sp.sin(q1+q2) + sp.cos(q1)*sp.cos(q1+q2)).to_expr()
cos(q2)
"""
from __future__ import annotations

from collections import defaultdict
from fractions import Fraction
from typing import Dict, Iterable, List, Optional, Tuple

import sympy as sp

def polynomial_terms(expr) -> Optional[List[Tuple[sp.Rational, Dict[sp.Symbol, int]]]]:
    """[(coefficient, {symbol: exponent})] of an expanded sum of monomials with rational
    coefficients, or None for anything else.

    >>> from app.core.expressions import symbol
    >>> x, y = symbol("x"), symbol("y")
    >>> sorted((str(c), sorted((str(s), e) for s, e in p.items())) for c, p in polynomial_terms(2*x**2*y - y/3))
    [('-1/3', [('y', 1)]), ('2', [('x', 2), ('y', 1)])]
    """
    out = []
    for term in sp.Add.make_args(expr):
        c, rest = term.as_coeff_Mul()
        if not c.is_Rational:
            return None
        powers: Dict[sp.Symbol, int] = {}
        for f in sp.Mul.make_args(rest):
            if f is sp.S.One:
                continue
            if f.is_Symbol:
                powers[f] = powers.get(f, 0) + 1
            elif f.is_Pow and f.base.is_Symbol and f.exp.is_Integer and f.exp > 0:
                powers[f.base] = powers.get(f.base, 0) + int(f.exp)
            else:
                return None
        out.append((c, powers))
    return out


class Sparse(dict):
    """A polynomial {monomial: Fraction} (monomial: sorted (symbol, exponent) pairs) with exact
    rational coefficients: sums and integer scalings without sympy's expression machinery."""

    __slots__ = ()

    @staticmethod
    def of(expr) -> Optional["Sparse"]:
        parts = polynomial_terms(expr)
        if parts is None:
            return None
        out = Sparse()
        for c, powers in parts:
            key = tuple(sorted(powers.items(), key=lambda item: item[0].name))
            out[key] = out.get(key, 0) + Fraction(c.p, c.q)
        return Sparse({k: v for k, v in out.items() if v})

    def __add__(self, other):
        if not isinstance(other, dict):
            if other == 0:
                return self
            return NotImplemented
        out = Sparse(self)
        for k, v in other.items():
            total = out.get(k, 0) + v
            if total:
                out[k] = total
            else:
                out.pop(k, None)
        return out

    __radd__ = __add__

    def __mul__(self, factor):
        if not isinstance(factor, (int, Fraction)):
            return NotImplemented
        return Sparse({k: v * factor for k, v in self.items()} if factor else {})

    __rmul__ = __mul__

    def times(self, other: "Sparse") -> "Sparse":
        """The product of two polynomials."""
        out: Dict[tuple, Fraction] = {}
        for k1, v1 in self.items():
            for k2, v2 in other.items():
                key = _monomial_product(k1, k2)
                out[key] = out.get(key, 0) + v1 * v2
        return Sparse({k: v for k, v in out.items() if v})

    def __ne__(self, other):          # "!= 0" tests a polynomial for being non-zero
        return bool(self) if isinstance(other, int) and other == 0 else dict.__ne__(self, other)

    __hash__ = None

    def to_expr(self) -> sp.Expr:
        return sp.Add(*[sp.Rational(v.numerator, v.denominator) * sp.Mul(*[s ** e for s, e in k])
                        for k, v in self.items()])


def _monomial_product(k1: tuple, k2: tuple) -> tuple:
    if not k1:
        return k2
    if not k2:
        return k1
    powers = dict(k1)
    for sym, exp in k2:
        powers[sym] = powers.get(sym, 0) + exp
    return tuple(sorted(powers.items(), key=lambda item: item[0].name))


Frequency = Tuple[Tuple[sp.Symbol, int], ...]   # sorted (angle symbol, integer multiple) pairs
Key = Tuple[Frequency, str]                      # (frequency, "c" or "s")

_ONE: Key = ((), "c")


def _sort_key(sym: sp.Symbol):
    return sym.name


def _canonical(freq: Dict[sp.Symbol, int]) -> Tuple[Frequency, int]:
    """Sort a frequency, drop zeros, and make its first entry positive. Returns (freq, sign)."""
    items = tuple(sorted(((s, n) for s, n in freq.items() if n != 0), key=lambda it: _sort_key(it[0])))
    if items and items[0][1] < 0:
        return tuple((s, -n) for s, n in items), -1
    return items, 1


def _combine(f1: Frequency, f2: Frequency, sign: int) -> Dict[sp.Symbol, int]:
    out: Dict[sp.Symbol, int] = defaultdict(int)
    for s, n in f1:
        out[s] += n
    for s, n in f2:
        out[s] += sign * n
    return out


def _add_part(parts: Dict[Key, list], freq: Dict[sp.Symbol, int], kind: str, coeff) -> None:
    """Put ``coeff * cos|sin(freq . theta)`` into ``parts`` (lists of coefficients per basis
    function, summed once by ``_summed``), with the frequency made canonical (sin changes sign)."""
    canon, sign = _canonical(freq)
    if not canon:
        if kind == "c":
            parts[_ONE].append(coeff)
        return
    parts[(canon, kind)].append(sign * coeff if kind == "s" else coeff)


def _summed(parts: Dict[Key, list]) -> "TrigPoly":
    return TrigPoly({key: expanded_sum(coeffs) for key, coeffs in parts.items()})


def expanded_sum(coeffs: list) -> sp.Expr:
    """``sympy.expand(sympy.Add(*coeffs))``, the very same expression, multiplied out on exact
    dictionaries of monomials when every coefficient is a polynomial with rational coefficients
    (sums and products of those, positive integer powers): sympy's expand built every
    intermediate product as an expression, most of a large model's derivation.

    >>> from app.core.expressions import symbol
    >>> a, b, m = symbol("a"), symbol("b"), symbol("m")
    >>> expanded_sum([m*(a + b)**2, -m*a**2])
    2*a*b*m + b**2*m
    """
    total = Sparse()
    for coeff in coeffs:
        poly = _sparse(coeff)
        if poly is None:
            return sp.expand(sp.Add(*coeffs))
        total = total + poly
    return total.to_expr()


_SPARSE: Dict[sp.Expr, Optional[Sparse]] = {}


def _sparse(expr) -> Optional[Sparse]:
    """An expression as a Sparse polynomial (multiplied out), or None when it is not a polynomial
    with rational coefficients. Remembered: the same factors recur across a model."""
    hit = _SPARSE.get(expr, False)
    if hit is not False:
        return hit
    if expr.is_Add:
        out = Sparse()
        for arg in expr.args:
            part = _sparse(arg)
            if part is None:
                out = None
                break
            out = out + part
    elif expr.is_Mul:
        out = Sparse({(): Fraction(1)})
        for arg in expr.args:
            part = _sparse(arg)
            if part is None:
                out = None
                break
            out = out.times(part)
    elif expr.is_Pow and expr.exp.is_Integer and expr.exp > 1 and expr.base.is_Add:
        base = _sparse(expr.base)
        out = None
        if base is not None:
            out = Sparse({(): Fraction(1)})
            for _ in range(int(expr.exp)):
                out = out.times(base)
    else:
        out = Sparse.of(expr)           # a number, a symbol, a power of a symbol (or None)
    if len(_SPARSE) > 200000:
        _SPARSE.clear()
    _SPARSE[expr] = out
    return out


def forget() -> None:
    """Empty the memory of multiplied-out coefficients (for cold benchmarks)."""
    _SPARSE.clear()


class TrigPoly:
    """A trigonometric polynomial in canonical form (immutable in use; see module docstring)."""

    __slots__ = ("terms",)

    def __init__(self, terms: Dict[Key, sp.Expr] | None = None):
        self.terms: Dict[Key, sp.Expr] = {}
        if terms:
            for key, coeff in terms.items():
                if coeff != 0:
                    self.terms[key] = coeff

    # ----------------------------------------------------------------- construction
    @staticmethod
    def constant(value) -> "TrigPoly":
        return TrigPoly({_ONE: sp.sympify(value)}) if value != 0 else TrigPoly()

    @classmethod
    def from_expr(cls, expr) -> "TrigPoly":
        """Convert a sympy expression; trigonometric arguments must be integer combinations of
        symbols plus a constant. Anything else is kept as an opaque factor of the coefficients."""
        expr = sp.sympify(expr)
        cache: Dict[sp.Basic, TrigPoly] = {}
        return cls._convert(expr, cache)

    @classmethod
    def _convert(cls, expr: sp.Expr, cache) -> "TrigPoly":
        hit = cache.get(expr)
        if hit is not None:
            return hit
        if not expr.has(sp.sin, sp.cos):
            result = TrigPoly.constant(expr)
        elif expr.is_Add:
            result = TrigPoly()
            for arg in expr.args:
                result = result + cls._convert(arg, cache)
        elif expr.is_Mul:
            result = TrigPoly.constant(1)
            for arg in expr.args:
                result = result * cls._convert(arg, cache)
        elif expr.is_Pow and expr.exp.is_Integer and expr.exp > 0:
            base = cls._convert(expr.base, cache)
            result = base.power(int(expr.exp))
        elif isinstance(expr, (sp.sin, sp.cos)):
            result = cls._trig(expr)
        else:
            result = TrigPoly.constant(expr)   # opaque (e.g. 1/cos(q), sqrt(...))
        cache[expr] = result
        return result

    @classmethod
    def _trig(cls, expr) -> "TrigPoly":
        arg = sp.expand(expr.args[0])
        freq: Dict[sp.Symbol, int] = {}
        phase = sp.Integer(0)
        for term in sp.Add.make_args(arg):
            coeff, rest = term.as_coeff_Mul()
            if rest == 1:
                phase += coeff
            elif rest.is_Symbol and coeff.is_Integer:
                freq[rest] = freq.get(rest, 0) + int(coeff)
            elif rest.is_number:
                phase += term
            else:
                return TrigPoly.constant(expr)   # not an integer combination: keep opaque
        cos_phase, sin_phase = sp.cos(phase), sp.sin(phase)
        parts: Dict[Key, list] = defaultdict(list)
        if isinstance(expr, sp.cos):   # cos(x + p) = cos p cos x - sin p sin x
            _add_part(parts, freq, "c", cos_phase)
            _add_part(parts, freq, "s", -sin_phase)
        else:                          # sin(x + p) = cos p sin x + sin p cos x
            _add_part(parts, freq, "s", cos_phase)
            _add_part(parts, freq, "c", sin_phase)
        return TrigPoly({key: sp.Add(*coeffs) for key, coeffs in parts.items()})

    # ----------------------------------------------------------------- arithmetic
    def __add__(self, other) -> "TrigPoly":
        if not isinstance(other, TrigPoly):
            other = TrigPoly.constant(other)
        terms = dict(self.terms)
        for key, coeff in other.terms.items():
            terms[key] = terms.get(key, 0) + coeff
        return TrigPoly(terms)

    __radd__ = __add__

    def __neg__(self) -> "TrigPoly":
        return TrigPoly({k: -c for k, c in self.terms.items()})

    def __sub__(self, other) -> "TrigPoly":
        if not isinstance(other, TrigPoly):
            other = TrigPoly.constant(other)
        return self + (-other)

    def __rsub__(self, other) -> "TrigPoly":
        return (-self) + other

    def scale(self, factor) -> "TrigPoly":
        factor = sp.sympify(factor)
        if factor == 0:
            return TrigPoly()
        return TrigPoly({k: c * factor for k, c in self.terms.items()})

    def __mul__(self, other) -> "TrigPoly":
        if not isinstance(other, TrigPoly):
            return self.scale(other)
        parts: Dict[Key, list] = defaultdict(list)     # one sum per basis function, built once
        half = sp.Rational(1, 2)
        for (f1, k1), c1 in self.terms.items():
            for (f2, k2), c2 in other.terms.items():
                coeff = c1 * c2
                if not f1:
                    _add_part(parts, dict(f2), k2, coeff)
                    continue
                if not f2:
                    _add_part(parts, dict(f1), k1, coeff)
                    continue
                plus, minus = _combine(f1, f2, 1), _combine(f1, f2, -1)
                h = coeff * half
                if k1 == "c" and k2 == "c":
                    _add_part(parts, minus, "c", h)
                    _add_part(parts, plus, "c", h)
                elif k1 == "s" and k2 == "s":
                    _add_part(parts, minus, "c", h)
                    _add_part(parts, plus, "c", -h)
                elif k1 == "s" and k2 == "c":
                    _add_part(parts, plus, "s", h)
                    _add_part(parts, minus, "s", h)
                else:  # cos a sin b
                    _add_part(parts, plus, "s", h)
                    _add_part(parts, minus, "s", -h)
        return _summed(parts)

    @staticmethod
    def sum(polys: Iterable["TrigPoly"]) -> "TrigPoly":
        """The expanded sum of many polynomials, each coefficient added up once (a chain of ``+``
        rebuilds every coefficient at each step)."""
        parts: Dict[Key, list] = defaultdict(list)
        for poly in polys:
            for key, coeff in poly.terms.items():
                parts[key].append(coeff)
        return _summed(parts)

    __rmul__ = __mul__

    def power(self, n: int) -> "TrigPoly":
        result, base = TrigPoly.constant(1), self
        while n:
            if n & 1:
                result = result * base
            n >>= 1
            if n:
                base = base * base
        return result

    def expand(self) -> "TrigPoly":
        """Expand every coefficient (drops the terms that cancel)."""
        return TrigPoly({k: sp.expand(c) for k, c in self.terms.items()})

    def diff(self, var: sp.Symbol) -> "TrigPoly":
        """Exact derivative with respect to ``var`` (angle or coefficient variable)."""
        terms: Dict[Key, sp.Expr] = {}
        for (freq, kind), coeff in self.terms.items():
            dc = sp.diff(coeff, var)
            if dc != 0:
                terms[(freq, kind)] = terms.get((freq, kind), 0) + dc
            n = dict(freq).get(var, 0)
            if n:
                if kind == "c":   # d/dx cos(n x) = -n sin(n x)
                    key, value = (freq, "s"), -n * coeff
                else:
                    key, value = (freq, "c"), n * coeff
                terms[key] = terms.get(key, 0) + value
        return TrigPoly(terms).expand()

    def subs(self, mapping) -> "TrigPoly":
        """Substitute in the coefficients (not inside the trigonometric basis)."""
        return TrigPoly({k: sp.expand(c.subs(mapping)) for k, c in self.terms.items()}) 

    # ----------------------------------------------------------------- queries and output
    def is_zero(self) -> bool:
        return not any(sp.expand(c) != 0 for c in self.terms.values())

    def __eq__(self, other) -> bool:
        if not isinstance(other, TrigPoly):
            other = TrigPoly.constant(other)
        return (self - other).is_zero()

    def __hash__(self):  # pragma: no cover - not hashable by value on purpose
        return id(self)

    @staticmethod
    def basis_function(key: Key) -> sp.Expr:
        freq, kind = key
        if not freq:
            return sp.Integer(1)
        arg = sp.Add(*[n * s for s, n in freq])
        return sp.cos(arg) if kind == "c" else sp.sin(arg)

    def items(self):
        return self.terms.items()

    def term_count(self) -> int:
        """Terms written out: the terms of every coefficient, over all basis functions."""
        return sum(len(sp.Add.make_args(coeff)) for coeff in self.terms.values())

    def to_expr(self, factor_coefficients: bool = False) -> sp.Expr:
        """Back to a sympy expression, one term per basis function."""
        out = []
        for key, coeff in self.terms.items():
            if factor_coefficients:
                coeff = sp.factor_terms(coeff)
            out.append(coeff * self.basis_function(key))
        return sp.Add(*out)

    def __repr__(self) -> str:
        return f"TrigPoly({self.to_expr()})"


def canonical(expr) -> sp.Expr:
    """Simplify an expression through the canonical form.

    >>> from app.core.expressions import symbol
    >>> q = symbol("q")
    >>> canonical(sp.sin(q)**2 + sp.cos(q)**2)
    1
    """
    return TrigPoly.from_expr(expr).to_expr()


def equal(a, b) -> bool:
    """Exact equality of two trigonometric-polynomial expressions."""
    return TrigPoly.from_expr(sp.sympify(a) - sp.sympify(b)).is_zero()


def matrix_to_trig(matrix: Iterable) -> list:
    return [TrigPoly.from_expr(e) for e in matrix]
