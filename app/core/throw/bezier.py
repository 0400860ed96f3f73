"""Bezier curves (Bernstein bases, exact degree elevation) and piecewise Chebyshev-Lobatto
quadrature, the numerical tools of the throw (no robot, no dynamics).
"""
from __future__ import annotations

from functools import lru_cache
from math import comb
from typing import List, Sequence

import numpy as np
from numpy.polynomial import chebyshev as npcheb

from ..errors import UserError


def elevate_bezier(points: Sequence[float], degree: int) -> List[float]:
    """Control points of the same Bezier polynomial written with a higher degree.

    >>> [round(v, 12) + 0.0 for v in elevate_bezier([0.0, 1.0], 2)]
    [0.0, 0.5, 1.0]
    """
    c = [float(v) for v in points]
    if degree < len(c) - 1:
        raise UserError(f"cannot lower the degree of a Bezier curve from {len(c) - 1} to {degree}")
    while len(c) - 1 < degree:
        n = len(c) - 1
        c = [c[0]] + [(i / (n + 1)) * c[i - 1] + (1 - i / (n + 1)) * c[i] for i in range(1, n + 1)] + [c[-1]]
    return c



def bernstein(degree: int, s: np.ndarray, derivative: int = 0) -> np.ndarray:
    """Matrix (len(s), degree + 1) mapping control points to the ``derivative``-th s-derivative.

    >>> (bernstein(2, np.array([0.5])) @ np.array([0.0, 1.0, 0.0])).round(12).tolist()
    [0.5]
    """
    s = np.asarray(s, dtype=float)
    n = degree - derivative
    if n < 0:
        return np.zeros((s.size, degree + 1))
    basis = np.stack([comb(n, k) * s ** k * (1 - s) ** (n - k) for k in range(n + 1)], axis=-1)
    diff = np.eye(degree + 1)
    for d in range(derivative):   # forward differences, scaled: n!/(n-r)! Delta^r c
        m = degree - d
        diff = m * (diff[1:] - diff[:-1])
    return basis @ diff


@lru_cache(maxsize=None)
def cheb_tables(P: int):
    """Chebyshev-Lobatto nodes on [-1, 1], values->coefficients matrix, cumulative integration matrix."""
    x = -np.cos(np.pi * np.arange(P) / (P - 1))
    V = npcheb.chebvander(x, P - 1)
    Vinv = np.linalg.inv(V)
    W = np.empty((P, P))
    for m in range(P):
        e = np.zeros(P)
        e[m] = 1.0
        W[:, m] = npcheb.chebval(x, npcheb.chebint(e, lbnd=-1))
    S = W @ Vinv
    S[0] = 0.0              # the integral from -1 to the first node (-1 itself) is 0, not a rounding of it
    return x, Vinv, S


class ChebPieces:
    """Piecewise Chebyshev-Lobatto representation of functions on [breaks[0], breaks[-1]].

    >>> mesh = ChebPieces(np.linspace(0.0, 1.0, 3), 8)
    >>> f = np.cos(mesh.nodes)
    >>> bool(abs(mesh.cumulative(f)[-1, -1] - np.sin(1.0)) < 1e-12)
    True
    """

    def __init__(self, breaks, P: int = 16):
        self.breaks = np.asarray(breaks, dtype=float)
        self.P = P
        x, self._Vinv, self._S = cheb_tables(P)
        self.h = np.diff(self.breaks)
        self.nodes = self.breaks[:-1, None] + 0.5 * (x[None, :] + 1.0) * self.h[:, None]   # (K, P)

    @property
    def pieces(self) -> int:
        return self.h.size

    def cumulative(self, f: np.ndarray) -> np.ndarray:
        """Integral from breaks[0] to every node of f given at the nodes (shape (..., K, P))."""
        local = np.einsum("ij,...kj->...ki", self._S, f) * (0.5 * self.h)[:, None]
        totals = local[..., -1]
        offsets = np.cumsum(totals, axis=-1) - totals
        return local + offsets[..., None]

    def tails(self, f: np.ndarray) -> np.ndarray:
        """Size of the last two Chebyshev coefficients per piece times half its length (error scale)."""
        coef = np.einsum("ij,...kj->...ki", self._Vinv, f)
        return (np.abs(coef[..., -1]) + np.abs(coef[..., -2])) * 0.5 * self.h

    def split(self, mask: np.ndarray) -> "ChebPieces":
        mids = 0.5 * (self.breaks[:-1] + self.breaks[1:])[mask]
        return ChebPieces(np.sort(np.concatenate([self.breaks, mids])), self.P)

    def interpolate(self, values: np.ndarray, where) -> np.ndarray:
        """Values (K, P) at the nodes -> values of the piecewise interpolant at points ``where``."""
        where = np.asarray(where, dtype=float)
        k = np.clip(np.searchsorted(self.breaks, where, side="right") - 1, 0, self.pieces - 1)
        x = 2.0 * (where - self.breaks[k]) / self.h[k] - 1.0
        coef = values @ self._Vinv.T                      # (K, P)
        return npcheb.chebval(x, coef[k].T, tensor=False)


