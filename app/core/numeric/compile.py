"""The one way from a sympy expression to a numeric function in the lab.

``numeric_function`` is the only call of ``sympy.lambdify`` in ``app/`` (tests/test_architecture.py
checks it): every compiled function goes through here, so how expressions are compiled (modules, common
subexpression elimination) is decided in one place. Functions worth keeping are kept by the
robot's compiled model (``app.core.numeric.model.CompiledModel``), never in module-level caches of
other modules.

>>> import sympy as sp
>>> x = sp.Symbol("x")
>>> numeric_function([x], x ** 2 + 1)(3.0)      # exact: small integers in binary floating point
10.0
"""
from __future__ import annotations

import sympy as sp


def numeric_function(args, expr, modules="numpy", cse: bool = False):
    """``sympy.lambdify(args, expr, modules, cse=cse)``: numpy by default; ``"math"`` for scalar
    checks, ``"sympy"`` for exact evaluation; ``cse=True`` eliminates common subexpressions (worth
    it for the large expressions of a robot's model). The generated function gets no copy of the
    expression in its docstring: printing it took a quarter of the compile time of a 3R's model."""
    return sp.lambdify(args, expr, modules=modules, cse=cse, docstring_limit=0)
