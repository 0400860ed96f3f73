"""Contact: static forces, contact-force estimation and isolation, collision residuals, impedance
and hybrid force/velocity parameters. Numeric (numpy) functions; the robot-dependent pieces take
numeric Jacobians computed by ``app.core.jacobians``.

- Statics: a force F on a point with Jacobian J_c is balanced by the joint torque tau = -J_c^T F,
  and produces tau_c = J_c^T F on the joints (``static_torque``).
- Isolation: on a serial chain, tau_c = J_c^T F has zero components beyond the joint that moves the
  contact link, so the last nonzero component names the link (``isolate``).
- Estimation: F = (J_c^T)^# tau_c; with the contact point unknown on a link, J_c(l) = J_o + l J_u is
  affine in the distance l, which is recovered when enough joints precede the link
  (``estimate_contact``).
- Collision detection: the momentum residual r' = K_I (tau_c - r) converges to tau_c
  (``momentum_residual``); the energy residual sees only the power q'^T tau_c = v_c^T F.
- Impedance: M_d x'' + D_d x' + K_d x = F with natural frequency and damping
  (``impedance_gains``), or a double real eigenvalue (``critically_damped_gains``).
- Hybrid force/velocity: in a task frame R, selection matrices split the directions that are
  velocity controlled from those that are force controlled (``hybrid_selection``).

>>> Jc = np.array([[-0.1, 0.0, 0.0], [0.1732, 0.0, 0.0]])
>>> isolate(Jc.T @ np.array([1.0, 2.0]))
1
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import List, Optional, Sequence

import numpy as np

from .errors import UserError
from .jacobians import DEFAULT_THRESHOLD


class ContactError(UserError):
    """Contact data that cannot be used (sizes, an estimate that is not possible)."""


def static_torque(J, F) -> np.ndarray:
    """Joint torque J^T F produced by a force (or wrench) F applied where J is the Jacobian.

    >>> static_torque([[1.0, 0.0], [0.0, 1.0]], [2.0, 3.0]).tolist()
    [2.0, 3.0]
    """
    return np.atleast_2d(np.asarray(J, float)).T @ np.asarray(F, float).reshape(-1)


def isolate(tau, threshold: float = 1e-9) -> int:
    """1-based index of the last nonzero joint torque (0 if all vanish): the contact is on the link
    moved by that joint (or a later one whose Jacobian columns vanish there)."""
    tau = np.asarray(tau, float).reshape(-1)
    nz = np.flatnonzero(np.abs(tau) > threshold)
    return int(nz[-1]) + 1 if nz.size else 0


@dataclass
class ContactEstimate:
    force: np.ndarray            # in the base frame
    distance: Optional[float]    # along the link x axis (None if not estimated)
    estimated_distance: bool
    residual: float              # |tau_c - J_c^T F|
    jacobian: np.ndarray         # J_c at the distance used


def estimate_contact(J_origin, J_axis, tau_c, distance: Optional[float] = None,
                     threshold: float = DEFAULT_THRESHOLD) -> ContactEstimate:
    """Contact force from the joint torque it produces, tau_c = J_c^T F with J_c = J_o + l J_u.

    ``J_origin``: position Jacobian of the link frame origin; ``J_axis``: Jacobian of the unit
    vector along the link (the derivative of the link direction). With ``distance`` given,
    F = (J_c^T)^# tau_c. Without it, when J_u has rank one (planar links) tau_c = J_o^T F + mu a
    is linear in (F, mu = l u.F) and l = mu / (u.F)."""
    Jo = np.atleast_2d(np.asarray(J_origin, float))
    Ju = np.atleast_2d(np.asarray(J_axis, float))
    tau = np.asarray(tau_c, float).reshape(-1)
    if distance is not None:
        Jc = Jo + distance * Ju
        from .redundancy import pinv
        F = pinv(Jc.T, threshold) @ tau
        return ContactEstimate(F, float(distance), False, float(np.linalg.norm(tau - Jc.T @ F)), Jc)
    U, s, Vt = np.linalg.svd(Ju)
    if np.sum(s > threshold) != 1:
        raise ContactError("the contact distance can only be estimated when the link direction moves in a plane (rank-one J_u)")
    u, a = U[:, 0], s[0] * Vt[0]
    A = np.hstack([Jo.T, a[:, None]])
    if np.linalg.matrix_rank(A, tol=threshold) < A.shape[1]:
        raise ContactError("not enough independent joint torques to estimate both the force and its application point")
    sol, *_ = np.linalg.lstsq(A, tau, rcond=None)
    F, mu = sol[:-1], sol[-1]
    normal = u @ F
    if abs(normal) < threshold:
        raise ContactError("the force is along the link: its application point cannot be located")
    l = float(mu / normal)
    Jc = Jo + l * Ju
    return ContactEstimate(F, l, True, float(np.linalg.norm(tau - Jc.T @ F)), Jc)


def momentum_residual(tau_ext, gains, t) -> np.ndarray:
    """Response of the momentum residual r' = K_I (tau_ext - r), r(0) = 0, to a constant external
    torque: r(t) = (1 - exp(-K_I t)) tau_ext (diagonal gains)."""
    tau = np.asarray(tau_ext, float).reshape(-1)
    k = np.asarray(gains, float) * np.ones_like(tau)
    return (1 - np.exp(-k * float(t))) * tau


def impedance_gains(mass, omega, zeta):
    """(K_d, D_d) giving M_d x'' + D_d x' + K_d x with natural frequency omega and damping zeta.

    >>> [round(float(x), 2) for x in impedance_gains(5, 10, 0.7071)]
    [500.0, 70.71]
    """
    return mass * omega ** 2, 2 * zeta * omega * mass


def critically_damped_gains(mass, eigenvalue):
    """(K_d, D_d) with a double real eigenvalue -lambda: D = 2 m lambda, K = m lambda^2."""
    return mass * eigenvalue ** 2, 2 * mass * eigenvalue


def rotation2(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s], [s, c]])


@dataclass
class HybridSelection:
    rotation: np.ndarray          # task frame axes in the base frame (columns)
    force_axes: List[int]         # 0-based task-frame axes that are force controlled
    S_force: np.ndarray           # base-frame projector on the force-controlled directions
    S_velocity: np.ndarray        # base-frame projector on the velocity-controlled directions


def hybrid_selection(rotation, force_axes: Sequence[int]) -> HybridSelection:
    """Projectors R S R^T on the force- and velocity-controlled directions of a task frame R.

    >>> h = hybrid_selection(rotation2(0.0), [1])
    >>> h.S_force.tolist(), h.S_velocity.tolist()
    ([[0.0, 0.0], [0.0, 1.0]], [[1.0, 0.0], [0.0, 0.0]])
    """
    R = np.atleast_2d(np.asarray(rotation, float))
    n = R.shape[0]
    S = np.zeros((n, n))
    for i in force_axes:
        S[i, i] = 1.0
    Sf = R @ S @ R.T
    return HybridSelection(R, list(force_axes), Sf, np.eye(n) - Sf)
