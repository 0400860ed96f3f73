"""The throwing arm (a robot file with the three-link structure, the wrist passive on a spring)
at given parameter values: the VHC's constrained configuration q = Phi(theta) and the reduced
dynamics' alpha, beta, gamma (eqs. 3.14-3.20), vectorized over nodes and batches of throws;
``solve`` hands over to the reduced dynamics (``reduced.py``).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Dict, Mapping, Optional

import numpy as np

from ..dynamics import derive
from ..errors import UserError
from ..numeric import NumericModel, compiled_function
from ..robot import RobotModel, load_robot
from .bezier import bernstein
from .config import REQUIRED_PARAMETERS, ROBOT_NAME, Progress, SpecBatch, ThrowSpec, VHCError
from . import reduced
from .reduced import Release, ReducedSolution, Throw


def has_throwing_structure(robot: RobotModel) -> bool:
    """Whether a robot has the throwing arm's structure: three coordinates, the third passive, a
    point 'ball' and the parameters the engine reads by name (``REQUIRED_PARAMETERS``).

    >>> has_throwing_structure(load_robot("throwing_arm")), has_throwing_structure(load_robot("planar_2r"))
    (True, False)
    """
    return (robot.n == 3 and tuple(robot.actuated) == (True, True, False) and "ball" in robot.points
            and all(p in robot.parameters for p in REQUIRED_PARAMETERS))


@dataclass
class ConstraintState:
    """The constrained configuration along theta (arrays of shape (B, N); q-like ones (3, B, N))."""
    theta: np.ndarray
    q: np.ndarray          # Phi(theta)
    dq: np.ndarray         # Phi'(theta)   (joint speed = Phi' theta_dot)
    ddq: np.ndarray        # Phi''(theta)
    u: np.ndarray          # arccos argument of eq. (3.14) (reachable where |u| <= 1)
    alpha: Optional[np.ndarray] = None   # (3, B, N): M Phi'
    beta: Optional[np.ndarray] = None    # M Phi'' + C(Phi, Phi') Phi'
    gamma: Optional[np.ndarray] = None   # g + spring


class ThrowingArm:
    """The throwing arm's model (a robot file with the throwing arm's structure) at given parameter
    values, compiled for fast vectorized evaluation of constraints and reduced dynamics.

    ``params`` overrides robot parameters by name (m1, c3, J2, d3, l0, platform, g, ...).

    >>> arm = ThrowingArm(params={"platform": 0.0})
    >>> round(arm.values["l3"], 2), arm.limits["speed"].round(4).tolist()
    (0.24, [1.9199, 2.234, 3.2114])
    """

    def __init__(self, robot: RobotModel | str | None = None, params: Optional[Mapping[str, float]] = None):
        robot = load_robot(robot or ROBOT_NAME) if not isinstance(robot, RobotModel) else robot
        if not has_throwing_structure(robot):
            missing = [p for p in REQUIRED_PARAMETERS if p not in robot.parameters]
            raise UserError(f"robot '{robot.name}' does not have the throwing arm's structure (three "
                            f"coordinates, the third passive, a point 'ball', parameters {REQUIRED_PARAMETERS}; "
                            f"missing: {missing})")
        if robot.has_friction:
            raise UserError("the VHC reduced dynamics of the throwing arm assumes no friction")
        self.robot = robot
        self.numeric = NumericModel(robot, params)      # validates the values
        self.values = dict(self.numeric.values)
        for name in ("l1", "l2", "l3"):
            if self.values[name] <= 0:
                raise UserError(f"{name}: a link length must be positive (got {self.values[name]:g})")
        if self.values["platform"] + self.values["l0"] < 0:
            raise UserError("the shoulder (platform + l0) must not be below the ground")
        self.l1, self.l2, self.l3 = (self.values[n] for n in ("l1", "l2", "l3"))
        self.shoulder_height = self.values["platform"] + self.values["l0"]
        self.g = self.values["g"]
        self.parameter_names = list(robot.parameters)
        self._k_index = self.parameter_names.index("k")
        dyn = derive(robot)
        q, dq, p = robot.q, robot.dq, robot.parameter_symbols
        # compiled M(q, p) (9 entries), c(q, q', p) and g(q, p) + spring (3 each), p = parameter_vector(k):
        # entries broadcast over arrays of q (the reduced dynamics and the closed-loop plants use them)
        self.mass_matrix_fn = compiled_function(robot, "vhc:M", [q, p], list(dyn.M))
        self.coriolis_fn = compiled_function(robot, "vhc:c", [q, dq, p], list(dyn.c))
        self.gravity_spring_fn = compiled_function(robot, "vhc:G", [q, p], list(dyn.g + dyn.spring))
        self.limits = self._read_limits()
        self._check_kinematics()

    # ------------------------------------------------------------------ data
    def _read_limits(self) -> Dict[str, np.ndarray]:
        lo, hi, speed, torque = [], [], [], []
        for i, name in enumerate(self.robot.coordinates):
            lim = self.robot.limits.get(name)
            pos = lim.position if lim and lim.position else (-np.inf, np.inf)
            lo.append(pos[0])
            hi.append(pos[1])
            speed.append(lim.velocity if lim and lim.velocity else np.inf)
            if self.robot.actuated[i]:
                torque.append(lim.torque if lim and lim.torque else np.inf)
        return {"lower": np.array(lo), "upper": np.array(hi), "speed": np.array(speed), "torque": np.array(torque)}

    def _check_kinematics(self) -> None:
        """The robot file's ball point must be where eq. (3.1) puts it (else the VHC would be wrong)."""
        pos, _jac = self.numeric.named_point("ball")
        q = np.array([0.7, -0.4, 0.9])
        mine = self.ball_position(q[:, None])[:, 0]
        if not np.allclose(pos(q)[:2], mine, atol=1e-12):
            raise UserError(f"robot '{self.robot.name}': the point 'ball' is not at the tip of link 3 at "
                            f"(0, platform + l0) + l1, l2, l3 as the VHC of eq. (3.12) assumes")

    def ball_position(self, q: np.ndarray) -> np.ndarray:
        """Ball (x, y) [m], y from the ground, for joint angles q of shape (3, ...) (eq. 3.1 + platform)."""
        a1, a12 = q[0], q[0] + q[1]
        a123 = a12 + q[2]
        x = self.l1 * np.cos(a1) + self.l2 * np.cos(a12) + self.l3 * np.cos(a123)
        y = self.shoulder_height + self.l1 * np.sin(a1) + self.l2 * np.sin(a12) + self.l3 * np.sin(a123)
        return np.stack([x, y])

    def ball_velocity(self, q: np.ndarray, dq: np.ndarray) -> np.ndarray:
        """Ball velocity J(q) dq [m/s] for arrays of shape (3, ...)."""
        a1, a12 = q[0], q[0] + q[1]
        a123 = a12 + q[2]
        w1, w12 = dq[0], dq[0] + dq[1]
        w123 = w12 + dq[2]
        vx = -(self.l1 * np.sin(a1) * w1 + self.l2 * np.sin(a12) * w12 + self.l3 * np.sin(a123) * w123)
        vy = self.l1 * np.cos(a1) * w1 + self.l2 * np.cos(a12) * w12 + self.l3 * np.cos(a123) * w123
        return np.stack([vx, vy])

    def theta_of_q(self, q: np.ndarray, psi: float) -> np.ndarray:
        """Eq. (3.12): the ball's position along the axis through the shoulder rotated by psi."""
        return (self.l1 * np.cos(q[0] - psi) + self.l2 * np.cos(q[0] + q[1] - psi)
                + self.l3 * np.cos(q[0] + q[1] + q[2] - psi))

    def parameter_vector(self, k) -> list:
        """The robot's parameter values in the compiled functions' order, with the wrist spring ``k``."""
        p = [self.values[n] for n in self.parameter_names]
        p[self._k_index] = k
        return p

    # ------------------------------------------------------------------ constraint geometry
    def constraint(self, spec: ThrowSpec, theta, dynamics: bool = True, strict: bool = True) -> ConstraintState:
        """q = Phi(theta) and its theta-derivatives (and alpha, beta, gamma) at the given theta values.

        With ``strict`` an unreachable theta (|arccos argument| > 1) raises a VHCError naming s and theta.

        >>> arm = ThrowingArm()
        >>> from app.core.throw.config import thesis_throw
        >>> st = arm.constraint(thesis_throw("throw1"), [-0.3377])
        >>> st.q[:, 0, 0].round(4).tolist()
        [1.732, 0.666, 0.6283]
        """
        theta = np.atleast_1d(np.asarray(theta, dtype=float))
        batch = SpecBatch.of([spec])
        s = (theta - spec.theta_b) / (spec.theta_e - spec.theta_b)
        return self.evaluate_batch(batch, s, dynamics=dynamics, strict=strict)

    def evaluate_batch(self, batch: SpecBatch, s: np.ndarray, dynamics: bool = True, strict: bool = True,
                       clip: float = 1.0) -> ConstraintState:
        """Constraint (and reduced dynamics) at s-values ``s`` (N,) for a batch of throws (B)."""
        D = batch.theta_e - batch.theta_b                                   # (B, 1)
        theta = batch.theta_b + D * s[None, :]
        phi1, phi2 = [], []
        for pts, out in ((batch.a, phi1), (batch.b, phi2)):
            deg = pts.shape[1] - 1
            for r in range(3):
                out.append(pts @ bernstein(deg, s, r).T / D ** r)
        psi = batch.psi
        A1 = phi1[0] - psi
        A12 = phi1[0] + phi2[0] - psi
        w12, w12d = phi1[1] + phi2[1], phi1[2] + phi2[2]
        l1, l2, l3 = self.l1, self.l2, self.l3
        u = (theta - l1 * np.cos(A1) - l2 * np.cos(A12)) / l3
        if strict:
            bad = np.abs(u) > 1.0 + 1e-12
            if np.any(bad):
                row = int(np.argwhere(bad)[0][0])
                idx = np.flatnonzero(bad[row])
                w = idx[np.argmax(np.abs(u[row, idx]))]
                raise VHCError(
                    f"the constraint cannot be reached for s between about {s[idx[0]]:.4f} and {s[idx[-1]]:.4f} (theta from "
                    f"{theta[row, idx[0]]:.4f} to {theta[row, idx[-1]]:.4f} m): the arccos argument of eq. (3.14) "
                    f"reaches {u[row, w]:.5f} at s = {s[w]:.4f} (theta = {theta[row, w]:.4f} m), outside [-1, 1]; "
                    f"the ball would have to be {1e3 * (abs(u[row, w]) - 1) * l3:.1f} mm beyond the reach of link 3")
        A3 = batch.branch * np.arccos(np.clip(u, -clip, clip))
        sA1, cA1, sA12, cA12, sA3, cA3 = np.sin(A1), np.cos(A1), np.sin(A12), np.cos(A12), np.sin(A3), np.cos(A3)
        with np.errstate(divide="ignore", invalid="ignore"):
            A3d = -(1.0 + l1 * sA1 * phi1[1] + l2 * sA12 * w12) / (l3 * sA3)
            A3dd = -(l1 * (cA1 * phi1[1] ** 2 + sA1 * phi1[2]) + l2 * (cA12 * w12 ** 2 + sA12 * w12d)
                     + l3 * cA3 * A3d ** 2) / (l3 * sA3)
        q = np.stack([phi1[0], phi2[0], A3 + psi - phi1[0] - phi2[0]])
        dq = np.stack([phi1[1], phi2[1], A3d - w12])
        ddq = np.stack([phi1[2], phi2[2], A3dd - w12d])
        st = ConstraintState(theta, q, dq, ddq, u)
        if dynamics:
            shape = theta.shape
            p = self.parameter_vector(batch.k)
            M = np.stack([np.broadcast_to(e, shape) for e in self.mass_matrix_fn(q, p)]).reshape((3, 3) + shape)
            c = np.stack([np.broadcast_to(e, shape) for e in self.coriolis_fn(q, dq, p)])
            G = np.stack([np.broadcast_to(e, shape) for e in self.gravity_spring_fn(q, p)])
            st.alpha = np.einsum("ij...,j...->i...", M, dq)
            st.beta = np.einsum("ij...,j...->i...", M, ddq) + c
            st.gamma = G
        return st

    # ------------------------------------------------------------------ release kinematics
    def release(self, spec: ThrowSpec, theta_dot_e: float) -> Release:
        """The ball's state at theta_e for a given release speed theta_dot_e (kinematics only)."""
        st = self.constraint(spec, [spec.theta_e], dynamics=False)
        q = st.q[:, 0, 0]
        dq = st.dq[:, 0, 0] * theta_dot_e
        return Release.make(self, spec, q, dq, theta_dot_e)

    # ------------------------------------------------------------------ the throw
    def solve(self, spec: ThrowSpec, tol: float = 1e-12, nodes: int = 16, max_pieces: int = 512,
              progress: Progress = None) -> Throw:
        """theta_dot^2(theta) from (3.24), the time law and everything along the throw
        (``reduced.solve``). Raises VHCError when the constraint cannot be reached, alpha crosses
        zero, or the arm does not get to theta_e (theta_dot^2 reaches zero)."""
        return reduced.solve(self, spec, tol, nodes, max_pieces, progress)

    def reduced_ode(self, spec: ThrowSpec, rtol: float = 1e-12) -> ReducedSolution:
        """The reduced dynamics integrated in time (``reduced.reduced_ode``: a check of the closed form)."""
        return reduced.reduced_ode(self, spec, rtol)
