"""One throw studied as the Throw studio shows it, as plain data (no GUI): the editable numbers of a
throw (``ThrowDraft``, which may not make a throw yet), the arm at the session's parameter values
(``ThrowStudy``), and a solved throw with its limit check, samples in time, phase portrait and both
flights of the ball (``evaluate`` -> ``ThrowView``), and where arm and ball are at any time of the
animation (``ball_at``).

>>> from app.core.throw.config import thesis_throw
>>> view = evaluate(ThrowingArm(), thesis_throw("throw1"))
>>> round(view.flights["thesis"].landing_x, 3), view.feasibility.feasible
(2.797, False)
"""
from __future__ import annotations

import math
import threading
from dataclasses import dataclass, field, replace
from typing import Callable, Dict, List, Mapping, Optional, Tuple

import numpy as np

from ..ballistics import Flight
from ..errors import UserError
from ..expressions import ExpressionError, excerpt, parse_number
from ..robot_model import refuse_negative
from .arm import ThrowingArm
from .bezier import elevate_bezier
from .closed_loop import CONTROLLERS
from .config import ThrowSpec
from .montecarlo import Study, monte_carlo
from .optimize import OptimizationResult, ThrowOptimizer
from .plants import Plant
from .portrait import PhasePortrait, phase_portrait
from .reduced import Feasibility, Throw, Trajectory
from .simulation import FullSimulation, simulate_full

PORTRAIT_RESTS = 7          # curves from rest in the phase portrait (plus the throw's own)
#: the full-dynamics checks of a throw: the VHC torques open loop, then tracking the VHC
FULL_DYNAMICS_CONTROLLERS = ("feedforward", "computed_torque")


# ====================================================================== the editable throw
@dataclass
class ThrowDraft:
    """The editable numbers of a throw (psi in degrees; a and b the Bezier control points). Unlike a
    ``ThrowSpec`` they may not make a throw (theta_e below theta_b while a slider moves); ``spec()``
    says why.

    >>> draft = ThrowDraft.of(ThrowSpec(-0.3, 0.3, math.radians(20.0), 20.0, (1.7, 1.3), (0.6, 0.3)))
    >>> draft.theta_e = -0.4
    >>> draft.spec()
    Traceback (most recent call last):
    ...
    app.core.errors.UserError: theta_e (-0.4 m) must be greater than theta_b (-0.3 m)
    >>> draft.theta_e = 0.3
    >>> round(draft.spec().psi_deg, 9), draft.raised().degree_of("a")
    (20.0, 2)
    """
    theta_b: float
    theta_e: float
    psi_deg: float
    k: float
    theta_dot_b: float
    a: List[float] = field(default_factory=list)
    b: List[float] = field(default_factory=list)
    branch: int = 1

    @staticmethod
    def of(spec: ThrowSpec) -> "ThrowDraft":
        return ThrowDraft(spec.theta_b, spec.theta_e, spec.psi_deg, spec.k, spec.theta_dot_b, list(spec.a),
                          list(spec.b), spec.branch)

    def spec(self) -> ThrowSpec:
        """The throw these numbers make (UserError when they make none)."""
        return ThrowSpec(float(self.theta_b), float(self.theta_e), math.radians(float(self.psi_deg)), float(self.k),
                         tuple(self.a), tuple(self.b), float(self.theta_dot_b), int(self.branch))

    def copy(self) -> "ThrowDraft":
        return ThrowDraft(self.theta_b, self.theta_e, self.psi_deg, self.k, self.theta_dot_b, list(self.a),
                          list(self.b), self.branch)

    def points(self, kind: str) -> List[float]:
        """The control points of q1 (``kind`` "a") or q2 ("b")."""
        if kind not in ("a", "b"):
            raise UserError(f"control points: expected 'a' or 'b', got {kind!r}")
        return self.a if kind == "a" else self.b

    def degree_of(self, kind: str) -> int:
        return len(self.points(kind)) - 1

    def raised(self) -> "ThrowDraft":
        """The same curves with one more control point each (exact degree elevation)."""
        out = self.copy()
        out.a = elevate_bezier(self.a, len(self.a))
        out.b = elevate_bezier(self.b, len(self.b))
        return out


def parse_points(text: str, name: str) -> List[float]:
    """Control points typed as numbers or constant expressions, separated by commas (or spaces).

    >>> [round(v, 6) for v in parse_points("1.7, pi/2, 1.3", "a")]
    [1.7, 1.570796, 1.3]
    >>> parse_points("1.7, x", "a")
    Traceback (most recent call last):
    ...
    app.core.errors.UserError: a: 'x' is not a number
    """
    import re

    text = (text or "").strip().strip("[]")
    parts = [p.strip() for p in (text.split(",") if "," in text else re.split(r"\s+", text)) if p.strip()]
    values = []
    for p in parts:
        try:
            v = parse_number(p)
        except (ExpressionError, UserError, TypeError, ValueError, ZeroDivisionError):
            raise UserError(f"{name}: '{p}' is not a number") from None
        if not math.isfinite(v):
            raise UserError(f"{name}: '{p}' is not a finite number")
        values.append(v)
    if len(values) < 2:
        raise UserError(f"{name}: give at least two control points, separated by commas")
    return values


def format_points(values) -> str:
    """Control points as text for a field.

    >>> format_points([1.7, 1.5707963267948966])
    '1.7, 1.5708'
    """
    return ", ".join(f"{v:.5g}" for v in values)


def parse_stiffness(text: str) -> float:
    """The wrist spring's stiffness as typed: a finite number >= 0 [N m/rad], written as a number or
    a constant expression.

    >>> parse_stiffness("1e9"), parse_stiffness("2*pi") > 6.28    # exact: 1e9 is a float exactly
    (1000000000.0, True)
    >>> parse_stiffness("-3")
    Traceback (most recent call last):
    ...
    app.core.errors.UserError: k: the wrist spring must not be negative (got -3)
    """
    try:
        value = parse_number(text.strip())
    except (ExpressionError, TypeError, ValueError):
        raise UserError(f"k: {excerpt(text)} is not a number") from None
    if not math.isfinite(value):
        raise UserError(f"k: expected a finite number, got {excerpt(text)}")
    problem = refuse_negative("k: the wrist spring", value)
    if problem:
        raise UserError(problem)
    return value


# ====================================================================== the arm of a session
class ThrowStudy:
    """The throwing arm of one robot at the parameter values of the moment: the arm is rebuilt only
    when the values change (thread-safe: the studio solves off its event thread).

    >>> study = ThrowStudy("throwing_arm")
    >>> study.arm({}) is study.arm({}), round(study.arm({"platform": 0.0}).shoulder_height, 4)
    (True, 0.3105)
    """

    def __init__(self, robot):
        self.robot = robot
        self._lock = threading.Lock()
        self._arm: Optional[ThrowingArm] = None
        self._key = None

    def arm(self, params: Mapping[str, float]) -> ThrowingArm:
        """The arm with ``params`` (robot parameter names -> values; UserError when bad)."""
        params = dict(params)
        key = tuple(sorted(params.items()))
        with self._lock:
            if self._arm is None or key != self._key:
                self._arm = ThrowingArm(self.robot, params=params)
                self._key = key
            return self._arm

    def view(self, spec: ThrowSpec, params: Mapping[str, float]) -> "ThrowView":
        """The throw solved and evaluated on the arm with ``params`` (UserError when it cannot be)."""
        return evaluate(self.arm(params), spec)


def wrist_curve(arm: ThrowingArm, spec: ThrowSpec, n: int = 121) -> Tuple[np.ndarray, np.ndarray]:
    """(s, q3(s)) on n points of s in [0, 1], NaN where the constraint cannot be reached.

    >>> from app.core.throw.config import thesis_throw
    >>> s, q3 = wrist_curve(ThrowingArm(), thesis_throw("throw1"), 5)
    >>> bool(np.all(np.isfinite(q3))), round(float(q3[0]), 4)
    (True, 0.6283)
    """
    s = np.linspace(0.0, 1.0, n)
    with np.errstate(all="ignore"):
        st = arm.constraint(spec, spec.theta_b + s * (spec.theta_e - spec.theta_b), dynamics=False, strict=False)
    q3 = st.q[2, 0].copy()
    q3[np.abs(st.u[0]) > 1.0] = np.nan
    return s, q3


# ====================================================================== one throw, evaluated
@dataclass
class ThrowView:
    """A solved throw and everything the studio draws of it."""
    spec: ThrowSpec
    throw: Throw
    feasibility: Feasibility
    samples: Trajectory                 # uniform in time from 0 to the release
    portrait: PhasePortrait
    throw_curve: np.ndarray             # theta_dot of the throw on portrait.theta (NaN outside [theta_b, theta_e])
    flights: Dict[str, Flight]          # "true" (J q') and "thesis" (theta_dot along psi)

    @property
    def release(self):
        return self.throw.release

    @property
    def duration(self) -> float:
        return self.throw.duration

    def flight_time(self, key: str = "true") -> float:
        return self.flights[key].time


def portrait_range(arm: ThrowingArm, spec: ThrowSpec, margin: float = 0.5) -> Tuple[float, float]:
    """The theta interval of the phase portrait: the throw's [theta_b, theta_e] widened by ``margin``
    times its length on both sides (equilibria often sit just outside), within the arm's reach.

    >>> from app.core.throw.config import thesis_throw
    >>> [round(v, 4) for v in portrait_range(ThrowingArm(), thesis_throw("throw1"))]
    [-0.6951, 0.7347]
    """
    reach = arm.l1 + arm.l2 + arm.l3
    d = spec.theta_e - spec.theta_b
    return max(spec.theta_b - margin * d, -reach), min(spec.theta_e + margin * d, reach)


def evaluate(arm: ThrowingArm, spec: ThrowSpec, samples: int = 240, portrait_points: int = 401,
             grid: int = 801) -> ThrowView:
    """Solve a throw (VHCError when it cannot be carried out), check its limits on ``grid`` points,
    sample it in time, draw its phase portrait and both flights of the ball."""
    throw = arm.solve(spec)
    feasibility = throw.check(grid=grid)
    traj = throw.sample(samples)
    lo, hi = portrait_range(arm, spec)
    rests = [(float(t0), 0.0) for t0 in np.linspace(lo, hi, PORTRAIT_RESTS + 2)[1:-1]]
    with np.errstate(all="ignore"):
        portrait = phase_portrait(arm, spec, (lo, hi), rests + [(spec.theta_b, spec.theta_dot_b)], n=portrait_points)
    inside = (portrait.theta >= spec.theta_b) & (portrait.theta <= spec.theta_e)
    curve = np.full(portrait.theta.size, np.nan)
    curve[inside] = throw.theta_dot(portrait.theta[inside])
    rel = throw.release
    flights = {"true": Flight(tuple(rel.position), tuple(rel.velocity), arm.g),
               "thesis": Flight(tuple(rel.position), tuple(rel.velocity_thesis), arm.g)}
    return ThrowView(spec, throw, feasibility, traj, portrait, curve, flights)


def ball_at(view: ThrowView, t: float, key: str = "true") -> Tuple[np.ndarray, np.ndarray]:
    """Joint angles and ball position (x, y) at time t of the animation: the swing until the
    release, then the ball's flight (the arm holds its release pose) until it lands.

    >>> from app.core.throw.config import thesis_throw
    >>> view = evaluate(ThrowingArm(), thesis_throw("throw1"))
    >>> q, ball = ball_at(view, 10.0)      # landed: on the ground (y exactly 0) where the flight lands
    >>> f"{ball[0]:.3f} m", f'{view.flights["true"].landing_x:.3f} m', bool(ball[1] == 0)
    ('2.594 m', '2.594 m', True)
    >>> q, ball = ball_at(view, 0.0)       # the start: the arm at the throw's first sample
    >>> bool(np.allclose(q, view.samples.q[:, 0])), bool(np.allclose(ball, view.samples.ball[:, 0]))
    (True, True)
    """
    tr = view.samples
    if t <= view.duration:
        q = np.array([np.interp(t, tr.t, tr.q[i]) for i in range(3)])
        ball = np.array([np.interp(t, tr.t, tr.ball[j]) for j in range(2)])
        return q, ball
    return tr.q[:, -1].copy(), view.flights[key].position_at(t - view.duration)


def verify_in_full_dynamics(throw: Throw, progress: Optional[Callable[[float, str], None]] = None
                            ) -> List[FullSimulation]:
    """The throw simulated in full dynamics under each of ``FULL_DYNAMICS_CONTROLLERS``;
    ``progress(fraction, stage)`` from 0 to 1 over both (it may stop the work by raising)."""
    report = progress or (lambda _f, _m: None)
    sims = []
    for k, controller in enumerate(FULL_DYNAMICS_CONTROLLERS):
        stage = controller.replace("_", " ")
        report(0.5 * k, stage)
        sims.append(simulate_full(throw, controller,
                                  progress=lambda f, m, k=k, stage=stage: report(0.5 * (k + f), stage)))
    return sims


def optimize_and_verify(robot, values: Mapping[str, float], objective: str, seed: int, budget: int,
                        progress: Callable[[float, str], None]) -> Tuple[OptimizationResult, List[FullSimulation]]:
    """The studio's Optimize button: the optimizer's best throw on the arm with ``values``, then its
    full-dynamics checks (progress 0-0.9, then 0.9-1). Returns the result without its arm, throw and
    feasibility (compiled functions that do not leave a worker process), and the simulations."""
    arm = ThrowingArm(robot, params=values)
    result = ThrowOptimizer(arm, objective=objective).run(seed=seed, evaluations=budget, progress=progress)
    sims = verify_in_full_dynamics(result.throw, lambda f, stage: progress(0.9 + 0.1 * f, f"full dynamics: {stage}"))
    return replace(result, throw=None, feasibility=None), sims


def verify_throw(robot, values: Mapping[str, float], spec: ThrowSpec,
                 progress: Callable[[float, str], None]) -> List[FullSimulation]:
    """The studio's Verify button: the throw of ``spec`` on the arm with ``values``, simulated in the
    full dynamics (``verify_in_full_dynamics``; in a worker process, where the arm is rebuilt)."""
    return verify_in_full_dynamics(ThrowingArm(robot, params=values).solve(spec), progress)


def closed_loop_study(robot, values: Mapping[str, float], spec: ThrowSpec, plant: Plant, count: int, seed: int,
                      progress: Callable[[float, str], None]) -> Study:
    """The studio's closed-loop study: ``count`` plants drawn from ``plant`` throwing ``spec`` under
    each controller (``monte_carlo``; in a worker process, where the arm is rebuilt)."""
    throw = ThrowingArm(robot, params=values).solve(spec)
    return monte_carlo(throw, plant, CONTROLLERS, count, seed=seed, progress=progress)
