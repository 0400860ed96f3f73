"""Multivariate factoring that takes the same time on every run.

sympy factors a polynomial in several variables with Wang's algorithm, which substitutes random
integers for all variables but one. The integers come from sympy's own generator, seeded afresh
by every process, and about one draw in two hundred makes the Hensel lifting blow up: the
determinant of J J^T of a planar 3R, factored in 0.04 s on most runs, then runs for minutes (a
page that freezes, a test that times out on one machine and not on another).

`install()` gives the factoring a generator of its own that draws mostly zeros: substitution points
with few nonzero entries keep the lifted polynomials sparse (on the determinant above, none of 1500
seeds ran over 0.3 s, against one in two hundred hanging with sympy's draws). The generator is one
stream, started again from a fixed seed by `restart()` at the beginning of every exercise solution
and every derivation, so the same job draws the same points on every run and every CPU (jobs that
run at once in the server's threads share the stream, and stay sparse). (It is a
stream and not a fresh generator per call because Wang's algorithm restarts itself with a wider
range when its points were unlucky, and fresh-but-identical draws would repeat the bad luck
forever.) The factors are unique, so only the time changes, never the answer. A caller that passes
sympy an explicit seed keeps it.

The patch is applied when sympy's factoring module is imported (or at once, if it already was):
`app/__init__.py` calls `install()`, so nothing under `app/` imports sympy before it.

>>> install()
>>> import sympy as sp
>>> x, y, z = sp.symbols("x y z")
>>> sp.factor(sp.expand((x*y + z) * (x - y*z + 1)))
(x*y + z)*(x - y*z + 1)
"""
from __future__ import annotations

import importlib.abc
import importlib.util
import random
import sys

FACTORING_MODULE = "sympy.polys.factortools"
FIXED_SEED = 20041103          # any fixed number
ZERO_SHARE = 0.75              # share of substituted variables set to zero
_STREAM = random.Random(FIXED_SEED)


def restart() -> None:
    """Start the factoring's draws again from the fixed seed (at the beginning of a job)."""
    _STREAM.seed(FIXED_SEED)


def sparse_randint(seed=None):
    """A `randint(a, b)` for Wang's substitution points: reproducible and mostly zero.

    >>> draw = sparse_randint()
    >>> restart(); first = [draw(-3, 3) for _ in range(20)]
    >>> restart(); first == [draw(-3, 3) for _ in range(20)]
    True
    >>> sum(draw(-3, 3) == 0 for _ in range(1000)) > 700
    True
    """
    if seed is not None:
        return _SYMPY_RANDINT[0](seed)

    def draw(low: int, high: int) -> int:
        if low <= 0 <= high and _STREAM.random() < ZERO_SHARE:
            return 0
        return _STREAM.randint(low, high)

    return draw


_SYMPY_RANDINT: list = []       # sympy's own _randint, kept for callers that pass a seed


def _patch(module) -> None:
    if getattr(module, "_randint", None) is sparse_randint:
        return
    _SYMPY_RANDINT[:] = [module._randint]
    module._randint = sparse_randint


class _PatchOnImport(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Finds sympy's factoring module through the normal machinery and patches it once loaded."""

    def find_spec(self, name, path=None, target=None):
        if name != FACTORING_MODULE:
            return None
        sys.meta_path.remove(self)
        try:
            spec = importlib.util.find_spec(name)
        finally:
            sys.meta_path.insert(0, self)
        if spec is None or spec.loader is None:
            return None
        self._loader = spec.loader
        spec.loader = self
        return spec

    def create_module(self, spec):
        return self._loader.create_module(spec)

    def exec_module(self, module):
        self._loader.exec_module(module)
        _patch(module)
        if self in sys.meta_path:
            sys.meta_path.remove(self)


def install() -> None:
    """Patch sympy's multivariate factoring now or when it is first imported (idempotent)."""
    if FACTORING_MODULE in sys.modules:
        _patch(sys.modules[FACTORING_MODULE])
    elif not any(isinstance(f, _PatchOnImport) for f in sys.meta_path):
        sys.meta_path.insert(0, _PatchOnImport())
