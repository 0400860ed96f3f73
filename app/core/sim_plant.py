"""The simulated plant: forces on points, surfaces, and the forward dynamics with them.

``PointForce`` and ``Surface`` are what a user asks for (``simulate(..., contacts=[...])``);
``_Contact`` is one of them resolved on a robot (its task point at the plant's parameters, its force
law) and ``_Plant`` the robot's ModelTerms with its passive joints and contacts: soft contacts add
J^T F, rigid ones a bilateral constraint whose force is solved exactly (Baumgarte-stabilized).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import List, Optional, Sequence, Tuple, Union

import numpy as np

from .errors import SimulationError
from .numeric import ModelTerms, TaskPoint


@dataclass
class PointForce:
    """A force F (world frame, newtons: x, y for planar robots) on a point, and optionally a moment
    (world frame, N m: one value about z for planar robots) on its body, between ``start`` and
    ``end`` seconds: a collision, a push, a payload, a contact wrench. Joint torque
    J^T F + J_w^T moment."""
    point: Union[str, Tuple]
    force: Sequence[float]
    start: float = 0.0
    end: float = math.inf
    moment: Optional[Sequence[float]] = None


@dataclass
class Surface:
    """A plane n^T p = offset that the point cannot cross; ``normal`` n points to the free side.

    ``stiffness`` None: rigid, a bilateral constraint (the point stays on the surface, the contact
    force is solved exactly; a run stops if the surface would have to pull). With a stiffness
    k (N/m) and damping d (N s/m): a compliant, unilateral wall F = (k delta - d delta') n for a
    penetration delta > 0. ``offset`` None: through the point's initial position."""
    point: Union[str, Tuple]
    normal: Sequence[float]
    offset: Optional[float] = None
    stiffness: Optional[float] = None
    damping: float = 0.0

    @property
    def rigid(self) -> bool:
        return self.stiffness is None


class _Contact:
    """A contact resolved on a robot: its task point (at the plant's parameters) and force law."""

    def __init__(self, spec, robot, values, q0):
        self.spec = spec
        self.point = TaskPoint(robot, spec.point, values)
        self.name = self.point.name
        dim = self.point.dim
        if isinstance(spec, PointForce):
            F = np.asarray(spec.force, dtype=float).reshape(-1)
            if F.size == 3 and dim == 2:
                if F[2] != 0:
                    raise SimulationError("a planar robot feels only in-plane forces (x, y)")
                F = F[:2]
            if F.size != dim or not np.all(np.isfinite(F)):
                raise SimulationError(f"force on {self.name}: expected {dim} finite components, got {list(spec.force)}")
            if not spec.end > spec.start:
                raise SimulationError(f"force on {self.name}: the end time must follow the start time")
            self.F = F
            self.kind = "force"
            self.moment = None
            if spec.moment is not None:
                mu = np.atleast_1d(np.asarray(spec.moment, dtype=float)).reshape(-1)
                if dim == 2 and mu.size == 1:
                    mu = np.array([0.0, 0.0, mu[0]])
                if mu.size != 3 or not np.all(np.isfinite(mu)) or (dim == 2 and np.any(mu[:2])):
                    raise SimulationError(f"moment on {self.name}: " + ("one value (about z) for a planar robot"
                                          if dim == 2 else "three finite components"))
                if self.point.body is None:
                    raise SimulationError(f"moment on {self.name}: the point is on the base, which does not move")
                self.moment = mu
        else:
            n = np.asarray(spec.normal, dtype=float).reshape(-1)
            if n.size == 3 and dim == 2:
                n = n[:2]
            if n.size != dim or not np.linalg.norm(n) > 0:
                raise SimulationError(f"surface at {self.name}: the normal needs {dim} components, not all zero")
            self.n = n / np.linalg.norm(n)
            self.offset = float(self.n @ self.point.position(q0)) if spec.offset is None else float(spec.offset)
            if spec.stiffness is not None and not spec.stiffness > 0:
                raise SimulationError("surface stiffness must be positive (omit it for a rigid surface)")
            if spec.damping < 0:
                raise SimulationError("surface damping must not be negative")
            self.kind = "rigid" if spec.rigid else "wall"

    def joint_torque(self, t, q, f) -> np.ndarray:
        """J^T f (+ J_w^T moment while a wrench acts) for the force f this contact exerts."""
        tau = self.point.jacobian(q).T @ f
        if self.kind == "force" and self.moment is not None and self.spec.start <= t < self.spec.end:
            tau = tau + self.point.angular_jacobian(q).T @ self.moment
        return tau

    def force(self, t, q, dq) -> np.ndarray:
        """Force on the robot (task coordinates) of a force or a compliant wall."""
        if self.kind == "force":
            return self.F if self.spec.start <= t < self.spec.end else np.zeros_like(self.F)
        pen = self.offset - self.n @ self.point.position(q)
        if pen <= 0:
            return np.zeros_like(self.n)
        rate = -(self.n @ (self.point.jacobian(q) @ dq))
        mag = self.spec.stiffness * pen + self.spec.damping * rate
        return max(mag, 0.0) * self.n


class _Plant:
    """The real robot: ModelTerms at the plant's parameters, passive joints, contacts."""

    #: Baumgarte stabilization of rigid contacts: phi'' + 2 w phi' + w^2 phi = 0
    BAUMGARTE = 50.0

    def __init__(self, terms: ModelTerms, contacts: List[_Contact]):
        self.terms = terms
        self.soft = [c for c in contacts if c.kind != "rigid"]
        self.rigid = [c for c in contacts if c.kind == "rigid"]
        self.contacts = contacts
        self.last_lambda = np.zeros(len(self.rigid))
        if not contacts:
            self.accel = terms.forward_dynamics
        else:
            self.accel = self._accel_contacts

    def _external(self, t, q, dq):
        tau = np.zeros(self.terms.n)
        for c in self.soft:
            F = c.force(t, q, dq)
            if F.any() or (c.kind == "force" and c.moment is not None):
                tau = tau + c.joint_torque(t, q, F)
        return tau

    def _accel_contacts(self, q, dq, tau, t=0.0):
        ext = self._external(t, q, dq) if self.soft else None
        if ext is not None:
            tau = tau + ext
        if not self.rigid:
            return self.terms.forward_dynamics(q, dq, tau)
        # M q'' = tau - bias + A^T lambda with A q'' = b (the constraint's acceleration, stabilized)
        Minv = self.terms.Minv(q)
        free = Minv @ (tau - self.terms.bias(q, dq))
        w = self.BAUMGARTE
        rows, b = [], []
        for c in self.rigid:
            p, J, jd = c.point.kinematics(q, dq)
            a = c.n @ J
            rows.append(a)
            b.append(-(c.n @ jd) - 2 * w * (a @ dq) - w * w * (c.n @ p - c.offset))
        if len(rows) == 1:        # one contact: a scalar equation
            a = rows[0]
            ma = Minv @ a
            lam = (b[0] - a @ free) / (a @ ma)
            self.last_lambda = np.array([lam])
            return free + ma * lam
        A = np.array(rows)
        MA = Minv @ A.T
        lam = np.linalg.solve(A @ MA, np.array(b) - A @ free)
        self.last_lambda = lam
        return free + MA @ lam

    def forces(self, t, q, dq, tau) -> List[np.ndarray]:
        """Contact forces on the robot (task coordinates), one per contact, at a state."""
        out = []
        if self.rigid:
            self._accel_contacts(q, dq, tau, t)
        k = 0
        for c in self.contacts:
            if c.kind == "rigid":
                out.append(self.last_lambda[k] * c.n)
                k += 1
            else:
                out.append(c.force(t, q, dq))
        return out
