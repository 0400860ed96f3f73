"""The reduced dynamics of a VHC throw (Lillehammer, chapter 3): on the constraint the passive row
of M q'' + C q' + g + k q3 = [tau1, tau2, 0] becomes alpha theta'' + beta theta'^2 + gamma = 0
(eqs. 3.15-3.20), whose integral (3.24) gives theta'^2(theta) in closed form. ``solve`` computes it
(and the time law) by piecewise Chebyshev quadrature in sigma with theta = theta_b + (theta_e -
theta_b) sigma^2 (the substitution removes the 1/sqrt singularity of dt = dtheta / theta' at a start
from rest), bisecting pieces until the Chebyshev coefficients of every integrand have decayed.
The results: ``Throw`` (theta_dot(theta), the time law, joint motion, torques, limit check),
``Release`` (the ball at release), ``Trajectory``, ``Feasibility``. ``reduced_ode`` integrates the
same dynamics in time, a check of the closed form (tests/test_throwing.py).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, List, Optional

import numpy as np

from ..ballistics import landing_distance
from ..errors import UserError
from .bezier import ChebPieces
from .config import Progress, SpecBatch, ThrowSpec, VHCError

if TYPE_CHECKING:       # the arm calls this module; these names are only annotations here
    from .arm import ConstraintState, ThrowingArm


def solve(arm: ThrowingArm, spec: ThrowSpec, tol: float = 1e-12, nodes: int = 16, max_pieces: int = 512,
          progress: Progress = None) -> "Throw":
    """theta_dot^2(theta) from (3.24), the time law and everything along the throw.

    Raises VHCError when the constraint cannot be reached, alpha crosses zero, or the arm does
    not get to theta_e (theta_dot^2 reaches zero)."""
    mesh = ChebPieces(np.linspace(0.0, 1.0, 9), nodes)
    batch = SpecBatch.of([spec])
    for it in range(40):
        if progress:
            progress(min(0.9, 0.1 * it), f"quadrature on {mesh.pieces} pieces")
        sol = integrate(arm, batch, mesh)
        sol.raise_problems(spec)
        scale = [np.sum(np.abs(f) * 0.5 * mesh.h[:, None]) / mesh.P + 1e-300 for f in sol.integrands]
        refine = np.zeros(mesh.pieces, dtype=bool)
        for f, sc in zip(sol.integrands, scale):
            refine |= mesh.tails(f)[0] > tol * max(sc, 1e-3)
        if not refine.any() or mesh.pieces >= max_pieces:
            break
        mesh = mesh.split(refine)
    if progress:
        progress(1.0, "done")
    return Throw(arm, spec, mesh, sol, converged=not refine.any())


def reduced_ode(arm: ThrowingArm, spec: ThrowSpec, rtol: float = 1e-12) -> "ReducedSolution":
    """Integrate alpha theta'' + beta theta'^2 + gamma = 0 in time from (theta_b, theta_dot_b) until
    theta = theta_e (an independent check of the closed form)."""
    from scipy.integrate import solve_ivp

    batch = SpecBatch.of([spec])
    D = spec.theta_e - spec.theta_b

    def rhs(t, x):
        st = arm.evaluate_batch(batch, np.array([(x[0] - spec.theta_b) / D]), strict=False, clip=1.0)
        return [x[1], -(st.beta[2, 0, 0] * x[1] ** 2 + st.gamma[2, 0, 0]) / st.alpha[2, 0, 0]]

    def at_release(t, x):
        return x[0] - spec.theta_e
    at_release.terminal = True
    at_release.direction = 1
    sol = solve_ivp(rhs, (0.0, 10.0), [spec.theta_b, spec.theta_dot_b], method="DOP853", rtol=rtol,
                    atol=1e-12, events=at_release, dense_output=True)
    if not sol.t_events[0].size:
        raise VHCError("the reduced dynamics never reaches theta_e within 10 s")
    T = float(sol.t_events[0][0])
    return ReducedSolution(T, float(sol.y_events[0][0][1]), sol.t, sol.y[0], sol.y[1], sol.sol)


@dataclass
class ReducedSolution:
    """The reduced dynamics integrated in time (``ThrowingArm.reduced_ode``); ``dense(t)`` -> (theta, theta_dot)."""
    duration: float
    theta_dot_e: float
    t: np.ndarray
    theta: np.ndarray
    theta_dot: np.ndarray
    dense: object


@dataclass
class _Integrals:
    """Closed-form theta_dot^2 and time on a Chebyshev mesh in sigma (arrays (B, K, P))."""
    state: ConstraintState
    theta: np.ndarray
    I1: np.ndarray            # int beta/alpha dtheta from theta_b
    I2: np.ndarray            # int exp(2 I1) 2 gamma/alpha dtheta
    Y: np.ndarray             # theta_dot^2
    time: Optional[np.ndarray]
    integrands: List[np.ndarray]
    alpha_sign_change: np.ndarray
    stall: np.ndarray
    mesh: ChebPieces

    def raise_problems(self, spec: ThrowSpec) -> None:
        a3 = self.state.alpha[2].reshape(self.theta.shape)[0]
        th = self.theta[0]
        if self.alpha_sign_change[0]:
            flat = a3.ravel()
            j = int(np.argmax(np.sign(flat[1:]) != np.sign(flat[0])))
            raise VHCError(f"the reduced dynamics is singular: alpha (eq. 3.15) changes sign near theta = "
                           f"{th.ravel()[j + 1]:.4f} m (s = {(th.ravel()[j + 1] - spec.theta_b) / (spec.theta_e - spec.theta_b):.4f}); "
                           f"theta_dot^2 of eq. (3.24) is undefined there")
        if self.stall[0]:
            Y = self.Y[0].ravel()
            j = int(np.argmax(Y[1:] <= 0)) + 1
            if j == 1 and spec.theta_dot_b == 0:
                raise VHCError("from rest the passive wrist pushes theta backwards (gamma/alpha > 0 at "
                               "theta_b): the throw cannot start")
            raise VHCError(f"theta_dot^2 reaches zero at theta = {th.ravel()[j]:.4f} m before the release "
                           f"point theta_e = {spec.theta_e:.4f} m: the arm stops and swings back")


def integrate(arm: ThrowingArm, batch: SpecBatch, mesh: ChebPieces, with_time: bool = True,
              strict: bool = True, clip: float = 1.0) -> _Integrals:
    """theta_dot^2 (and the time) of a batch of throws at the nodes of ``mesh`` (no error raised:
    see ``_Integrals.raise_problems``)."""
    sigma = mesh.nodes.ravel()
    st = arm.evaluate_batch(batch, sigma * sigma, strict=strict, clip=clip)
    B = batch.theta_b.shape[0]
    shape = (B,) + mesh.nodes.shape
    D = (batch.theta_e - batch.theta_b)[:, :, None]
    dth = 2.0 * D * mesh.nodes[None]                   # dtheta/dsigma
    a3 = st.alpha[2].reshape(shape)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        g1 = st.beta[2].reshape(shape) / a3 * dth
        g2 = 2.0 * st.gamma[2].reshape(shape) / a3 * dth
        I1 = mesh.cumulative(g1)
        e = np.exp(2.0 * I1)
        I2 = mesh.cumulative(e * g2)
        Yb = (batch.theta_dot_b ** 2)[:, :, None]
        Y = (Yb - I2) / e
    flat = a3.reshape(B, -1)
    sign_change = np.any(np.sign(flat) != np.sign(flat[:, :1]), axis=1) | np.any(flat == 0, axis=1)
    Yf = Y.reshape(B, -1)
    stall = np.any(Yf[:, 1:] <= 0, axis=1)
    integrands = [g1, g2]
    time_nodes = None
    if with_time and not stall.any() and not sign_change.any():
        with np.errstate(divide="ignore", invalid="ignore"):
            gt = dth / np.sqrt(Y)
        # at sigma = 0: 0 when moving, 2 sqrt(D / Y'(theta_b)) from rest (Y ~ Y' D sigma^2)
        slope = (-2.0 * st.gamma[2].reshape(shape) / a3)[:, 0, 0]
        start = np.where(batch.theta_dot_b[:, 0] > 0, 0.0, 2.0 * np.sqrt(D[:, 0, 0] / np.maximum(slope, 1e-300)))
        gt[:, 0, 0] = start
        integrands.append(gt)
        time_nodes = mesh.cumulative(gt)
    return _Integrals(st, st.theta.reshape(shape), I1, I2, Y, time_nodes, integrands, sign_change, stall, mesh)


# ====================================================================== results
@dataclass(frozen=True)
class Release:
    """The ball at release: joint state, position (y from the ground), true velocity J(q) dq, and
    the thesis's convention (speed theta_dot along psi), with the distances of eqs. (3.4)/(3.5)."""
    q: np.ndarray
    dq: np.ndarray
    theta_dot: float
    position: np.ndarray
    velocity: np.ndarray
    velocity_thesis: np.ndarray
    distance_from_base: float
    distance_from_release: float
    distance_from_base_thesis: float
    distance_from_release_thesis: float
    g: float

    @staticmethod
    def make(arm: ThrowingArm, spec: ThrowSpec, q, dq, theta_dot: float) -> "Release":
        q = np.asarray(q, dtype=float)
        dq = np.asarray(dq, dtype=float)
        pos = arm.ball_position(q)
        vel = arm.ball_velocity(q, dq)
        if pos[1] < 0:
            raise VHCError(f"the release point is {-pos[1]:.3f} m below the ground")
        vth = theta_dot * np.array([math.cos(spec.psi), math.sin(spec.psi)])
        d = float(landing_distance(pos[0], pos[1], vel[0], vel[1], arm.g))
        dt = float(landing_distance(pos[0], pos[1], vth[0], vth[1], arm.g))
        return Release(q, dq, float(theta_dot), pos, vel, vth, d, d - float(pos[0]), dt, dt - float(pos[0]), arm.g)

    @property
    def speed(self) -> float:
        return float(np.hypot(*self.velocity))

    @property
    def angle_deg(self) -> float:
        """Direction of the true ball velocity above the horizontal [deg]."""
        return math.degrees(math.atan2(self.velocity[1], self.velocity[0]))


@dataclass
class Trajectory:
    """Samples along a throw (arrays over time; q-like arrays have shape (3, n))."""
    t: np.ndarray
    theta: np.ndarray
    theta_dot: np.ndarray
    theta_ddot: np.ndarray
    q: np.ndarray
    dq: np.ndarray
    ddq: np.ndarray
    tau: np.ndarray          # (2, n) actuated torques
    ball: np.ndarray         # (2, n) ball position, y from the ground
    ball_velocity: np.ndarray


@dataclass
class Feasibility:
    """Constraint check of a throw on a dense grid (limits of the robot file, Table A.2)."""
    feasible: bool
    violations: List[str]
    max_speed_ratio: List[float]
    max_torque: List[float]
    q_min: List[float]
    q_max: List[float]
    grid: int


class Throw:
    """A solved throw: theta_dot(theta), the time law, joint motion, torques and the release.

    ``converged`` says whether the adaptive quadrature met its tolerance; ``nodes`` is its size."""

    def __init__(self, arm: ThrowingArm, spec: ThrowSpec, mesh: ChebPieces, sol: _Integrals, converged: bool):
        self.arm = arm
        self.spec = spec
        self.mesh = mesh
        self.converged = converged
        self._I1 = sol.I1[0]
        self._I2 = sol.I2[0]
        self._time = sol.time[0]
        Y = sol.Y[0]
        self.theta_dot_e = float(math.sqrt(Y[-1, -1]))
        self.duration = float(self._time[-1, -1])
        self.release = arm.release(spec, self.theta_dot_e)
        self.nodes = int(mesh.nodes.size)

    @property
    def delta(self) -> float:
        return self.spec.theta_e - self.spec.theta_b

    def _sigma(self, theta) -> np.ndarray:
        s = (np.asarray(theta, dtype=float) - self.spec.theta_b) / self.delta
        if np.any(s < -1e-12) or np.any(s > 1 + 1e-12):
            raise UserError(f"theta outside the throw's interval [{self.spec.theta_b}, {self.spec.theta_e}]")
        return np.sqrt(np.clip(s, 0.0, 1.0))

    def theta_dot_squared(self, theta) -> np.ndarray:
        """Closed form (3.24) at any theta in [theta_b, theta_e]."""
        sig = self._sigma(theta)
        I1 = self.mesh.interpolate(self._I1, sig)
        I2 = self.mesh.interpolate(self._I2, sig)
        return np.where(sig > 0, (self.spec.theta_dot_b ** 2 - I2) * np.exp(-2.0 * I1), self.spec.theta_dot_b ** 2)

    def theta_dot(self, theta) -> np.ndarray:
        return np.sqrt(np.maximum(self.theta_dot_squared(theta), 0.0))

    def time_of(self, theta) -> np.ndarray:
        """t(theta) = integral of dtheta / theta_dot from theta_b [s]."""
        return self.mesh.interpolate(self._time, self._sigma(theta))

    def theta_at(self, t) -> np.ndarray:
        """The time law theta(t) for 0 <= t <= duration (inverse of time_of, Newton-polished)."""
        t = np.clip(np.asarray(t, dtype=float), 0.0, self.duration)
        sig_nodes = self.mesh.nodes.ravel()
        sig = np.interp(t, self._time.ravel(), sig_nodes)
        for _ in range(4):          # Newton on t(sigma) = t with dt/dsigma = 2 D sigma / theta_dot
            th = self.spec.theta_b + self.delta * sig * sig
            err = self.mesh.interpolate(self._time, sig) - t
            rate = 2.0 * self.delta * sig / np.maximum(self.theta_dot(th), 1e-300)
            step = np.where(rate > 0, err / np.where(rate > 0, rate, 1.0), 0.0)
            sig = np.clip(sig - step, 0.0, 1.0)
        return self.spec.theta_b + self.delta * sig * sig

    def along(self, theta) -> Trajectory:
        """Joint angles, speeds, accelerations and torques at the given theta values."""
        theta = np.atleast_1d(np.asarray(theta, dtype=float))
        st = self.arm.constraint(self.spec, theta)
        Y = np.maximum(self.theta_dot_squared(theta), 0.0)
        a, b, c = (x[:, 0, :] for x in (st.alpha, st.beta, st.gamma))
        thdd = -(b[2] * Y + c[2]) / a[2]
        q, p1, p2 = st.q[:, 0, :], st.dq[:, 0, :], st.ddq[:, 0, :]
        thd = np.sqrt(Y)
        dq = p1 * thd
        ddq = p2 * Y + p1 * thdd
        tau = a[:2] * thdd + b[:2] * Y + c[:2]
        return Trajectory(self.time_of(theta), theta, thd, thdd, q, dq, ddq, tau,
                          self.arm.ball_position(q), self.arm.ball_velocity(q, dq))

    def sample(self, n: int = 200) -> Trajectory:
        """n samples uniform in time from t = 0 to the release (their times exactly those, the first 0)."""
        t = np.linspace(0.0, self.duration, n)
        return replace(self.along(self.theta_at(t)), t=t)

    def check(self, grid: int = 2001, q1_min: Optional[float] = None) -> Feasibility:
        """Every limit of the robot file (positions, speeds, torques) on a uniform theta grid plus the
        quadrature nodes. ``q1_min`` tightens q1's lower limit (pi/6 in eq. 4.5)."""
        theta = np.union1d(np.linspace(self.spec.theta_b, self.spec.theta_e, grid),
                           self.spec.theta_b + self.delta * self.mesh.nodes.ravel() ** 2)
        tr = self.along(theta)
        lim = self.arm.limits
        lower = lim["lower"].copy()
        if q1_min is not None:
            lower[0] = max(lower[0], q1_min)
        names = self.arm.robot.coordinates
        violations: List[str] = []
        tol = 1e-9
        for i, name in enumerate(names):
            j_lo, j_hi = int(np.argmin(tr.q[i])), int(np.argmax(tr.q[i]))
            if tr.q[i, j_lo] < lower[i] - tol:
                violations.append(f"{name} = {tr.q[i, j_lo]:.4f} rad below its lower limit {lower[i]:.4f} rad "
                                  f"at theta = {theta[j_lo]:.4f} m")
            if tr.q[i, j_hi] > lim["upper"][i] + tol:
                violations.append(f"{name} = {tr.q[i, j_hi]:.4f} rad above its upper limit {lim['upper'][i]:.4f} rad "
                                  f"at theta = {theta[j_hi]:.4f} m")
        ratios = []
        for i, name in enumerate(names):
            j = int(np.argmax(np.abs(tr.dq[i])))
            ratio = float(abs(tr.dq[i, j]) / lim["speed"][i])
            ratios.append(ratio)
            if ratio > 1 + tol:
                violations.append(f"speed of {name}: {abs(tr.dq[i, j]):.4f} rad/s at theta = {theta[j]:.4f} m is "
                                  f"{ratio:.2%} of its limit {lim['speed'][i]:.4f} rad/s")
        torques = []
        act = [n for n, a in zip(names, self.arm.robot.actuated) if a]
        for i, name in enumerate(act):
            j = int(np.argmax(np.abs(tr.tau[i])))
            torques.append(float(abs(tr.tau[i, j])))
            if abs(tr.tau[i, j]) > lim["torque"][i] * (1 + tol):
                violations.append(f"torque of {name}: {abs(tr.tau[i, j]):.2f} N m at theta = {theta[j]:.4f} m "
                                  f"exceeds its limit {lim['torque'][i]:g} N m")
        return Feasibility(not violations, violations, ratios, torques, tr.q.min(axis=1).tolist(),
                           tr.q.max(axis=1).tolist(), int(theta.size))


