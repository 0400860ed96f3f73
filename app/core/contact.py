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

    >>> static_torque([[1.0, 0.0], [0.0, 1.0]], [2.0, 3.0]).tolist()      # exact: products with 0 and 1
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
    >>> h.S_force.tolist(), h.S_velocity.tolist()       # exact: cos 0 = 1, sin 0 = 0, entries 0 and 1
    ([[0.0, 0.0], [0.0, 1.0]], [[1.0, 0.0], [0.0, 0.0]])
    """
    R = np.atleast_2d(np.asarray(rotation, float))
    n = R.shape[0]
    S = np.zeros((n, n))
    for i in force_axes:
        S[i, i] = 1.0
    Sf = R @ S @ R.T
    return HybridSelection(R, list(force_axes), Sf, np.eye(n) - Sf)


# ====================================================================== natural and artificial constraints
#: task-frame directions: translations along and rotations about x_t, y_t, z_t
VELOCITY_NAMES = ("v_x", "v_y", "v_z", "w_x", "w_y", "w_z")
FORCE_NAMES = ("F_x", "F_y", "F_z", "M_x", "M_y", "M_z")

#: motions a contact leaves free, by the type of the pair and its axis (0, 1, 2 = x_t, y_t, z_t):
#: indices into VELOCITY_NAMES
PAIRS = {
    "point": lambda a: [i for i in range(6) if i != a],            # frictionless point contact, normal a
    "planar": lambda a: [i for i in range(3) if i != a] + [3 + a],  # face on a plane of normal a
    "prismatic": lambda a: [a],                                     # e.g. a square peg in its hole
    "cylindrical": lambda a: [a, 3 + a],                            # a round peg, a door handle
    "revolute": lambda a: [3 + a],
    "spherical": lambda a: [3, 4, 5],
}


@dataclass
class TaskFrameConstraints:
    free: List[bool]                     # per direction: motion allowed by the environment
    commandable: List[bool]              # per direction: the robot can act along it
    natural_velocities: List[str]        # zero velocities imposed by the environment
    natural_forces: List[str]            # zero forces/moments (no reaction along free directions)
    force_controlled: List[str]          # artificial constraints on forces (commandable directions)
    velocity_controlled: List[str]       # artificial constraints on velocities (commandable directions)
    uncontrolled: List[str]              # artificial constraints the robot cannot impose
    S_f: np.ndarray                      # 6 x k selection of the force-controlled directions
    S_v: np.ndarray                      # 6 x (commandable - k) selection of the velocity-controlled ones


def task_frame_constraints(free: Sequence[int], commandable: Optional[Sequence[int]] = None) -> TaskFrameConstraints:
    """Natural constraints (v = 0 along blocked directions, F = 0 along free ones) and artificial
    constraints (the complement: forces along blocked directions, velocities along free ones), with
    the selection matrices of hybrid force/velocity control for the directions the robot commands.

    >>> c = task_frame_constraints(PAIRS["planar"](2), commandable=[0, 1, 2, 5])   # cube on a plane, SCARA
    >>> c.natural_velocities, c.force_controlled, c.velocity_controlled, c.uncontrolled
    (['v_z', 'w_x', 'w_y'], ['F_z'], ['v_x', 'v_y', 'w_z'], ['M_x', 'M_y'])
    """
    free_mask = [i in set(free) for i in range(6)]
    cmd = [True] * 6 if commandable is None else [i in set(commandable) for i in range(6)]
    f_idx = [i for i in range(6) if not free_mask[i] and cmd[i]]
    v_idx = [i for i in range(6) if free_mask[i] and cmd[i]]
    S_f = np.zeros((6, len(f_idx)))
    S_v = np.zeros((6, len(v_idx)))
    for k, i in enumerate(f_idx):
        S_f[i, k] = 1.0
    for k, i in enumerate(v_idx):
        S_v[i, k] = 1.0
    return TaskFrameConstraints(
        free_mask, cmd,
        [VELOCITY_NAMES[i] for i in range(6) if not free_mask[i]],
        [FORCE_NAMES[i] for i in range(6) if free_mask[i]],
        [FORCE_NAMES[i] for i in f_idx], [VELOCITY_NAMES[i] for i in v_idx],
        [(VELOCITY_NAMES if free_mask[i] else FORCE_NAMES)[i] for i in range(6) if not cmd[i]],
        S_f, S_v)
