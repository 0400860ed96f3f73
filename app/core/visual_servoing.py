"""Image-based visual servoing with point features of a pin-hole camera (focal length lambda).

A point P = (X, Y, Z) in the camera frame (Z > 0) is seen at u = lambda X / Z, v = lambda Y / Z.
When the camera moves with linear and angular velocity (V, W) expressed in its own frame, the
fixed point moves in the camera frame as P' = -V - W x P, and the feature moves as
f' = J_p(u, v, Z) (V, W) with the interaction matrix

    J_p = [ -lambda/Z   0          u/Z   u v/lambda            -(lambda + u^2/lambda)   v ]
          [  0         -lambda/Z   v/Z   lambda + v^2/lambda   -u v/lambda             -u ].

Several points stack their rows; the barycentre of N points has the mean of their matrices.
Camera motions that leave the features still form the null space of J_p.

>>> import sympy as sp
>>> lam, u, v, Z = sp.symbols("lam u v Z", positive=True)
>>> J = point_interaction_matrix(u, v, Z, lam)
>>> (J * sp.Matrix([u, v, lam, 0, 0, 0])).applyfunc(sp.simplify).T
Matrix([[0, 0]])
"""
from __future__ import annotations

from typing import List, Sequence

import numpy as np
import sympy as sp

COMPONENTS = ("v_x", "v_y", "v_z", "w_x", "w_y", "w_z")


def point_interaction_matrix(u, v, Z, lam) -> sp.Matrix:
    """2 x 6 interaction matrix of one point feature (symbolic or numeric entries)."""
    return sp.Matrix([[-lam / Z, 0, u / Z, u * v / lam, -(lam + u ** 2 / lam), v],
                      [0, -lam / Z, v / Z, lam + v ** 2 / lam, -u * v / lam, -u]])


def interaction_matrix(points: Sequence[Sequence], lam, combine: str = "stack") -> sp.Matrix:
    """Stacked (2N x 6) or mean (2 x 6, image barycentre) interaction matrix of N points (u, v, Z)."""
    mats = [point_interaction_matrix(u, v, Z, lam) for u, v, Z in points]
    if combine == "mean":
        return (sum(mats, sp.zeros(2, 6)) / len(mats)).applyfunc(sp.expand)
    return sp.Matrix.vstack(*mats)


def null_basis(J: sp.Matrix) -> List[sp.Matrix]:
    """Basis of the null space in reduced row echelon form (one vector per free variable, as the
    symbolic null of Matlab returns it), entries cancelled."""
    return [v.applyfunc(lambda e: sp.factor(sp.cancel(e))) for v in J.nullspace(simplify=sp.cancel)]


def restricted_null_basis(J: sp.Matrix, components: Sequence[int]) -> List[sp.Matrix]:
    """Null-space vectors of J that use only the given components (others zero), as 6-vectors."""
    basis = null_basis(J[:, list(components)])
    out = []
    for b in basis:
        full = sp.zeros(J.cols, 1)
        for k, c in enumerate(components):
            full[c] = b[k]
        out.append(primitive(full))
    return out


def reparametrized(J_p: sp.Matrix, coordinates: Sequence[sp.Symbol], u_of, v_of, u=None, v=None, damping=None) -> dict:
    """Interaction matrix of one point feature written with other image coordinates s (e.g. polar
    rho, theta) given through u = u(s), v = v(s): with J_t = d(u, v)/ds, s' = J_t^-1 J_p (V, W).
    Returns J_t, its determinant and inverse, the new matrix J_s (entries simplified), the zero
    entries of J_p and J_s as (row, component) pairs and, with ``damping`` (sigma), the damped
    inverse J_t^T (sigma^2 I + J_t J_t^T)^-1 and its determinant.

    >>> rho, th, lam, Z = sp.symbols("rho theta lam Z", positive=True)
    >>> u, v = sp.symbols("u v")
    >>> r = reparametrized(point_interaction_matrix(u, v, Z, lam), [rho, th], rho*sp.cos(th), rho*sp.sin(th), u, v)
    >>> r["det_J_t"], r["J_s"][0, 2], r["J_s"][1, 5], r["zeros_s"]
    (rho, rho/Z, -1, [(0, 'w_z'), (1, 'v_z')])
    """
    u = u if u is not None else sp.Symbol("u")
    v = v if v is not None else sp.Symbol("v")
    uv = sp.Matrix([u_of, v_of])
    J_t = uv.jacobian(sp.Matrix(list(coordinates))).applyfunc(sp.simplify)
    det = sp.simplify(J_t.det())
    J_t_inv = J_t.inv().applyfunc(sp.simplify)
    J_s = (J_t_inv * J_p.xreplace({u: u_of, v: v_of})).applyfunc(lambda e: sp.factor(sp.trigsimp(sp.expand(e))))

    def zeros(J):
        return [(i, COMPONENTS[j]) for i in range(J.rows) for j in range(J.cols) if J[i, j] == 0]

    out = {"J_t": J_t, "det_J_t": det, "J_t_inv": J_t_inv, "J_s": J_s, "zeros_p": zeros(J_p), "zeros_s": zeros(J_s)}
    if damping is not None:
        def tidy(e):
            return sp.factor(sp.trigsimp(sp.cancel(e)))

        dls = (J_t.T * (damping ** 2 * sp.eye(J_t.rows) + J_t * J_t.T).inv()).applyfunc(tidy)
        out["J_t_dls"] = dls
        out["det_J_t_dls"] = tidy(dls.det())
    return out


def primitive(vector: sp.Matrix) -> sp.Matrix:
    """The vector scaled to polynomial entries without a common factor (direction kept)."""
    entries = [sp.together(e) for e in vector]
    dens = [sp.fraction(e)[1] for e in entries if e != 0]
    if not dens:
        return vector
    scale = sp.lcm_list(dens) if len(dens) > 1 else dens[0]
    out = [sp.expand(sp.cancel(e * scale)) for e in entries]
    nonzero = [e for e in out if e != 0]
    common = sp.gcd_list(nonzero) if len(nonzero) > 1 else nonzero[0]
    return sp.Matrix([sp.factor(sp.cancel(e / common)) for e in out])


# ====================================================================== numbers
def project(points_camera: np.ndarray, lam: float) -> np.ndarray:
    """Features (u, v) and depths Z of points given in the camera frame: rows (u, v, Z)."""
    P = np.atleast_2d(np.asarray(points_camera, float))
    if np.any(P[:, 2] <= 0):
        raise ValueError("a point is behind the camera (Z <= 0)")
    return np.column_stack([lam * P[:, 0] / P[:, 2], lam * P[:, 1] / P[:, 2], P[:, 2]])


def numeric_interaction_matrix(features: np.ndarray, lam: float) -> np.ndarray:
    """Stacked interaction matrix for rows (u, v, Z)."""
    rows = []
    for u, v, Z in np.atleast_2d(features):
        rows += [[-lam / Z, 0, u / Z, u * v / lam, -(lam + u * u / lam), v],
                 [0, -lam / Z, v / Z, lam + v * v / lam, -u * v / lam, -u]]
    return np.array(rows)


def camera_twist_jacobian(J_world: np.ndarray, R_camera: np.ndarray) -> np.ndarray:
    """6 x n Jacobian of the camera twist (V, W) in camera axes from the world geometric Jacobian
    of the camera origin: blockdiag(R^T, R^T) J."""
    T = np.zeros((6, 6))
    T[:3, :3] = T[3:, 3:] = R_camera.T
    return T @ J_world
