"""Closed-loop throws of the throwing arm in full 3-DOF dynamics, on a plant that differs from the
planner's model.

The plan is a VHC throw (``app/core/throw/``): q1 = phi1(theta), q2 = phi2(theta), the wrist passive.
Three controllers drive the actuated joints while the wrist stays free:

- ``open``: the plan's nominal torques tau1(t), tau2(t), open loop;
- ``vhc``: feedback linearization of the constraint outputs y = q_a - phi(theta(q)) (theta from
  eq. 3.12 of the measured q), with v = y'' = -kp y - kd y';
- ``transverse``: the same feedback linearization with v = -K(theta) x_perp, where
  x_perp = (I, y, y') are transverse coordinates of the planned orbit, I = theta'^2 - Psi(theta) the
  deviation from the plan's closed-form theta'^2(theta) = Psi(theta) (eq. 3.24). K comes from a
  finite-horizon (time-varying) Riccati equation of the transverse linearization along the orbit
  (Shiriaev, Perram, Canudas-de-Wit 2005; Shiriaev, Freidovich, Gusev 2010):

      I' = 2 theta' / alpha (R - beta I),   R = -(F_y y + F_y' y' + F_y'' y''),   y'' = v,

  with alpha, beta the reduced dynamics of the passive row and F the passive row of the full model
  written in the coordinates (theta, y) (its partial derivatives by complex-step differentiation).

A plant (``Plant``, ``plants.py``) sets the arm's dynamic parameters (masses,
CoMs, inertias, the spring k), wrist viscous and Coulomb friction, torque saturation at the Table A.2
limits, sensor noise on q and q' and a control period (zero-order hold). The simulation integrates a
batch of plants at once (fixed-step RK4, vectorized over plants), which is what the Monte-Carlo study
(``app/core/throw/montecarlo.py``) uses. The ball is released when theta(q) of the true state reaches
theta_e (the crossing located by Hermite interpolation inside the step); it then flies ballistically.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional

import numpy as np
import numpy.polynomial.polynomial as npoly

from ..ballistics import landing_distance
from ..errors import UserError
from .arm import ThrowingArm
from .config import Progress
from .plants import COULOMB_WIDTH, Plant, PlantBatch, plant_batch
from .reduced import Throw

CONTROLLERS = ("open", "vhc", "transverse")


# ====================================================================== the controller's model
def _dynamics(arm: ThrowingArm, q: np.ndarray, dq: np.ndarray, p):
    """M (B, 3, 3) and M q'' - everything but tau: h = c + g + k q3 (B, 3) for q, dq (3, B)."""
    B = q.shape[1]
    if B == 1:     # scalars: numpy's per-call overhead dominates on arrays of one element
        q, dq, p = [float(v) for v in q[:, 0]], [float(v) for v in dq[:, 0]], [float(np.ravel(v)[0]) for v in p]
        M = np.array(arm.mass_matrix_fn(q, p), dtype=float).reshape(1, 3, 3)
        h = np.array(arm.coriolis_fn(q, dq, p), dtype=float) + np.array(arm.gravity_spring_fn(q, p), dtype=float)
        return M, h.reshape(1, 3)
    M = np.array(np.broadcast_arrays(*arm.mass_matrix_fn(q, p), np.empty(B))[:9]).T.reshape(B, 3, 3)
    c = np.array(np.broadcast_arrays(*arm.coriolis_fn(q, dq, p), np.empty(B))[:3]).T
    G = np.array(np.broadcast_arrays(*arm.gravity_spring_fn(q, p), np.empty(B))[:3]).T
    return M, c + G


def _theta_jacobian(arm: ThrowingArm, q, dq, psi: float):
    """theta(q) (eq. 3.12), its gradient J (3, B) and J'(q, q') q' (B,)."""
    a1, a12 = q[0] - psi, q[0] + q[1] - psi
    a123 = a12 + q[2]
    l1, l2, l3 = arm.l1, arm.l2, arm.l3
    s1, s12, s123 = l1 * np.sin(a1), l2 * np.sin(a12), l3 * np.sin(a123)
    c1, c12, c123 = l1 * np.cos(a1), l2 * np.cos(a12), l3 * np.cos(a123)
    J = -np.stack([s1 + s12 + s123, s12 + s123, s123])
    w1, w12 = dq[0], dq[0] + dq[1]
    w123 = w12 + dq[2]
    Jdq = -(c1 * w1 ** 2 + c12 * w12 ** 2 + c123 * w123 ** 2)
    return c1 + c12 + c123, J, Jdq


def _power_basis(points: np.ndarray) -> np.ndarray:
    """Coefficients in powers of s of the Bezier polynomial with these control points (exact sums).

    >>> [f"{c:.1f}" for c in _power_basis(np.array([0.0, 1.0, 0.0]))]     # 2 s (1 - s)
    ['0.0', '2.0', '-2.0']
    """
    n = points.size - 1
    return np.array([math.comb(n, j) * sum((-1) ** (j - k) * math.comb(j, k) * points[k] for k in range(j + 1))
                     for j in range(n + 1)])


class _Plan:
    """What every controller needs from the plan, precomputed: Bezier constraint, Psi(theta) =
    theta'^2 with its derivative on a grid (for Hermite interpolation), nominal torques in time."""

    def __init__(self, throw: Throw, grid: int = 2001):
        self.throw = throw
        self.arm = arm = throw.arm
        self.spec = spec = throw.spec
        self.D = throw.delta
        self.p = arm.parameter_vector(spec.k)
        self.a = np.asarray(spec.a, dtype=float)
        self.b = np.asarray(spec.b, dtype=float)
        self.power = [np.stack([_power_basis(self.a), _power_basis(self.b)], axis=1)]   # (n + 1, 2) in s
        for _ in range(2):
            self.power.append(npoly.polyder(self.power[-1]))
        self.theta = np.linspace(spec.theta_b, spec.theta_e, grid)
        st = arm.constraint(spec, self.theta)
        alpha, beta, gamma = st.alpha[2, 0], st.beta[2, 0], st.gamma[2, 0]
        self.psi_values = throw.theta_dot_squared(self.theta)
        self.psi_slopes = -2.0 * (beta * self.psi_values + gamma) / alpha

    def phi(self, theta):
        """phi, phi', phi'' (each (2, B)) at theta (B,) (the Bezier polynomials, extended beyond [0, 1])."""
        s = (theta - self.spec.theta_b) / self.D
        return [npoly.polyval(s, c) / self.D ** r for r, c in enumerate(self.power)]

    def psi(self, theta):
        """Psi(theta) = the plan's theta'^2: cubic Hermite on the grid, continued beyond [theta_b, theta_e]
        by its second-order Taylor polynomial at the end (a step of the simulation may cross theta_e)."""
        grid, values, slopes = self.theta, self.psi_values, self.psi_slopes
        h = grid[1] - grid[0]
        th = np.clip(theta, grid[0], grid[-1])
        j = np.clip(((th - grid[0]) / h).astype(int), 0, grid.size - 2)
        u = (th - grid[j]) / h
        y0, y1 = values[j], values[j + 1]
        m0, m1 = slopes[j] * h, slopes[j + 1] * h
        inside = ((2 * u ** 3 - 3 * u ** 2 + 1) * y0 + (u ** 3 - 2 * u ** 2 + u) * m0
                  + (-2 * u ** 3 + 3 * u ** 2) * y1 + (u ** 3 - u ** 2) * m1)
        lo, hi = theta - grid[0], theta - grid[-1]
        below = values[0] + slopes[0] * lo + 0.5 * (slopes[1] - slopes[0]) / h * lo ** 2
        above = values[-1] + slopes[-1] * hi + 0.5 * (slopes[-1] - slopes[-2]) / h * hi ** 2
        return np.where(lo < 0, below, np.where(hi > 0, above, inside))


def _outputs(plan: _Plan, q, dq):
    """theta, theta', y = q_a - phi(theta), y', and the map y'' = L q'' + r (L (B, 2, 3), r (2, B))."""
    theta, J, Jdq = _theta_jacobian(plan.arm, q, dq, plan.spec.psi)
    thd = np.einsum("ib,ib->b", J, dq)
    phi, dphi, ddphi = plan.phi(theta)
    y = q[:2] - phi
    yd = dq[:2] - dphi * thd
    B = q.shape[1]
    L = np.zeros((B, 2, 3))
    L[:, 0, 0] = L[:, 1, 1] = 1.0
    L -= np.einsum("ib,jb->bij", dphi, J)
    r = -dphi * Jdq - ddphi * thd ** 2
    return theta, thd, y, yd, L, r


def _inverse3(M: np.ndarray) -> np.ndarray:
    """Inverses of a batch of 3 x 3 matrices (B, 3, 3) by cofactors (LAPACK's per-matrix call costs
    more than the arithmetic at this size).

    >>> M = np.array([[[2.0, 1.0, 0.0], [1.0, 3.0, 1.0], [0.0, 1.0, 4.0]]])
    >>> bool(np.allclose(_inverse3(M)[0] @ M[0], np.eye(3)))
    True
    """
    def cross(a, b):
        return np.stack([a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1], a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2],
                         a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]], axis=-1)

    r0, r1, r2 = M[:, 0], M[:, 1], M[:, 2]
    c0, c1, c2 = cross(r1, r2), cross(r2, r0), cross(r0, r1)
    det = np.einsum("bi,bi->b", r0, c0)
    return np.stack([c0, c1, c2], axis=-1) / det[:, None, None]


def _solve2(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    """x with A x = b for batches A (B, 2, 2), b (B, 2) (Cramer's rule)."""
    det = A[:, 0, 0] * A[:, 1, 1] - A[:, 0, 1] * A[:, 1, 0]
    return np.stack([A[:, 1, 1] * b[:, 0] - A[:, 0, 1] * b[:, 1], A[:, 0, 0] * b[:, 1] - A[:, 1, 0] * b[:, 0]],
                    axis=-1) / det[:, None]


def _linearizing_torque(plan: _Plan, q, dq, v, L, r):
    """The torques (2, B) that make y'' = v in the planner's model: (L M^-1 B) tau = v - r + L M^-1 h."""
    M, h = _dynamics(plan.arm, q, dq, plan.p)
    LM = np.einsum("bij,bjk->bik", L, _inverse3(M))
    rhs = v.T - r.T + np.einsum("bij,bj->bi", LM, h)
    return _solve2(LM[:, :, :2], rhs).T


# ====================================================================== transverse linearization
def state_of(plan: _Plan, theta, thd, thdd, y, yd, ydd):
    """q, q', q'' (each (3, ...)) from the coordinates (theta, y = q_a - phi(theta)) and their time
    derivatives: q_a = phi + y, the wrist from eq. (3.12) on the plan's arccos branch (complex-analytic,
    so that complex-step derivatives go through it). y-like arguments have shape (2, ...)."""
    arm, spec = plan.arm, plan.spec
    phi, dphi, ddphi = plan.phi(np.real(theta))
    q1, q2 = phi[0] + y[0], phi[1] + y[1]
    A1, A12 = q1 - spec.psi, q1 + q2 - spec.psi
    A3 = spec.branch * np.arccos((theta - arm.l1 * np.cos(A1) - arm.l2 * np.cos(A12)) / arm.l3)
    q = np.stack([q1, q2, A3 + spec.psi - q1 - q2])
    dqa = dphi * thd + yd
    ddqa = ddphi * thd ** 2 + dphi * thdd + ydd
    s1, s12, s123 = arm.l1 * np.sin(A1), arm.l2 * np.sin(A12), arm.l3 * np.sin(A3)
    c1, c12, c123 = arm.l1 * np.cos(A1), arm.l2 * np.cos(A12), arm.l3 * np.cos(A3)
    J = [-(s1 + s12 + s123), -(s12 + s123), -s123]
    dq3 = (thd - J[0] * dqa[0] - J[1] * dqa[1]) / J[2]
    w1, w12 = dqa[0], dqa[0] + dqa[1]
    Jdq = -(c1 * w1 ** 2 + c12 * w12 ** 2 + c123 * (w12 + dq3) ** 2)
    ddq3 = (thdd - Jdq - J[0] * ddqa[0] - J[1] * ddqa[1]) / J[2]
    return q, np.stack([dqa[0], dqa[1], dq3]), np.stack([ddqa[0], ddqa[1], ddq3])


def _passive_row(plan: _Plan, theta, thd, thdd, y, yd, ydd):
    """The passive row F = M3 q'' + c3 + g3 + k q3 of the planner's model in the coordinates (theta, y)."""
    q, dq, ddq = state_of(plan, theta, thd, thdd, y, yd, ydd)
    arm = plan.arm
    shape = np.broadcast(q[0], dq[0]).shape
    M = [np.broadcast_to(e, shape) for e in arm.mass_matrix_fn(q, plan.p)]
    c = np.broadcast_to(arm.coriolis_fn(q, dq, plan.p)[2], shape)
    g = np.broadcast_to(arm.gravity_spring_fn(q, plan.p)[2], shape)
    return M[6] * ddq[0] + M[7] * ddq[1] + M[8] * ddq[2] + c + g


@dataclass
class TransverseLinearization:
    """x_perp' = A x_perp + B v along the orbit, x_perp = (I, y1, y2, y1', y2'), v = y''; arrays over
    the plan's times ``t`` (A (N, 5, 5), B (N, 5, 2)), at theta(t), theta'(t)."""
    t: np.ndarray
    theta: np.ndarray
    theta_dot: np.ndarray
    A: np.ndarray
    B: np.ndarray


def transverse_linearization(throw: Throw, t: Optional[np.ndarray] = None, plan: Optional[_Plan] = None,
                             ) -> TransverseLinearization:
    """The transverse linearization of the full model under y'' = v along the planned orbit.

    I' = 2 theta'/alpha (R - beta I) with R = -(F_y y + F_y' y' + F_y'' v); F's partial derivatives
    by complex-step differentiation (exact to rounding)."""
    plan = plan or _Plan(throw)
    t = np.linspace(0.0, throw.duration, 401) if t is None else np.asarray(t, dtype=float)
    tr = throw.along(throw.theta_at(t))
    th, thd, thdd = tr.theta, tr.theta_dot, tr.theta_ddot
    st = throw.arm.constraint(throw.spec, th)
    alpha, beta = st.alpha[2, 0], st.beta[2, 0]
    h = 1e-20
    N = th.size
    grads = np.zeros((N, 6))
    for j in range(6):
        pert = np.zeros((6, N), dtype=complex)
        pert[j] = 1j * h
        F = _passive_row(plan, th.astype(complex), thd, thdd, pert[0:2], pert[2:4], pert[4:6])
        grads[:, j] = F.imag / h
    A = np.zeros((N, 5, 5))
    Bm = np.zeros((N, 5, 2))
    gain = 2.0 * thd / alpha
    A[:, 0, 0] = -gain * beta
    A[:, 0, 1:5] = -gain[:, None] * grads[:, 0:4]
    A[:, 1, 3] = A[:, 2, 4] = 1.0
    Bm[:, 0, :] = -gain[:, None] * grads[:, 4:6]
    Bm[:, 3, 0] = Bm[:, 4, 1] = 1.0
    return TransverseLinearization(t, th, thd, A, Bm)


@dataclass
class Gains:
    """Weights of the transverse LQR: state cost diag(1/I_s^2, 1/y_s^2, 1/y_s^2, 1/yd_s^2, 1/yd_s^2),
    input cost 1/v_s^2, terminal cost on I 1/I_final^2 (the release speed is what the throw is about).
    Also the PD gains of the VHC controller (kp [1/s^2], kd [1/s])."""
    I_scale: float = 0.1          # [m^2/s^2]
    y_scale: float = 0.01         # [rad]
    yd_scale: float = 0.1         # [rad/s]
    v_scale: float = 4.0          # [rad/s^2]
    I_final: float = 0.3          # [m^2/s^2]
    kp: float = 400.0
    kd: float = 40.0


def riccati_gains(lin: TransverseLinearization, gains: Gains) -> np.ndarray:
    """K(t) (N, 2, 5) of the finite-horizon LQR: -P' = A^T P + P A - P B R^-1 B^T P + Q, P(T) = P_f,
    integrated backwards in time on the orbit."""
    from scipy.integrate import solve_ivp

    Q = np.diag([gains.I_scale ** -2, gains.y_scale ** -2, gains.y_scale ** -2, gains.yd_scale ** -2,
                 gains.yd_scale ** -2])
    Rinv = gains.v_scale ** 2
    Pf = np.diag([gains.I_final ** -2, 0.0, 0.0, 0.0, 0.0])
    t = lin.t

    def at(tt, arr):
        j = int(np.clip(np.searchsorted(t, tt) - 1, 0, t.size - 2))
        u = (tt - t[j]) / (t[j + 1] - t[j])
        return (1 - u) * arr[j] + u * arr[j + 1]

    def rhs(tt, p):
        P = p.reshape(5, 5)
        A, B = at(tt, lin.A), at(tt, lin.B)
        PB = P @ B
        dP = -(A.T @ P + P @ A - Rinv * PB @ PB.T + Q)
        return (0.5 * (dP + dP.T)).ravel()

    sol = solve_ivp(rhs, (t[-1], t[0]), Pf.ravel(), t_eval=t[::-1], method="LSODA", rtol=1e-8, atol=1e-6)
    if not sol.success:
        raise UserError(f"the Riccati equation of the transverse stabilizer failed: {sol.message}")
    P = sol.y.T[::-1].reshape(-1, 5, 5)
    return Rinv * np.einsum("nji,njk->nik", lin.B, P)


# ====================================================================== controllers
class Controller:
    """One of ``CONTROLLERS`` for a planned throw; ``torque(t, q, dq)`` (arrays (3, B)) -> (2, B)."""

    def __init__(self, throw: Throw, kind: str, gains: Optional[Gains] = None):
        if kind not in CONTROLLERS:
            raise UserError(f"unknown controller '{kind}' (one of {', '.join(CONTROLLERS)})")
        self.kind = kind
        self.throw = throw
        self.gains = gains or Gains()
        self.plan = _Plan(throw)
        if kind == "transverse":
            self.linearization = transverse_linearization(throw, plan=self.plan)
            self.K = riccati_gains(self.linearization, self.gains)

    def feedforward(self, t: np.ndarray) -> np.ndarray:
        """The plan's torques at times t (held at the release value after the planned duration)."""
        tr = self.throw.along(self.throw.theta_at(np.minimum(t, self.throw.duration)))
        return tr.tau

    def gain(self, theta: np.ndarray) -> np.ndarray:
        """K at the orbit point with the same theta (B, 2, 5), linear between the orbit's samples."""
        grid = self.linearization.theta
        j = np.clip(np.searchsorted(grid, theta) - 1, 0, grid.size - 2)
        u = np.clip((theta - grid[j]) / (grid[j + 1] - grid[j]), 0.0, 1.0)[:, None, None]
        return (1.0 - u) * self.K[j] + u * self.K[j + 1]

    def torque(self, q: np.ndarray, dq: np.ndarray) -> np.ndarray:
        """Feedback torques (2, B) from the measured state (``vhc`` and ``transverse``)."""
        plan = self.plan
        theta, thd, y, yd, L, r = _outputs(plan, q, dq)
        if self.kind == "vhc":
            v = -self.gains.kp * y - self.gains.kd * yd
        else:
            x = np.concatenate([(thd ** 2 - plan.psi(theta))[None], y, yd])
            v = -np.einsum("bij,jb->ib", self.gain(theta), x)
        return _linearizing_torque(plan, q, dq, v, L, r)


# ====================================================================== simulation
@dataclass
class ClosedLoopRun:
    """Results per plant (arrays (B,)); the trajectory of plant 0 for plots."""
    controller: str
    released: np.ndarray            # the ball reached theta_e before the time limit
    release_time: np.ndarray        # [s]
    theta_dot_e: np.ndarray         # theta' at release [m/s]
    release_speed: np.ndarray       # |J(q) q'| [m/s]
    release_position: np.ndarray    # (2, B) [m]
    release_velocity: np.ndarray    # (2, B) [m/s]
    distance: np.ndarray            # landing distance from the base, true velocity [m] (NaN: no release)
    distance_thesis: np.ndarray     # thesis convention (theta' along psi) [m]
    max_speed_ratio: np.ndarray     # (3, B) max |q_i'| / limit
    max_torque_ratio: np.ndarray    # (2, B) max |commanded tau_i| / limit (before saturation)
    position_violation: np.ndarray  # a joint left its range
    violation: np.ndarray           # any limit exceeded (or no release)
    t: np.ndarray                   # times of the first plant's trajectory
    q: np.ndarray                   # (3, n)
    tau: np.ndarray                 # (2, n) applied torques

    @property
    def size(self) -> int:
        return self.released.size


def _plant_acceleration(arm: ThrowingArm, plants: PlantBatch, q, dq, tau):
    M, h = _dynamics(arm, q, dq, list(plants.params))
    w = dq[2]
    fr = plants.viscous * w + plants.coulomb * np.tanh(w / COULOMB_WIDTH)
    rhs = np.stack([tau[0], tau[1], -fr], axis=-1) - h
    return np.einsum("bij,bj->ib", _inverse3(M), rhs)


def simulate_closed_loop(throw: Throw, controller, plant: Plant, plants: Optional[PlantBatch] = None,
                         seed: int = 0, step: Optional[float] = None, max_time: Optional[float] = None,
                         progress: Progress = None, gains: Optional[Gains] = None) -> ClosedLoopRun:
    """Simulate the full arm for a batch of plants (default: the one ``plant``) under a controller
    (a name of ``CONTROLLERS`` or a ``Controller``) until each ball reaches theta_e.

    The plant's friction, saturation, noise and control period apply to every member of the batch;
    ``plants`` gives each member's parameters and friction (``plant_batch``). RK4 with a fixed step of
    at most ``step`` seconds, a divisor of the control period (default: 1 ms with a control period,
    between samples the plant is smooth; 0.2 ms for continuous control); noise drawn from ``seed``."""
    arm, spec = throw.arm, throw.spec
    ctl = controller if isinstance(controller, Controller) else Controller(throw, controller, gains)
    if plants is None:
        plants = plant_batch(arm, spec.k, [plant.values(arm.values, spec.k)], [plant.viscous], [plant.coulomb])
    B = plants.size
    rng = np.random.default_rng(seed)
    period = plant.control_period
    sub, dt, n_steps = _time_grid(period, step, max_time if max_time is not None else 1.5 * throw.duration + 0.2)
    lim = arm.limits
    tau_lim = lim["torque"][:, None]
    st0 = arm.constraint(spec, [spec.theta_b], dynamics=False)
    q0 = st0.q[:, 0, 0]
    dq0 = st0.dq[:, 0, 0] * spec.theta_dot_b
    x = np.concatenate([np.repeat(q0[:, None], B, 1), np.repeat(dq0[:, None], B, 1)])   # (6, B)
    if ctl.kind == "open":   # the plan's torques at every stage time (multiples of dt/2)
        ff = ctl.feedforward(np.arange(2 * n_steps + 3) * 0.5 * dt)

    def command(k_half, xs):
        """Commanded torques (2, B) at stage time k_half * dt / 2 from the state xs (true or measured)."""
        if ctl.kind == "open":
            return np.repeat(ff[:, k_half][:, None], xs.shape[1], 1)
        return ctl.torque(xs[:3], xs[3:])

    def apply(tau):
        return np.clip(tau, -tau_lim, tau_lim) if plant.saturate else tau

    def f(xs, tau, pl):
        return np.concatenate([xs[3:], _plant_acceleration(arm, pl, xs[:3], xs[3:], tau)])

    active = np.ones(B, dtype=bool)
    out = {name: np.full(B, np.nan) for name in ("time", "thd")}
    q_rel, dq_rel = np.full((3, B), np.nan), np.full((3, B), np.nan)
    speed_ratio = np.abs(x[3:]) / lim["speed"][:, None]
    torque_ratio = np.zeros((2, B))
    pos_bad = np.zeros(B, dtype=bool)
    traj_t, traj_q, traj_tau = [0.0], [x[:3, 0].copy()], []
    held = None
    for n in range(n_steps):
        idx = np.flatnonzero(active)
        if idx.size == 0:
            break
        xa = x[:, idx]
        pl = plants.take(idx)
        if period > 0 and n % sub == 0:      # a control sample: measure (with noise), compute, hold
            meas = xa.copy()
            if plant.noise_q > 0 or plant.noise_dq > 0:
                noise = rng.normal(0.0, 1.0, (6, B))[:, idx]
                meas[:3] += plant.noise_q * noise[:3]
                meas[3:] += plant.noise_dq * noise[3:]
            cmd = command(2 * n, meas)
            torque_ratio[:, idx] = np.maximum(torque_ratio[:, idx], np.abs(cmd) / tau_lim)
            held = np.full((2, B), np.nan)
            held[:, idx] = apply(cmd)
        if period > 0:
            tau_of = lambda k_half, xs, _h=held[:, idx]: _h
        else:
            def tau_of(k_half, xs):
                cmd = command(k_half, xs)
                torque_ratio[:, idx] = np.maximum(torque_ratio[:, idx], np.abs(cmd) / tau_lim)
                return apply(cmd)
        xn, k1 = _rk4_step(lambda xs, k_half: f(xs, tau_of(2 * n + k_half, xs), pl), xa, dt)
        if idx[0] == 0 and active[0]:
            traj_t.append((n + 1) * dt)
            traj_q.append(xn[:3, 0].copy())
            traj_tau.append(tau_of(2 * n, xa)[:, 0].copy())
        theta_new = arm.theta_of_q(xn[:3], spec.psi)
        crossed = theta_new >= spec.theta_e
        if crossed.any():
            c = np.flatnonzero(crossed)
            pc = plants.take(idx[c])
            f1 = f(xn[:, c], tau_of(2 * n + 2, xn)[:, c], pc)
            s = _hermite_crossing(arm, spec, xa[:, c], xn[:, c], k1[:, c], f1, dt)
            xr = _hermite(xa[:, c], xn[:, c], k1[:, c], f1, dt, s)
            g = idx[c]
            out["time"][g] = (n + s) * dt
            q_rel[:, g] = xr[:3]
            dq_rel[:, g] = xr[3:]
            active[g] = False
            speed_ratio[:, g] = np.maximum(speed_ratio[:, g], np.abs(xr[3:]) / lim["speed"][:, None])
        x[:, idx] = xn
        inside = idx[~crossed]
        speed_ratio[:, inside] = np.maximum(speed_ratio[:, inside], np.abs(xn[3:, ~crossed]) / lim["speed"][:, None])
        bad = np.any((xn[:3] < lim["lower"][:, None] - 1e-9) | (xn[:3] > lim["upper"][:, None] + 1e-9), axis=0)
        pos_bad[idx] |= bad & ~crossed
        if progress and n % 200 == 0:
            progress(min(0.99, n * dt / max(throw.duration, 1e-9)), f"{ctl.kind}: t = {n * dt:.3f} s")
    if progress:
        progress(1.0, "done")
    return _closed_loop_run(throw, ctl.kind, out["time"], q_rel, dq_rel, q0, speed_ratio, torque_ratio, pos_bad,
                            traj_t, traj_q, traj_tau)


def _time_grid(period: float, step: Optional[float], T_max: float):
    """Integrator steps per control period, the step [s] (at most ``step``, a divisor of the period;
    default 1 ms with a control period, 0.2 ms for continuous control) and the number of steps."""
    step = step or (1e-3 if period > 0 else 2e-4)
    sub = max(1, int(math.ceil(period / step - 1e-9))) if period > 0 else 1
    dt = period / sub if period > 0 else step
    return sub, dt, int(math.ceil(T_max / dt))


def _rk4_step(f, x, dt):
    """One classical Runge-Kutta step of x' = f(x, k_half) (k_half: 0, 1, 2 half steps into it);
    the new state and the slope at the start."""
    k1 = f(x, 0)
    k2 = f(x + 0.5 * dt * k1, 1)
    k3 = f(x + 0.5 * dt * k2, 1)
    k4 = f(x + dt * k3, 2)
    return x + dt / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4), k1


def _closed_loop_run(throw: Throw, kind: str, release_time, q_rel, dq_rel, q0, speed_ratio, torque_ratio, pos_bad,
                     traj_t, traj_q, traj_tau) -> ClosedLoopRun:
    """The results of ``simulate_closed_loop`` from the release states (NaN: no release) and the
    first plant's trajectory."""
    arm, spec = throw.arm, throw.spec
    released = np.isfinite(release_time)
    pos = arm.ball_position(np.where(released, q_rel, q0[:, None]))
    vel = arm.ball_velocity(np.where(released, q_rel, q0[:, None]), np.where(released, dq_rel, 0.0))
    _theta, J, _ = _theta_jacobian(arm, np.where(released, q_rel, q0[:, None]),
                                   np.where(released, dq_rel, 0.0), spec.psi)
    thd = np.einsum("ib,ib->b", J, np.where(released, dq_rel, 0.0))
    with np.errstate(invalid="ignore"):
        y = np.maximum(pos[1], 0.0)
        dist = np.where(released, landing_distance(pos[0], y, vel[0], vel[1], arm.g), np.nan)
        dist_th = np.where(released, landing_distance(pos[0], y, thd * math.cos(spec.psi),
                                                      thd * math.sin(spec.psi), arm.g), np.nan)
    violation = ~released | pos_bad | np.any(speed_ratio > 1 + 1e-9, axis=0) | np.any(torque_ratio > 1 + 1e-9, axis=0)
    if traj_tau:
        traj_tau.append(traj_tau[-1])
    return ClosedLoopRun(kind, released, release_time, np.where(released, thd, np.nan),
                         np.where(released, np.hypot(*vel), np.nan), np.where(released, pos, np.nan),
                         np.where(released, vel, np.nan), dist, dist_th, speed_ratio, torque_ratio, pos_bad,
                         violation, np.array(traj_t), np.array(traj_q).T,
                         np.array(traj_tau).T if traj_tau else np.zeros((2, 0)))


def _hermite(x0, x1, f0, f1, dt, s):
    """Cubic Hermite interpolation of the state inside a step at fractions s (B,)."""
    h00, h10 = 2 * s ** 3 - 3 * s ** 2 + 1, s ** 3 - 2 * s ** 2 + s
    h01, h11 = -2 * s ** 3 + 3 * s ** 2, s ** 3 - s ** 2
    return h00 * x0 + h10 * dt * f0 + h01 * x1 + h11 * dt * f1


def _hermite_crossing(arm, spec, x0, x1, f0, f1, dt) -> np.ndarray:
    """The step fraction s in [0, 1] where theta(q(s)) = theta_e (Illinois regula falsi)."""
    g = lambda s: arm.theta_of_q(_hermite(x0, x1, f0, f1, dt, s)[:3], spec.psi) - spec.theta_e
    a = np.zeros(x0.shape[1])
    b = np.ones(x0.shape[1])
    ga, gb = g(a), g(b)
    side = np.zeros(a.size)
    for _ in range(60):
        s = np.where(gb != ga, b - gb * (b - a) / np.where(gb != ga, gb - ga, 1.0), 0.5 * (a + b))
        gs = g(s)
        left = np.sign(gs) == np.sign(ga)
        a, ga, b, gb = np.where(left, s, a), np.where(left, gs, ga), np.where(left, b, s), np.where(left, gb, gs)
        ga = np.where(~left & (side == -1), 0.5 * ga, ga)   # Illinois: halve the stale end
        gb = np.where(left & (side == 1), 0.5 * gb, gb)
        side = np.where(left, 1, -1)
        if np.all(np.abs(gs) < 1e-15) or np.all(b - a < 1e-15):
            break
    return s
