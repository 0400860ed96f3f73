"""Reference trajectories q_d(t) with their first and second derivatives, for closed-loop runs.

A reference is evaluated on a whole time grid at once (vectorized), so a simulation computes it
before its loop. Kinds: a set point, rest-to-rest cubic and quintic polynomials, minimum-time
profiles under bounds (bang-bang under an acceleration bound, trapezoidal velocity under velocity
and acceleration bounds, all joints synchronized to the slowest), and sinusoids. Every vector
argument takes one value per coordinate, or a single value for all.

>>> ref = Polynomial([0.0, 0.0], [1.0, 2.0], duration=2.0, order=5)
>>> qd, dqd, ddqd = ref.sample(np.array([0.0, 1.0, 2.0, 3.0]))
>>> (qd.round(9) + 0.0).tolist()
[[0.0, 0.0], [0.5, 1.0], [1.0, 2.0], [1.0, 2.0]]
>>> dqd[1].round(9).tolist()                  # 15/8 * distance / duration at mid-time
[0.9375, 1.875]
>>> round(parse_reference("trapezoidal goal=1 vmax=1 amax=2", start=[0.0]).motion_time, 9)
1.5
"""
from __future__ import annotations

from typing import Dict, Optional, Sequence, Tuple

import numpy as np

from .errors import UserError
from .expressions import ExpressionError, parse_number

Samples = Tuple[np.ndarray, np.ndarray, np.ndarray]


class TrajectoryError(UserError):
    """A reference trajectory is malformed (missing goal, negative bound, wrong length, ...)."""


def _vector(value, n: int, what: str) -> np.ndarray:
    arr = np.atleast_1d(np.asarray(value, dtype=float)).reshape(-1)
    if arr.size == 1 and n != 1:
        arr = np.full(n, float(arr[0]))
    if arr.size != n:
        raise TrajectoryError(f"{what}: expected {n} values (one per coordinate) or one for all, got {arr.size}")
    if not np.all(np.isfinite(arr)):
        raise TrajectoryError(f"{what}: values must be finite numbers")
    return arr


class Reference:
    """Base class: ``sample(t)`` gives (q_d, q'_d, q''_d), each of shape (len(t), n)."""
    kind = ""
    #: time after which the reference is constant (None: never, e.g. a sinusoid)
    motion_time: Optional[float] = 0.0

    def __init__(self, n: int):
        self.n = n

    def sample(self, t) -> Samples:
        raise NotImplementedError

    def at(self, t: float) -> Samples:
        """(q_d, q'_d, q''_d) at one time instant, as 1-D arrays."""
        q, dq, ddq = self.sample(np.array([float(t)]))
        return q[0], dq[0], ddq[0]

    def describe(self) -> str:
        """The reference as text that ``parse_reference`` reads back."""
        raise NotImplementedError


def _fmt(v: np.ndarray) -> str:
    return ",".join(f"{x:.10g}" for x in v)


class SetPoint(Reference):
    """A constant q_d (regulation).

    >>> SetPoint([0.5, -1]).at(3.0)[0].tolist()           # exact: the set point itself
    [0.5, -1.0]
    """
    kind = "setpoint"

    def __init__(self, goal):
        goal = np.atleast_1d(np.asarray(goal, dtype=float))
        super().__init__(goal.size)
        self.goal = _vector(goal, self.n, "setpoint goal")

    def sample(self, t):
        t = np.atleast_1d(np.asarray(t, dtype=float))
        q = np.tile(self.goal, (t.size, 1))
        return q, np.zeros_like(q), np.zeros_like(q)

    def describe(self):
        return f"setpoint goal={_fmt(self.goal)}"


class Polynomial(Reference):
    """Rest-to-rest cubic (order 3: zero boundary velocities) or quintic (order 5: zero boundary
    velocities and accelerations) from ``start`` to ``goal`` in ``duration`` seconds, starting at
    ``t0``; constant outside [t0, t0 + duration].

    >>> bool(abs(Polynomial([0], [1], duration=1.0, order=3).at(0.5)[2][0]) < 1e-12)   # cubic: a(T/2) = 0
    True
    """

    def __init__(self, start, goal, duration: float, order: int = 5, t0: float = 0.0):
        goal = np.atleast_1d(np.asarray(goal, dtype=float))
        super().__init__(goal.size)
        if order not in (3, 5):
            raise TrajectoryError(f"polynomial order must be 3 (cubic) or 5 (quintic), got {order}")
        if not duration > 0:
            raise TrajectoryError(f"{'cubic' if order == 3 else 'quintic'}: the duration T must be positive, got {duration}")
        self.start = _vector(start, self.n, "start")
        self.goal = _vector(goal, self.n, "goal")
        self.duration, self.order, self.t0 = float(duration), order, float(t0)
        self.kind = "cubic" if order == 3 else "quintic"
        self.motion_time = self.t0 + self.duration

    def sample(self, t):
        t = np.atleast_1d(np.asarray(t, dtype=float))
        T = self.duration
        s = np.clip((t - self.t0) / T, 0.0, 1.0)[:, None]
        inside = ((t > self.t0) & (t < self.t0 + T))[:, None]
        if self.order == 3:
            p, dp, ddp = 3 * s ** 2 - 2 * s ** 3, 6 * s - 6 * s ** 2, 6 - 12 * s
        else:
            p = 10 * s ** 3 - 15 * s ** 4 + 6 * s ** 5
            dp = 30 * s ** 2 - 60 * s ** 3 + 30 * s ** 4
            ddp = 60 * s - 180 * s ** 2 + 120 * s ** 3
        D = self.goal - self.start
        return (self.start + p * D, np.where(inside, dp * D / T, 0.0), np.where(inside, ddp * D / T ** 2, 0.0))

    def describe(self):
        return (f"{self.kind} from={_fmt(self.start)} goal={_fmt(self.goal)} T={self.duration:g}"
                + (f" t0={self.t0:g}" if self.t0 else ""))


class MinimumTime(Reference):
    """Minimum-time rest-to-rest motion under |q''| <= amax (bang-bang) and, when ``vmax`` is
    given, |q'| <= vmax (trapezoidal velocity, bang-coast-bang). Each joint's own minimum time is
    computed; with ``synchronized`` (default) every joint is slowed to finish with the slowest one,
    keeping its acceleration bound and lowering its cruise speed.

    >>> ref = MinimumTime([0], [1], amax=4.0)          # bang-bang: T = 2 sqrt(D / a)
    >>> round(ref.motion_time, 9)
    1.0
    """

    def __init__(self, start, goal, amax, vmax=None, synchronized: bool = True, t0: float = 0.0):
        goal = np.atleast_1d(np.asarray(goal, dtype=float))
        super().__init__(goal.size)
        self.start = _vector(start, self.n, "start")
        self.goal = _vector(goal, self.n, "goal")
        self.amax = _vector(amax, self.n, "amax")
        if np.any(self.amax <= 0):
            raise TrajectoryError("amax (acceleration bound) must be positive")
        self.vmax = None if vmax is None else _vector(vmax, self.n, "vmax")
        if self.vmax is not None and np.any(self.vmax <= 0):
            raise TrajectoryError("vmax (velocity bound) must be positive")
        self.kind = "bangbang" if vmax is None else "trapezoidal"
        self.t0 = float(t0)
        D = np.abs(self.goal - self.start)
        a = self.amax
        v = np.sqrt(D * a) if self.vmax is None else np.minimum(self.vmax, np.sqrt(D * a))
        with np.errstate(divide="ignore", invalid="ignore"):
            T = np.where(D > 0, D / np.where(v > 0, v, 1) + v / a, 0.0)   # T = D/v + v/a
        self.joint_times = T
        Tall = float(T.max()) if T.size else 0.0
        if synchronized and Tall > 0:
            # cruise speed that reaches D in Tall with acceleration a: v = (a T - sqrt(a^2 T^2 - 4 a D)) / 2
            disc = np.maximum(a * a * Tall * Tall - 4 * a * D, 0.0)
            v = (a * Tall - np.sqrt(disc)) / 2
            T = np.where(D > 0, Tall, 0.0)
        self.cruise = v
        self.times = T
        self.motion_time = self.t0 + Tall

    def sample(self, t):
        t = np.atleast_1d(np.asarray(t, dtype=float))[:, None] - self.t0
        sign = np.sign(self.goal - self.start)
        a, v, T = self.amax, self.cruise, self.times
        with np.errstate(divide="ignore", invalid="ignore"):
            ta = np.where(a > 0, v / a, 0.0)                  # end of the acceleration phase
        tc = np.clip(t, 0.0, T)
        acc_phase = tc < ta
        dec_phase = tc > T - ta
        s_acc = 0.5 * a * tc ** 2
        s_cruise = 0.5 * a * ta ** 2 + v * (tc - ta)
        s_dec = np.abs(self.goal - self.start) - 0.5 * a * (T - tc) ** 2
        s = np.where(acc_phase, s_acc, np.where(dec_phase, s_dec, s_cruise))
        ds = np.where(acc_phase, a * tc, np.where(dec_phase, a * (T - tc), v))
        dds = np.where(acc_phase, a, np.where(dec_phase, -a, 0.0))
        moving = (t > 0) & (t < T)
        ds = np.where(moving, ds, 0.0)
        dds = np.where(moving, dds, 0.0)
        return self.start + sign * s, sign * ds, sign * dds

    def describe(self):
        text = f"{self.kind} from={_fmt(self.start)} goal={_fmt(self.goal)} amax={_fmt(self.amax)}"
        if self.vmax is not None:
            text += f" vmax={_fmt(self.vmax)}"
        return text + (f" t0={self.t0:g}" if self.t0 else "")


class Sinusoid(Reference):
    """q_d(t) = center + amplitude sin(2 pi f t + phase).

    >>> Sinusoid([0], [1], 0.25).at(1.0)[0].round(12).tolist()
    [1.0]
    """
    kind = "sine"
    motion_time = None

    def __init__(self, center, amplitude, frequency, phase=0.0):
        amplitude = np.atleast_1d(np.asarray(amplitude, dtype=float))
        center = np.atleast_1d(np.asarray(center, dtype=float))
        super().__init__(max(amplitude.size, center.size))
        self.center = _vector(center, self.n, "center")
        self.amplitude = _vector(amplitude, self.n, "amplitude")
        self.frequency = _vector(frequency, self.n, "frequency f")
        self.phase = _vector(phase, self.n, "phase")
        if np.any(self.frequency < 0):
            raise TrajectoryError("the frequency f must not be negative")

    def sample(self, t):
        t = np.atleast_1d(np.asarray(t, dtype=float))[:, None]
        w = 2 * np.pi * self.frequency
        arg = w * t + self.phase
        return (self.center + self.amplitude * np.sin(arg), self.amplitude * w * np.cos(arg),
                -self.amplitude * w * w * np.sin(arg))

    def describe(self):
        return (f"sine center={_fmt(self.center)} amplitude={_fmt(self.amplitude)} f={_fmt(self.frequency)}"
                + (f" phase={_fmt(self.phase)}" if np.any(self.phase) else ""))


#: kind -> (allowed keys, required keys, one-line help)
REFERENCE_KINDS: Dict[str, Tuple[Tuple[str, ...], Tuple[str, ...], str]] = {
    "setpoint": (("goal", "by"), (), "constant q_d = goal (default: the initial value)"),
    "cubic": (("goal", "by", "T", "from", "t0"), ("goal", "T"), "rest-to-rest cubic polynomial to goal in T s"),
    "quintic": (("goal", "by", "T", "from", "t0"), ("goal", "T"), "rest-to-rest quintic polynomial to goal in T s"),
    "bangbang": (("goal", "by", "amax", "from", "t0"), ("goal", "amax"), "minimum time under |acceleration| <= amax"),
    "trapezoidal": (("goal", "by", "vmax", "amax", "from", "t0"), ("goal", "vmax", "amax"),
                    "minimum time under |velocity| <= vmax and |acceleration| <= amax"),
    "sine": (("center", "amplitude", "f", "phase"), ("amplitude", "f"),
             "center + amplitude sin(2 pi f t + phase) (center default: the initial value)"),
}


def parse_reference(text: Optional[str], start: Sequence[float], names: Optional[Sequence[str]] = None) -> Reference:
    """Read a reference from text ``KIND key=value ...``; vector values are comma-separated (one
    per coordinate, or one for all) and may use ``pi``. ``start`` is the initial value of the
    referenced coordinates: motions start there unless ``from=...`` says otherwise (an initial
    error); ``by=...`` gives the goal as a displacement from the start; an empty text holds the
    start (set point).

    >>> parse_reference("quintic goal=pi/2,0 T=2", start=[0, 0]).describe()
    'quintic from=0,0 goal=1.570796327,0 T=2'
    >>> parse_reference("setpoint by=0.5", start=[0.2, 1.0]).goal.round(9).tolist()
    [0.7, 1.5]
    >>> parse_reference("cubic T=2", start=[0, 0])
    Traceback (most recent call last):
    ...
    app.core.trajectories.TrajectoryError: reference 'cubic': missing goal (rest-to-rest cubic polynomial to goal in T s; or by=, a displacement)
    """
    start = np.asarray(start, dtype=float).reshape(-1)
    n = start.size
    names = list(names) if names is not None else [f"q{i + 1}" for i in range(n)]
    text = (text or "").strip()
    if not text:
        return SetPoint(start)
    kind, *items = text.split()
    kind = kind.lower()
    if kind not in REFERENCE_KINDS:
        raise TrajectoryError(f"unknown reference kind '{kind}' (use one of {', '.join(REFERENCE_KINDS)})")
    allowed, required, help_text = REFERENCE_KINDS[kind]
    values: Dict[str, np.ndarray] = {}
    for item in items:
        if "=" not in item:
            raise TrajectoryError(f"reference '{kind}': expected key=value, got '{item}'")
        key, raw = item.split("=", 1)
        if key not in allowed:
            raise TrajectoryError(f"reference '{kind}': unknown key '{key}' (allowed: {', '.join(allowed)})")
        try:
            vals = [parse_number(part) for part in raw.split(",")]
        except (ExpressionError, TypeError, ValueError) as exc:
            raise TrajectoryError(f"reference '{kind}': {key}={raw}: {exc}") from None
        if len(vals) not in (1, n):
            raise TrajectoryError(f"reference '{kind}': {key} needs {n} values ({', '.join(names)}) or one, got {len(vals)}")
        values[key] = _vector(vals, n, f"reference '{kind}': {key}")
    start = values.get("from", start)
    if "by" in values:              # a displacement from the start instead of a goal
        if "goal" in values:
            raise TrajectoryError(f"reference '{kind}': give goal or by, not both")
        values["goal"] = start + values.pop("by")
    for key in required:
        if key not in values:
            raise TrajectoryError(f"reference '{kind}': missing {key} ({help_text}; or by=, a displacement)")
    t0 = float(values["t0"][0]) if "t0" in values else 0.0
    if kind == "setpoint":
        return SetPoint(values.get("goal", start))
    if kind in ("cubic", "quintic"):
        T = values["T"]
        if np.ptp(T) > 0:
            raise TrajectoryError(f"reference '{kind}': T is one duration for all coordinates")
        return Polynomial(start, values["goal"], float(T[0]), order=3 if kind == "cubic" else 5, t0=t0)
    if kind == "bangbang":
        return MinimumTime(start, values["goal"], values["amax"], t0=t0)
    if kind == "trapezoidal":
        return MinimumTime(start, values["goal"], values["amax"], values["vmax"], t0=t0)
    return Sinusoid(values.get("center", start), values["amplitude"], values["f"], values.get("phase", 0.0))
