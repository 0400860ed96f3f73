"""Joint accelerations reachable at a state under torque bounds: lo <= M(q) q'' + n(q, q') <= hi is
an intersection of bands, a convex polygon for two joints (a polytope in general). Its vertices
are where n of the band edges meet; the largest norm of q'' is at a vertex; q'' = 0 is reachable
exactly when lo <= n <= hi (the state can be kept at constant velocity).

>>> P = acceleration_polytope(np.eye(2), np.zeros(2), [-1, -2], [1, 2])
>>> np.round(P.vertices, 6).tolist()
[[-1.0, -2.0], [1.0, -2.0], [1.0, 2.0], [-1.0, 2.0]]
>>> f"{P.max_norm:.4f}", P.zero_feasible
('2.2361', True)
"""
from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations
from typing import List

import numpy as np

from .errors import UserError

TOL = 1e-9


class PolytopeError(UserError):
    """Inconsistent data for the acceleration polytope."""


@dataclass
class AccelerationPolytope:
    A: np.ndarray              # constraints A x <= b
    b: np.ndarray
    vertices: np.ndarray       # one row per vertex (counterclockwise for two joints)
    max_norm: float
    max_norm_vertex: np.ndarray
    zero_feasible: bool

    @property
    def empty(self) -> bool:
        return len(self.vertices) == 0


def acceleration_polytope(M, n, lower, upper) -> AccelerationPolytope:
    """The polytope {x : lower <= M x + n <= upper} and its vertices."""
    M = np.atleast_2d(np.asarray(M, float))
    k = M.shape[0]
    n, lo, hi = (np.asarray(v, float).reshape(-1) * np.ones(k) for v in (n, lower, upper))
    if np.any(lo > hi):
        raise PolytopeError("a lower torque bound is above the upper one")
    A = np.vstack([M, -M])
    b = np.concatenate([hi - n, n - lo])
    verts: List[np.ndarray] = []
    for rows in combinations(range(2 * k), k):
        Ak = A[list(rows)]
        if abs(np.linalg.det(Ak)) < 1e-12:
            continue
        x = np.linalg.solve(Ak, b[list(rows)])
        if np.all(A @ x <= b + TOL * (1 + np.abs(b))) and not any(np.allclose(x, v, atol=1e-10) for v in verts):
            verts.append(x)
    V = np.array(verts) if verts else np.zeros((0, k))
    if k == 2 and len(V):
        c = V.mean(axis=0)
        V = V[np.argsort(np.arctan2(V[:, 1] - c[1], V[:, 0] - c[0]))]
    if len(V):
        norms = np.linalg.norm(V, axis=1)
        i = int(np.argmax(norms))
        best, vmax = float(norms[i]), V[i]
    else:
        best, vmax = float("nan"), np.full(k, np.nan)
    return AccelerationPolytope(A, b, V, best, vmax, bool(np.all(lo <= n + TOL) and np.all(n <= hi + TOL)))
