"""Comparison of engine results with expected answers (used by the tests and by variants).

Symbolic answers are equal when the exact canonical form of their difference is zero, or, for
expressions outside that form, when they agree at 20 random points to 1e-9. Numbers compare to a
tolerance.

>>> same("sin(q)**2 + cos(q)**2", 1)
True
>>> same([["a", "b"]], [["a", "b + 1"]])
False
"""
from __future__ import annotations

import math
import random
from typing import Any, Mapping, Optional

import numpy as np
import sympy as sp

from .expressions import parse_expression, symbol
from .numeric import numeric_function
from .trig import TrigPoly


def as_sympy(value, definitions: Optional[Mapping[str, Any]] = None):
    """Expected values (strings, numbers, nested lists) -> sympy objects with real symbols; a
    definition may use the ones before it.

    >>> as_sympy(["2*b", 1], {"a": "m*l", "b": "a + 1"})
    Matrix([
    [2*l*m + 2],
    [        1]])
    """
    defs: dict = {}
    for name, text in (definitions or {}).items():
        defs[name] = _converted(text, dict(defs))
    return _converted(value, defs)


def _converted(value, defs: Mapping[str, Any]):
    """``as_sympy`` with the definitions already converted (each parsed once, however deep the list)."""
    if isinstance(value, (list, tuple)):
        items = [_converted(v, defs) for v in value]
        if items and all(isinstance(i, sp.MatrixBase) for i in items):
            return sp.Matrix([list(i) for i in items])
        return sp.Matrix(items)
    if isinstance(value, (sp.Basic, sp.MatrixBase)):
        return value
    if isinstance(value, (int, float)):
        return sp.sympify(value)
    return parse_expression(str(value), extra=defs)


def _realify(expr):
    """Replace plain symbols by the lab's real symbols of the same name."""
    expr = sp.sympify(expr)
    return expr.xreplace({s: symbol(s.name) for s in expr.free_symbols if isinstance(s, sp.Symbol)})


def _scalar_same(a, b, tol=1e-9) -> bool:
    d = sp.expand(_realify(a) - _realify(b))
    if d == 0:
        return True
    try:
        if TrigPoly.from_expr(d).is_zero():
            return True
    except Exception:
        pass
    ra, rb = _realify(a), _realify(b)
    syms = sorted(d.free_symbols | ra.free_symbols | rb.free_symbols, key=lambda s: s.name)
    f = numeric_function(syms, d, "math")
    rng = random.Random(7)
    scale_f = numeric_function(syms, sp.Abs(ra) + sp.Abs(rb) + 1, "math")
    for _ in range(20):
        vals = [rng.uniform(0.3, 1.7) for _ in syms]
        try:
            v, s = f(*vals), scale_f(*vals)
        except (ZeroDivisionError, ValueError):
            continue
        if abs(v) > tol * s:
            return False
    return True


def same(expected, computed, tol: float = 1e-9, definitions=None) -> bool:
    """True when the computed answer equals the expected one (symbolic, numeric or yes/no).

    >>> same(True, True), same(False, 0.0), same([True, False], [True, False])
    (True, False, True)
    """
    flags = (bool, np.bool_)
    if isinstance(expected, (list, tuple)) and any(isinstance(x, flags) for x in expected):   # yes/no per item
        items = list(computed) if isinstance(computed, (list, tuple, np.ndarray)) else None
        return items is not None and len(items) == len(expected) and all(
            same(x, y, tol, definitions) for x, y in zip(expected, items))
    if isinstance(expected, flags) or isinstance(computed, flags):
        return isinstance(expected, flags) and isinstance(computed, flags) and bool(expected) == bool(computed)
    e = as_sympy(expected, definitions)
    c = computed
    if isinstance(c, np.ndarray):
        c = c.tolist() if c.ndim else float(c)
    c = as_sympy(c)
    if isinstance(e, sp.MatrixBase) or isinstance(c, sp.MatrixBase):
        if not (isinstance(e, sp.MatrixBase) and isinstance(c, sp.MatrixBase)):
            return False
        if e.shape != c.shape:
            if e.shape == c.shape[::-1] and 1 in e.shape:
                e = e.T
            else:
                return False
        return all(same(e[i], c[i], tol) for i in range(len(e)))
    e, c = sp.sympify(e), sp.sympify(c)
    if e.is_number and c.is_number:
        ev, cv = complex(e), complex(c)
        return abs(ev - cv) <= tol * max(1.0, abs(ev))
    return _scalar_same(e, c)


def parallel(expected, computed, definitions=None) -> bool:
    """True when two vectors are non-zero multiples of each other (a null-space direction, which
    the print and the engine may scale differently).

    >>> parallel(["u", "v", "lam"], ["2*u", "2*v", "2*lam"]), parallel([1, 0], [0, 1])
    (True, False)
    """
    e = as_sympy(expected, definitions)
    c = as_sympy(computed.tolist() if isinstance(computed, np.ndarray) else computed)
    if not (isinstance(e, sp.MatrixBase) and isinstance(c, sp.MatrixBase)) or len(e) != len(c):
        return False
    e, c = list(e), list(c)
    if all(same(0, x) for x in c) or all(same(0, x) for x in e):
        return False
    return all(same(0, sp.expand(e[i] * c[j] - e[j] * c[i])) for i in range(len(e)) for j in range(i + 1, len(e)))

