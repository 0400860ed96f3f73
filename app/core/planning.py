"""Timing laws and minimum-time motions under velocity, acceleration and torque bounds.

A rest-to-rest motion of amplitude ``delta`` in time T follows a normalized timing law: cubic,
quintic, bang-bang (triangular velocity), or trapezoidal velocity (bang-coast-bang) with an
acceleration phase Ts. ``TimingLaw`` evaluates position, velocity and acceleration at any time.

Minimum time:
- ``trapezoid_min_time``: bounds V, A (bang-coast-bang, or bang-bang when the coast vanishes),
  also with different acceleration and deceleration bounds (``bang_bang_min_time``);
- ``minimum_time``: the smallest T of a law class of fixed shape for which the inverse-dynamics
  torque (gravity included) stays within bounds, exactly: it is the time scaling of the unit-time
  motion, sampled with the switching instants;
- ``uniform_time_scaling``: slowing a trajectory down by k (t' = k t) divides the inertial and
  Coriolis torques by k^2 and leaves gravity unchanged; the smallest feasible k.

Second-order and jerk-level inversion of differential kinematics: ``second_order_inversion``
(q'' = J^# (p'' - J' q')) and ``jerk_inversion`` (q''' = J^# (p''' - 2 J' q'' - J'' q')).

>>> law = TimingLaw.trapezoidal(delta=1.0, T=2.0, Ts=0.5)
>>> round(law.V, 4), round(law.A, 4), round(float(law(1.0)[0]), 4)
(0.6667, 1.3333, 0.5)
>>> round(trapezoid_min_time(5, V=3, A=9).T, 4)
2.0
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, List, Optional, Sequence, Tuple

import numpy as np

from .errors import UserError
from .latex import num, vec
from .steps import Step


class PlanningError(UserError):
    """Impossible timing data (e.g. a time too short for the velocity bound)."""


# ====================================================================== timing laws
@dataclass
class TimingLaw:
    """Rest-to-rest timing law sigma(t) from 0 to ``delta`` in time T.

    kind: "cubic", "quintic", "bang_bang" or "trapezoidal" (Ts = acceleration time, V = cruise
    speed, A = acceleration; for bang-bang Ts = T/2). ``A_dec`` is the deceleration when it
    differs from A (asymmetric bang-bang)."""
    kind: str
    delta: float
    T: float
    Ts: float = 0.0
    V: float = 0.0
    A: float = 0.0
    A_dec: Optional[float] = None

    # ---------------------------------------------------------------- constructors
    @staticmethod
    def polynomial(kind: str, delta: float, T: float) -> "TimingLaw":
        if kind not in ("cubic", "quintic"):
            raise PlanningError(f"unknown polynomial law '{kind}' (cubic or quintic)")
        _positive(T, "T")
        vmax = (1.5 if kind == "cubic" else 1.875) * delta / T
        amax = (6.0 if kind == "cubic" else 10 / math.sqrt(3)) * delta / T ** 2
        return TimingLaw(kind, delta, T, 0.0, vmax, amax)

    @staticmethod
    def bang_bang(delta: float, T: Optional[float] = None, A: Optional[float] = None) -> "TimingLaw":
        """Symmetric bang-bang acceleration: A = 4 delta / T^2."""
        if T is None and A is None:
            raise PlanningError("bang-bang law: give T or A")
        if T is None:
            _positive(A, "A")
            T = 2 * math.sqrt(abs(delta) / A)
        _positive(T, "T")
        A = 4 * delta / T ** 2
        return TimingLaw("bang_bang", delta, T, T / 2, A * T / 2, A)

    @staticmethod
    def trapezoidal(delta: float, T: Optional[float] = None, V: Optional[float] = None,
                    A: Optional[float] = None, Ts: Optional[float] = None, ratio: Optional[float] = None) -> "TimingLaw":
        """Trapezoidal velocity from any two of T, V, A, Ts (or T and ratio = Ts/T).

        delta = V (T - Ts), A = V / Ts."""
        sgn = 1.0 if delta >= 0 else -1.0
        d = abs(delta)
        if ratio is not None:
            if T is None or not 0 < ratio <= 0.5:
                raise PlanningError("trapezoidal law: ratio = Ts/T needs T and 0 < ratio <= 1/2")
            Ts = ratio * T
        if T is not None and Ts is not None:
            pass
        elif T is not None and V is not None:
            Ts = T - d / abs(V)
            if not 0 < Ts <= T / 2 + 1e-12:
                raise PlanningError(f"trapezoidal law: V = {V:g} cannot cover {d:g} in T = {T:g} "
                                    f"(needs {d / T:g} < V <= {2 * d / T:g})")
        elif T is not None and A is not None:
            disc = T ** 2 - 4 * d / abs(A)
            if disc < -1e-12:
                raise PlanningError(f"trapezoidal law: A = {A:g} is too small for {d:g} in T = {T:g}")
            Ts = (T - math.sqrt(max(disc, 0.0))) / 2
        elif V is not None and A is not None:
            return trapezoid_min_time(delta, V, A)
        elif Ts is not None and V is not None:
            T = d / abs(V) + Ts
        else:
            raise PlanningError("trapezoidal law: give two of T, V, A, Ts (or T and ratio)")
        _positive(T, "T")
        _positive(Ts, "Ts")
        if Ts > T / 2 + 1e-12:
            raise PlanningError(f"trapezoidal law: Ts = {Ts:g} > T/2")
        V = d / (T - Ts)
        return TimingLaw("trapezoidal", delta, T, Ts, sgn * V, sgn * V / Ts)

    # ---------------------------------------------------------------- evaluation
    @property
    def switch_times(self) -> List[float]:
        """Instants where the acceleration jumps (start and end of the deceleration included)."""
        if self.kind in ("bang_bang", "trapezoidal"):
            return sorted({0.0, self.Ts, self.T - self.deceleration_time, self.T})
        return [0.0, self.T]

    @property
    def deceleration_time(self) -> float:
        return self.Ts if self.A_dec is None else abs(self.V / self.A_dec)

    def __call__(self, t) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(position, velocity, acceleration) at times t (clamped to [0, T])."""
        t = np.clip(np.asarray(t, float), 0.0, self.T)
        if self.kind in ("cubic", "quintic"):
            x = t / self.T
            if self.kind == "cubic":
                s, ds, dds = 3 * x ** 2 - 2 * x ** 3, 6 * x - 6 * x ** 2, 6 - 12 * x
            else:
                s = 10 * x ** 3 - 15 * x ** 4 + 6 * x ** 5
                ds = 30 * x ** 2 - 60 * x ** 3 + 30 * x ** 4
                dds = 60 * x - 180 * x ** 2 + 120 * x ** 3
            return self.delta * s, self.delta * ds / self.T, self.delta * dds / self.T ** 2
        A, V, Ts, T = self.A, self.V, self.Ts, self.T
        Ad = self.A if self.A_dec is None else self.A_dec
        t_dec = T - self.deceleration_time
        p = np.where(t < Ts, 0.5 * A * t ** 2,
                     np.where(t < t_dec, 0.5 * A * Ts ** 2 + V * (t - Ts),
                              self.delta - 0.5 * Ad * (T - t) ** 2))
        v = np.where(t < Ts, A * t, np.where(t < t_dec, V, Ad * (T - t)))
        a = np.where(t < Ts, A, np.where(t < t_dec, 0.0, -Ad))
        return p, v, a

    def steps(self, unit: str = "rad") -> List[Step]:
        if self.kind in ("cubic", "quintic"):
            law = r"\sigma(\tau) = 3\tau^2 - 2\tau^3" if self.kind == "cubic" else r"\sigma(\tau) = 10\tau^3 - 15\tau^4 + 6\tau^5"
            return [Step(f"{self.kind.capitalize()} timing law",
                         law + rf",\ \tau = t/T,\quad \dot\sigma_{{max}} = {num(self.V)},\ \ddot\sigma_{{max}} = {num(self.A)}",
                         f"Rest-to-rest over {num(self.delta)} {unit} in $T = {num(self.T)}$ s.")]
        return [Step("Bang-coast-bang timing law" if self.kind == "trapezoidal" else "Bang-bang timing law",
                     rf"T = {num(self.T)},\ T_s = {num(self.Ts)},\ V = {num(self.V)},\ A = {num(self.A)}",
                     f"Accelerate at $A$ for $T_s$, cruise at $V$, decelerate; the displacement is {num(self.delta)} {unit} $= V (T - T_s)$.",
                     {"profile": {"kind": self.kind, "T": self.T, "Ts": self.Ts, "V": self.V, "A": self.A}})]


def _positive(x, name):
    if x is None or not np.isfinite(x) or x <= 0:
        raise PlanningError(f"{name} must be a positive number, got {x!r}")


def trapezoid_min_time(delta: float, V: float, A: float) -> TimingLaw:
    """Minimum-time rest-to-rest motion under |v| <= V, |a| <= A: bang-coast-bang when
    |delta| > V^2/A (T = |delta|/V + V/A), bang-bang otherwise (T = 2 sqrt(|delta|/A))."""
    _positive(V, "V")
    _positive(A, "A")
    d = abs(delta)
    sgn = 1.0 if delta >= 0 else -1.0
    if d >= V ** 2 / A:
        return TimingLaw("trapezoidal", delta, d / V + V / A, V / A, sgn * V, sgn * A)
    Ts = math.sqrt(d / A)
    return TimingLaw("bang_bang", delta, 2 * Ts, Ts, sgn * A * Ts, sgn * A)


def bang_bang_min_time(delta: float, a_accel: float, a_decel: float) -> TimingLaw:
    """Minimum time with different bounds on acceleration (first phase) and deceleration:
    T = sqrt(2 |delta| (a1 + a2) / (a1 a2)), switching at Ts = sqrt(2 |delta| a2 / (a1 (a1 + a2))).

    >>> law = bang_bang_min_time(0.4, 40/3 - 9.81, 40/3 + 9.81)
    >>> round(law.T, 4), round(law.Ts, 4)
    (0.5115, 0.4439)
    """
    _positive(a_accel, "acceleration bound")
    _positive(a_decel, "deceleration bound")
    d = abs(delta)
    sgn = 1.0 if delta >= 0 else -1.0
    T = math.sqrt(2 * d * (a_accel + a_decel) / (a_accel * a_decel))
    Ts = math.sqrt(2 * d * a_decel / (a_accel * (a_accel + a_decel)))
    return TimingLaw("bang_bang", delta, T, Ts, sgn * a_accel * Ts, sgn * a_accel, sgn * a_decel)


# ====================================================================== torque-bounded minimum time
def sample_times(law: TimingLaw, count: int = 2001) -> np.ndarray:
    """Uniform samples of [0, T] plus the switching instants (approached from both sides)."""
    t = np.linspace(0.0, law.T, count)
    extra = []
    for ts in law.switch_times:
        extra += [ts, max(ts - 1e-12 * law.T, 0.0), min(ts + 1e-12 * law.T, law.T)]
    return np.unique(np.concatenate([t, extra]))


@dataclass
class MinimumTime:
    T: float
    law: TimingLaw
    peak: float                 # max over t of |tau_i| / bound_i at the optimum (= 1)
    peak_time: float
    peak_joint: int             # 1-based
    steps: List[Step] = field(default_factory=list)


def minimum_time(make_law: Callable[[float], TimingLaw], torque: Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray],
                 gravity: Callable[[np.ndarray], np.ndarray], bounds: Sequence[float], samples: int = 4001) -> MinimumTime:
    """Smallest T such that |torque(p, v, a)_i| <= bounds_i along ``make_law(T)``, for a law class
    of fixed shape (cubic, quintic, bang-bang, trapezoid with fixed Ts/T): along the normalized
    motion the torque is tau = (tau_1 - g)/T^2 + g, with tau_1 the torque for T = 1, so T_min is the
    uniform time scaling of the unit-time motion (``uniform_time_scaling`` without the k >= 1 floor).

    ``torque`` maps arrays of path positions, velocities, accelerations (shape (k,)) to torques
    (k, n); ``gravity`` maps path positions to the gravity torques (k, n)."""
    unit = make_law(1.0)
    t = sample_times(unit, samples)
    p, v, a = unit(t)
    tau = np.atleast_2d(np.asarray(torque(p, v, a), float))
    g = np.atleast_2d(np.asarray(gravity(p), float))
    ts = uniform_time_scaling(tau, g, bounds, floor=0.0)
    T = ts.k
    law = make_law(T)
    ratio = np.abs(ts.scaled_peaks) / np.asarray(bounds, float)
    k, joint = np.unravel_index(np.argmax(ratio), ratio.shape)
    tp = float(t[k] * T)
    steps = law.steps() + [Step("Minimum time", rf"T_{{min}} = {num(T)}\ \mathrm{{s}}",
                                rf"With $T$ the inertial torques scale as $1/T^2$; joint {joint + 1} reaches its bound at $t = {num(tp)}$ s.",
                                {"profile": {"kind": law.kind, "T": law.T, "Ts": law.Ts, "V": law.V, "A": law.A}})]
    return MinimumTime(T, law, float(ratio[k, joint]), tp, int(joint) + 1, steps)


@dataclass
class TimeScaling:
    k: float
    per_joint: List[float]
    scaled_peaks: np.ndarray       # torque at the critical samples after scaling
    steps: List[Step]


def uniform_time_scaling(tau, gravity, bounds, lower_bounds=None, floor: float = 1.0) -> TimeScaling:
    """Smallest k >= floor (1: only slowing down) such that tau_k = (tau - g)/k^2 + g stays within
    the bounds at every sample.

    ``tau`` and ``gravity`` are arrays (samples x n) of the nominal torque and of its gravity part;
    ``bounds`` the upper bounds (and -bounds the lower ones unless ``lower_bounds`` is given).

    >>> ts = uniform_time_scaling([[140.0, 0.0], [0.0, 25.0]], [[34.6836, 0.0], [0.0, 12.2625]], [100, 20])
    >>> [round(k, 4) for k in ts.per_joint], round(ts.k, 4)
    ([1.2698, 1.283], 1.283)
    """
    tau = np.atleast_2d(np.asarray(tau, float))
    g = np.atleast_2d(np.asarray(gravity, float))
    hi = np.asarray(bounds, float).reshape(-1)
    lo = -hi if lower_bounds is None else np.asarray(lower_bounds, float).reshape(-1)
    dyn = tau - g
    k2 = np.full(tau.shape, floor ** 2)
    for idx in np.ndindex(tau.shape):
        a, gi, j = dyn[idx], g[idx], idx[1]
        if a > 0:
            room = hi[j] - gi
        elif a < 0:
            room = gi - lo[j]
        else:
            continue
        if room <= 0:
            raise PlanningError(f"joint {j + 1}: gravity alone ({gi:g}) reaches the torque bound; no time scaling helps")
        k2[idx] = max(floor ** 2, abs(a) / room)
    per_joint = [float(math.sqrt(k2[:, j].max())) for j in range(tau.shape[1])]
    k = max(per_joint)
    scaled = dyn / k ** 2 + g
    steps = [Step("Torque under time scaling", r"\tau_k(t') = \frac{\tau(t) - g(q(t))}{k^2} + g(q(t)),\quad t' = k t",
                  r"Inertial and Coriolis torques scale with $1/k^2$, gravity does not."),
             Step("Scaling factor", ", ".join(rf"k_{j + 1} = {num(kj)}" for j, kj in enumerate(per_joint)) + rf",\quad k = {num(k)}",
                  r"Each joint needs $k^2 \ge |\tau - g| / (\tau_{\max} - |g|)$ where its torque is largest; $k$ is the largest.")]
    return TimeScaling(k, per_joint, scaled, steps)


# ====================================================================== higher-order inversion
def second_order_inversion(J, dJdq, ddp, threshold: float = 1e-9) -> np.ndarray:
    """q'' = J^# (p'' - J' q') (minimum-norm joint acceleration)."""
    from .redundancy import pinv
    return pinv(J, threshold) @ (np.asarray(ddp, float) - np.asarray(dJdq, float))


def jerk_inversion(J, dJ, ddJ, dq, ddq, dddp, threshold: float = 1e-9) -> np.ndarray:
    """q''' = J^# (p''' - 2 J' q'' - J'' q') (minimum-norm joint jerk)."""
    from .redundancy import pinv
    J, dJ, ddJ = (np.atleast_2d(np.asarray(x, float)) for x in (J, dJ, ddJ))
    return pinv(J, threshold) @ (np.asarray(dddp, float) - 2 * dJ @ np.asarray(ddq, float) - ddJ @ np.asarray(dq, float))


def synchronized_trapezoids(deltas: Sequence[float], T: float, ratio: float) -> List[TimingLaw]:
    """Trapezoidal laws for several joints that start and stop together (same T and Ts)."""
    return [TimingLaw.trapezoidal(d, T=T, ratio=ratio) if abs(d) > 0 else TimingLaw("trapezoidal", 0.0, T, ratio * T)
            for d in deltas]
