"""The ball-catching arm of the 4M20 coursework (seeds/ball-catching-coursework.txt).

A planar 3R arm (robot file ``catching_arm``: L = 0.8, 0.8, 0.3 m, theta1 in [-90, 90] deg,
theta2 and theta3 in [-160, 160] deg) stands on the floor (y = 0) and catches a ball in flight:

- ``CatchingArm.forward``: end-effector position (from the robot file's kinematics);
- ``CatchingArm.ik_family``: every joint solution for a point, parametrized by the hand orientation
  phi = theta2 + theta3 - theta1 (the coursework's redundant variable), two elbow branches, within
  the joint limits (the coursework's Table 1 rows are members of it);
- ``CatchingArm.reachable_region``: boundary polylines of the reachable set (above the floor), from a
  reachability grid and marching squares, for the viewer to draw;
- ``BallFlight``: the ball of eqs. (1)-(2), x = -u cos(alpha) t + x0, y = u sin(alpha) t + g t^2/2 + y0;
  ``BallFlight.from_release`` takes any release position/velocity (e.g. the throwing arm's);
- ``plan_catch``: the part of the flight inside the reachable region, the interception point and
  time (middle of that part, or the point closest to the hand), the joint solution that moves the
  joints least (l1 norm) and synchronized trapezoidal velocity profiles that reach it at the catch;
- ``catch_scene``: a throw of the throwing arm (a release state) and its catch, as one scene.

Angles are in radians unless a name says ``_deg``.

>>> arm = CatchingArm()
>>> np.round(arm.forward(np.radians([30, 120, 80])), 4).tolist()
[0.4521, 0.3974]
>>> ball = BallFlight.coursework(alpha_deg=45)
>>> round(ball.time_at_height(1.634)[0], 3)
0.289
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np
import sympy as sp

from .errors import UserError
from .numeric import numeric_function
from .planning import TimingLaw, synchronized_trapezoids
from .robot import RobotModel, load_robot
from .trajectories import Reference

#: the coursework's trapezoid: Ts/T minimizing |theta''_max| T/2 + |theta'_max| (= (sqrt(3) - 1)/2)
WEIGHTED_RATIO = (math.sqrt(3.0) - 1.0) / 2.0


class CatchError(UserError):
    """The ball cannot be caught (never inside the reachable region, or no joint solution)."""


def _wrap(a):
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


class CatchingArm:
    """Kinematics of the catching arm, read from its robot file (lengths, limits)."""

    def __init__(self, robot: RobotModel | str = "catching_arm", params: Optional[Dict[str, float]] = None):
        self.robot = load_robot(robot) if isinstance(robot, str) else robot
        values = self.robot.parameter_values(params)
        self.values = dict(values)
        self.L = np.array([values["L1"], values["L2"], values["L3"]], float)
        lims = [self.robot.limits[c].position for c in self.robot.coordinates]
        self.lower = np.array([l[0] for l in lims], float)
        self.upper = np.array([l[1] for l in lims], float)
        from .jacobians import task_function
        r = task_function(self.robot, "ee", ("x", "y"))
        subs = {sp.Symbol(k, real=True): v for k, v in values.items()}
        self._fk = numeric_function([self.robot.q], r.xreplace(subs), "numpy")

    # ---------------------------------------------------------------- kinematics
    def forward(self, q) -> np.ndarray:
        """End-effector position (x, y) for joint angles q (rad); q may be (3,) or (3, k)."""
        return np.asarray(self._fk(np.asarray(q, float)), float).reshape(2, *np.shape(q)[1:])

    def joints(self, q) -> np.ndarray:
        """Positions of the base, joints 2 and 3 and the hand, (4, 2), for drawing."""
        a1 = -q[0]
        a2 = a1 + q[1]
        a3 = a2 + q[2]
        pts = [np.zeros(2)]
        for L, a in zip(self.L, (a1, a2, a3)):
            pts.append(pts[-1] + L * np.array([math.sin(a), math.cos(a)]))
        return np.array(pts)

    def within_limits(self, q, tol: float = 1e-9) -> np.ndarray:
        q = np.asarray(q, float)
        return np.all((q >= self.lower[:, None] - tol) & (q <= self.upper[:, None] + tol), axis=0) if q.ndim == 2 \
            else bool(np.all((q >= self.lower - tol) & (q <= self.upper + tol)))

    def ik(self, point, phi, elbow: int = 1) -> Optional[np.ndarray]:
        """Joint angles placing the hand at ``point`` with orientation phi = theta2 + theta3 - theta1
        (angle of link 3 from the vertical, clockwise), elbow = +1 or -1 (sign of theta2); None if
        the wrist is out of reach. Limits are not checked here."""
        q = self._ik(np.asarray(point, float)[:, None], np.atleast_1d(phi), elbow)
        return None if np.any(np.isnan(q)) else q[:, 0]

    def _ik(self, p, phi, elbow):
        """Vectorized IK: p (2, k) or (2, 1), phi (k,) -> q (3, k) with NaN when unreachable."""
        L1, L2, L3 = self.L
        wx = p[0] - L3 * np.sin(phi)
        wy = p[1] - L3 * np.cos(phi)
        c2 = (wx ** 2 + wy ** 2 - L1 ** 2 - L2 ** 2) / (2 * L1 * L2)
        c2 = np.where(np.abs(c2) <= 1 + 1e-12, np.clip(c2, -1, 1), np.nan)
        t2 = elbow * np.arccos(c2)
        # absolute angles from the vertical, clockwise: (x, y) = sum L (sin a, cos a)
        a1 = np.arctan2(wx, wy) - np.arctan2(L2 * np.sin(t2), L1 + L2 * np.cos(t2))
        t1 = _wrap(-a1)
        t3 = _wrap(phi - a1 - t2)
        return np.stack([t1, t2, t3])

    def ik_family(self, point, samples: int = 1441) -> List[np.ndarray]:
        """All joint solutions for a point within the limits: a list of branches, each (4, k) with
        rows phi, theta1, theta2, theta3 (phi sampled over [-pi, pi])."""
        phi = np.linspace(-np.pi, np.pi, samples)
        p = np.asarray(point, float).reshape(2, 1)
        out = []
        for elbow in (1, -1):
            q = self._ik(p, phi, elbow)
            ok = ~np.any(np.isnan(q), axis=0)
            ok[ok] = self.within_limits(q[:, ok])
            idx = np.flatnonzero(ok)
            if idx.size == 0:
                continue
            for run in np.split(idx, np.flatnonzero(np.diff(idx) > 1) + 1):
                out.append(np.vstack([phi[run], q[:, run]]))
        return out

    def reachable(self, points, samples: int = 241, chunk: int = 4096) -> np.ndarray:
        """Boolean mask: which points (2, k) have a joint solution within the limits (hand
        orientations sampled at ``samples`` values)."""
        p = np.asarray(points, float)
        phi = np.linspace(-np.pi, np.pi, samples)[:, None]
        ok = np.zeros(p.shape[1], dtype=bool)
        for start in range(0, p.shape[1], chunk):
            sl = slice(start, start + chunk)
            P = p[:, sl][:, None, :]                      # (2, 1, k)
            for elbow in (1, -1):
                q = self._ik(P, phi, elbow)               # (3, m, k)
                good = ~np.any(np.isnan(q), axis=0)
                good &= np.all((q >= self.lower[:, None, None] - 1e-9) & (q <= self.upper[:, None, None] + 1e-9), axis=0)
                ok[sl] |= good.any(axis=0)
        return ok

    def reachable_region(self, resolution: float = 0.02, floor: Optional[float] = 0.0,
                         samples: int = 181) -> List[np.ndarray]:
        """Boundary of the reachable region as closed polylines ((k, 2) arrays, x and y in m);
        with ``floor`` only the part above it (y >= floor) is kept, as in the coursework."""
        R = float(self.L.sum())
        xs = np.arange(-R - 2 * resolution, R + 2 * resolution + 1e-12, resolution)
        y0 = (floor if floor is not None else -R) - 2 * resolution
        ys = np.arange(y0, R + 2 * resolution + 1e-12, resolution)
        X, Y = np.meshgrid(xs, ys)
        mask = self.reachable(np.vstack([X.ravel(), Y.ravel()]), samples).reshape(X.shape)
        if floor is not None:
            mask &= Y >= floor
        lines = marching_squares(mask.astype(float), xs, ys, 0.5)
        if floor is not None:
            for line in lines:
                line[:, 1] = np.maximum(line[:, 1], floor)
        return lines

    def jacobian(self, q) -> np.ndarray:
        """2 x 3 position Jacobian at q (numeric)."""
        a1 = -q[0]
        a = np.array([a1, a1 + q[1], a1 + q[1] + q[2]])
        L = self.L
        dx = np.array([L[k] * math.cos(a[k]) for k in range(3)])
        dy = np.array([-L[k] * math.sin(a[k]) for k in range(3)])
        # da_k/dtheta: a1 = -t1, a2 = -t1 + t2, a3 = -t1 + t2 + t3
        D = np.array([[-1, 0, 0], [-1, 1, 0], [-1, 1, 1]], float)
        return np.vstack([dx @ D, dy @ D])


def marching_squares(field: np.ndarray, xs: np.ndarray, ys: np.ndarray, level: float) -> List[np.ndarray]:
    """Contour lines of a sampled field (rows along ys, columns along xs) at ``level``, chained into
    polylines ((k, 2) arrays). Saddle cells are resolved by the cell average."""
    F = np.asarray(field, float)
    segs = []

    def interp(p1, p2, v1, v2):
        t = (level - v1) / (v2 - v1)
        return (p1[0] + t * (p2[0] - p1[0]), p1[1] + t * (p2[1] - p1[1]))

    for i in range(F.shape[0] - 1):
        for j in range(F.shape[1] - 1):
            v = [F[i, j], F[i, j + 1], F[i + 1, j + 1], F[i + 1, j]]
            inside = [x > level for x in v]
            if all(inside) or not any(inside):
                continue
            c = [(xs[j], ys[i]), (xs[j + 1], ys[i]), (xs[j + 1], ys[i + 1]), (xs[j], ys[i + 1])]
            cross = []
            for k in range(4):
                a, b = k, (k + 1) % 4
                if inside[a] != inside[b]:
                    cross.append((k, interp(c[a], c[b], v[a], v[b])))
            if len(cross) == 2:
                segs.append((cross[0][1], cross[1][1]))
            else:   # saddle: pair edges according to the centre value
                centre = sum(v) / 4 > level
                e = dict(cross)
                pairs = [(0, 1), (2, 3)] if centre != inside[1] else [(0, 3), (1, 2)]
                for a, b in pairs:
                    segs.append((e[a], e[b]))
    # chain the segments
    key = lambda p: (round(p[0], 9), round(p[1], 9))
    ends: Dict[tuple, List[int]] = {}
    for k, (a, b) in enumerate(segs):
        ends.setdefault(key(a), []).append(k)
        ends.setdefault(key(b), []).append(k)
    used = np.zeros(len(segs), dtype=bool)
    lines = []
    for start in range(len(segs)):
        if used[start]:
            continue
        used[start] = True
        a, b = segs[start]
        line = [a, b]
        for direction in (1, 0):
            while True:
                tip = line[-1] if direction else line[0]
                nxt = [k for k in ends.get(key(tip), []) if not used[k]]
                if not nxt:
                    break
                k = nxt[0]
                used[k] = True
                p, q = segs[k]
                new = q if key(p) == key(tip) else p
                if direction:
                    line.append(new)
                else:
                    line.insert(0, new)
        lines.append(np.array(line))
    return sorted(lines, key=len, reverse=True)


# ====================================================================== the ball
@dataclass
class BallFlight:
    """Ballistic flight without drag: p(t) = p0 + v0 t + (0, g t^2 / 2), g < 0 (coursework eq. 1)."""
    p0: np.ndarray
    v0: np.ndarray
    g: float = -9.81

    @staticmethod
    def coursework(u: float = 10.0, alpha_deg: float = 45.0, x0: float = 3.0, y0: float = 0.0, g: float = -9.81) -> "BallFlight":
        """Eq. (1): thrown from (x0, y0) towards -x at speed u and elevation alpha."""
        a = math.radians(alpha_deg)
        return BallFlight(np.array([x0, y0]), np.array([-u * math.cos(a), u * math.sin(a)]), g)

    @staticmethod
    def from_release(position, velocity, g: float = 9.81, origin=(0.0, 0.0)) -> "BallFlight":
        """A ball released at ``position`` with ``velocity`` (world frame, gravity g > 0 downwards),
        expressed in a frame whose origin is ``origin`` (e.g. the catching arm's base)."""
        return BallFlight(np.asarray(position, float) - np.asarray(origin, float), np.asarray(velocity, float), -abs(g))

    def position(self, t) -> np.ndarray:
        t = np.asarray(t, float)
        return np.array([self.p0[0] + self.v0[0] * t, self.p0[1] + self.v0[1] * t + 0.5 * self.g * t ** 2])

    def velocity(self, t) -> np.ndarray:
        t = np.asarray(t, float)
        return np.array([self.v0[0] + 0 * t, self.v0[1] + self.g * t])

    def time_at_height(self, y: float) -> Tuple[float, ...]:
        """Eq. (2): the times (ascending) at which the ball is at height y."""
        a, b, c = 0.5 * self.g, self.v0[1], self.p0[1] - y
        disc = b * b - 4 * a * c
        if disc < 0:
            return ()
        r = sorted({float((-b + s * math.sqrt(disc)) / (2 * a)) for s in (1, -1)})
        return tuple(t for t in r if t >= 0)

    def landing_time(self, floor: float = 0.0) -> float:
        times = self.time_at_height(floor)
        if not times:
            raise CatchError("the ball never reaches the floor")
        return times[-1]


# ====================================================================== planning the catch
@dataclass
class CatchPlan:
    time: float                        # interception time [s]
    point: np.ndarray                  # interception point [m]
    window: Tuple[float, float]        # entry and exit times of the reachable region
    q_start: np.ndarray
    q_catch: np.ndarray
    phi: float                         # hand orientation at the catch
    laws: List[TimingLaw]              # one per joint, synchronized, ending at the catch
    ratio: float                       # Ts / T of the trapezoids
    family: List[np.ndarray] = field(default_factory=list)

    @property
    def joint_speed_max(self) -> np.ndarray:
        return np.array([law.V for law in self.laws])

    @property
    def joint_acceleration_max(self) -> np.ndarray:
        return np.array([law.A for law in self.laws])

    def joint_motion(self, t) -> np.ndarray:
        """Joint angles (3, k) at times t (held at q_catch after the catch)."""
        return np.array([q0 + law(t)[0] for q0, law in zip(self.q_start, self.laws)])


def _crossings(mask: np.ndarray, t: np.ndarray, arm: CatchingArm, ball: BallFlight) -> List[Tuple[float, float]]:
    """Time intervals where the ball is reachable, with the ends refined by bisection."""
    def ok(tt):
        return bool(arm.reachable(ball.position(tt).reshape(2, 1))[0]) and ball.position(tt)[1] >= 0

    def refine(a, b, inside_a):
        for _ in range(40):
            m = 0.5 * (a + b)
            if ok(m) == inside_a:
                a = m
            else:
                b = m
        return 0.5 * (a + b)

    out = []
    idx = np.flatnonzero(mask)
    if idx.size == 0:
        return out
    for run in np.split(idx, np.flatnonzero(np.diff(idx) > 1) + 1):
        i0, i1 = run[0], run[-1]
        t0 = t[0] if i0 == 0 else refine(t[i0 - 1], t[i0], False)
        t1 = t[-1] if i1 == len(t) - 1 else refine(t[i1], t[i1 + 1], True)
        out.append((t0, t1))
    return out


def plan_catch(arm: CatchingArm, ball: BallFlight, q_start, method: str = "middle", ratio: float = WEIGHTED_RATIO,
               samples: int = 801, floor: float = 0.0, time: Optional[float] = None, norm: str = "l1") -> CatchPlan:
    """Where, when and how to catch: the interception point on the reachable part of the flight
    (``middle`` of the first reachable stretch in time, ``closest`` to the hand's start position,
    or the given ``time``), the joint solution closest to q_start (``norm`` l1, as the coursework, or
    linf), and trapezoidal joint motions (Ts/T = ``ratio``) that start at t = 0 and reach it at the
    interception time."""
    q_start = np.asarray(q_start, float)
    T_land = ball.landing_time(floor)
    t = np.linspace(0.0, T_land, samples)
    mask = arm.reachable(ball.position(t)) & (ball.position(t)[1] >= floor)
    windows = _crossings(mask, t, arm, ball)
    if not windows:
        raise CatchError("the ball never enters the reachable region of the arm")
    if time is not None:
        tc = float(time)
        window = next(((a, b) for a, b in windows if a - 1e-9 <= tc <= b + 1e-9), None)
        if window is None:
            raise CatchError(f"at t = {tc:g} s the ball is not in the reachable region")
    elif method == "middle":
        t0, t1 = windows[0]
        tc = 0.5 * (t0 + t1)
        window = windows[0]
    elif method == "closest":
        hand = arm.forward(q_start)
        best = None
        for (t0, t1) in windows:
            tt = np.linspace(t0, t1, 2001)
            d = np.linalg.norm(ball.position(tt) - hand[:, None], axis=0)
            k = int(np.argmin(d))
            if best is None or d[k] < best[0]:
                best = (d[k], tt[k], (t0, t1))
        _, tc, window = best
    else:
        raise CatchError(f"unknown interception method '{method}' (middle or closest)")
    point = ball.position(tc)
    family = arm.ik_family(point)
    if not family:
        raise CatchError(f"no joint solution within the limits for the point {np.round(point, 4).tolist()}")
    q_catch, phi = _closest_solution(arm, point, family, q_start, norm)
    laws = synchronized_trapezoids(q_catch - q_start, tc, ratio)
    return CatchPlan(float(tc), point, window, q_start, q_catch, phi, laws, ratio, family)


def _closest_solution(arm: CatchingArm, point, family, q_start, norm: str = "l1"):
    """Member of the IK family with the least joint displacement (l1 or linf norm), refined in phi."""
    from scipy.optimize import minimize_scalar
    if norm not in ("l1", "linf"):
        raise CatchError(f"unknown norm '{norm}' (l1 or linf)")
    measure = (lambda D: np.abs(D).sum(axis=0)) if norm == "l1" else (lambda D: np.abs(D).max(axis=0))
    best = None
    for branch in family:
        d = measure(branch[1:] - q_start[:, None])
        k = int(np.argmin(d))
        if best is None or d[k] < best[0]:
            best = (d[k], branch, k)
    _, branch, k = best
    elbow = 1 if branch[2, k] >= 0 else -1
    lo, hi = branch[0, max(k - 1, 0)], branch[0, min(k + 1, branch.shape[1] - 1)]

    def cost(phi):
        q = arm.ik(point, phi, elbow)
        return np.inf if q is None or not arm.within_limits(q) else float(measure((q - q_start)[:, None])[0])
    res = minimize_scalar(cost, bounds=(lo, hi), method="bounded", options={"xatol": 1e-12})
    phi = float(res.x) if np.isfinite(res.fun) and res.fun <= best[0] else float(branch[0, k])
    return arm.ik(point, phi, elbow), phi


# ====================================================================== the catch in full dynamics
#: computed-torque gains of the catcher: e'' + Kd e' + Kp e = 0 with a double pole at -40 rad/s
CATCH_KP = 1600.0
CATCH_KD = 80.0
CATCH_RATE = 1000.0


class PlanReference(Reference):
    """The catch plan's joint motion as a reference of the closed-loop simulation: q_d, q_d', q_d''
    of the synchronized trapezoids."""
    kind = "catch_plan"

    def __init__(self, plan: CatchPlan):
        super().__init__(len(plan.laws))
        self.plan = plan
        self.motion_time = plan.time

    def sample(self, t):
        t = np.atleast_1d(np.asarray(t, float))
        rows = [law(t) for law in self.plan.laws]
        q = np.stack([q0 + r[0] for q0, r in zip(self.plan.q_start, rows)], axis=1)
        return q, np.stack([r[1] for r in rows], axis=1), np.stack([r[2] for r in rows], axis=1)

    def describe(self) -> str:
        return (f"catch plan: trapezoids (Ts/T = {self.plan.ratio:.4g}) from "
                + ",".join(f"{v:.6g}" for v in self.plan.q_start) + " to "
                + ",".join(f"{v:.6g}" for v in self.plan.q_catch) + f" in {self.plan.time:.6g} s")


@dataclass
class CatchRun:
    """The catching arm moved in full dynamics along a catch plan (times from the start of the motion)."""
    t: np.ndarray                      # (k,) control instants, the last one the catch time
    q: np.ndarray                      # (k, 3)
    dq: np.ndarray                     # (k, 3)
    tau: np.ndarray                    # (k, 3) applied torques (after saturation), held over each period
    q_end: np.ndarray                  # joints at the catch time
    hand: np.ndarray                   # hand at the catch time (arm base frame)
    tracking_error: float              # max |q_d - q| over the motion and the joints [rad]
    hand_tracking_error: float         # max |p(q_d) - p(q)| over the motion [m]
    max_torque: np.ndarray             # (3,) max |tau_i| [N m]
    torque_limits: Optional[np.ndarray]    # (3,) from the robot file (None: it has none)
    saturated: bool                    # a torque reached its limit
    energy_error: float                # |E(end) - E(start) - sum tau_k . (q_k+1 - q_k)| [J] (the integrator's error)
    work: float                        # sum tau_k . (q_k+1 - q_k) [J]
    position_violation: bool           # a joint left its position range by more than 1e-6 rad
    message: str                       # why the simulation stopped early ('' when it reached the catch time)


def simulate_catch(arm: CatchingArm, plan: CatchPlan, rate: float = CATCH_RATE, kp: float = CATCH_KP,
                   kd: float = CATCH_KD, plant_params: Optional[Dict[str, float]] = None,
                   torque_limits=None) -> CatchRun:
    """Move the catching arm along ``plan`` in full dynamics: the robot file's model (derived by the
    engine, evaluated by ``NumericModel``) integrated with RK4, under computed torque
    tau = M(q)(q_d'' + Kd e' + Kp e) + C(q, q') q' + g(q) at ``rate`` Hz (zero-order hold; the rate
    raised to the next whole number of periods in the motion, so that the run ends at the catch time), torques clipped to the robot
    file's torque limits (or ``torque_limits``) when there are any. The controller's model has the
    arm's parameters, the simulated arm ``plant_params`` on top of them (model mismatch)."""
    from .sim import simulate
    from .numeric import NumericModel
    if not rate > 0 or not math.isfinite(rate):
        raise UserError(f"the catcher's control rate must be a positive number of Hz, got {rate}")
    robot = arm.robot
    T = float(plan.time)
    steps = max(1, int(math.ceil(T * rate - 1e-9)))
    if torque_limits is None:
        lims = [robot.limits[c].torque if c in robot.limits and robot.limits[c].torque else None
                for c in robot.coordinates]
        torque_limits = None if all(v is None for v in lims) else [math.inf if v is None else v for v in lims]
    bounds = None if torque_limits is None else np.broadcast_to(np.asarray(torque_limits, float), (robot.n,)).copy()
    sat = None if bounds is None else np.where(np.isfinite(bounds), bounds, 1e12)
    plant = {**arm.values, **(plant_params or {})}
    run = simulate(robot, "computed_torque", PlanReference(plan), duration=T, rate=steps / T,
                   q0=plan.q_start, dq0=np.zeros(robot.n), gains={"Kp": kp, "Kd": kd},
                   model_params=arm.values, plant_params=plant, saturation=sat, stop_at_limits=False)
    q, dq, tau = run.q, run.dq, run.tau
    err = run.ref - q
    hand_d = arm.forward(run.ref.T)
    hand = arm.forward(q.T)
    num = NumericModel(robot, plant)
    work = float(np.sum(tau[:-1] * np.diff(q, axis=0)))
    e0, e1 = sum(num.energy(q[0], dq[0])), sum(num.energy(q[-1], dq[-1]))
    outside = np.any((q < arm.lower - 1e-6) | (q > arm.upper + 1e-6))
    max_tau = np.abs(tau).max(axis=0)
    return CatchRun(t=run.t, q=q, dq=dq, tau=tau, q_end=q[-1].copy(), hand=hand[:, -1].copy(),
                    tracking_error=float(np.abs(err).max()),
                    hand_tracking_error=float(np.linalg.norm(hand - hand_d, axis=0).max()),
                    max_torque=max_tau, torque_limits=bounds,
                    saturated=bool(bounds is not None and np.any(max_tau >= bounds * (1 - 1e-12))),
                    energy_error=float(abs(e1 - e0 - work)), work=work, position_violation=bool(outside),
                    message=run.message)


# ====================================================================== the scene
def catch_scene(release_position, release_velocity, g: float = 9.81, base_x: Optional[float] = None,
                q_start=None, method: str = "middle", frames: int = 120, arm: Optional[CatchingArm] = None) -> dict:
    """A thrown ball (release state in the world frame, y from the ground, e.g. the throwing arm's
    ``Release.position``/``velocity``) caught by the catching arm standing at ``base_x`` on the
    ground (default: 0.5 m beyond the landing point). Returns plain data for the viewer: the ball
    path, the catch point and time (world frame, time from the release), the release state, the
    arm base, joint angles over time and the arm's reachable-region boundary (world frame)."""
    arm = arm or CatchingArm()
    world = BallFlight.from_release(release_position, release_velocity, g)
    land = world.landing_time()
    if base_x is None:
        base_x = float(world.position(land)[0]) + 0.5
    ball = BallFlight.from_release(release_position, release_velocity, g, origin=(base_x, 0.0))
    q0 = np.radians([30.0, 120.0, 80.0]) if q_start is None else np.asarray(q_start, float)
    plan = plan_catch(arm, ball, q0, method)
    t = np.linspace(0.0, plan.time, frames)
    q = plan.joint_motion(t)
    region = [line + np.array([base_x, 0.0]) for line in arm.reachable_region(resolution=0.04, samples=121)]
    path_t = np.linspace(0.0, plan.time, frames)
    return {
        "base": [base_x, 0.0],
        "release": list(np.asarray(release_position, float)),
        "velocity": list(np.asarray(release_velocity, float)),
        "g": float(abs(g)),
        "ball_path": world.position(np.linspace(0.0, land, 200)).T.tolist(),
        "ball_until_catch": world.position(path_t).T.tolist(),
        "catch_time": plan.time,
        "catch_point": (plan.point + np.array([base_x, 0.0])).tolist(),
        "window": list(plan.window),
        "times": t.tolist(),
        "q": q.T.tolist(),
        "q_catch": plan.q_catch.tolist(),
        "joint_speed_max": plan.joint_speed_max.tolist(),
        "joint_acceleration_max": plan.joint_acceleration_max.tolist(),
        "reachable_region": [line.tolist() for line in region],
    }


def catch_thesis_throw(name: str = "throw1", **kwargs) -> dict:
    """The throwing arm's throw ``name`` (app/throws, solved by app.core.throw) caught by the
    catching arm: ``catch_scene`` of its release."""
    from .throw.arm import ThrowingArm
    from .throw.config import load_throw_config
    cfg = load_throw_config(name)
    arm = ThrowingArm(params=cfg.model) if getattr(cfg, "model", None) else ThrowingArm()
    throw = arm.solve(cfg.spec)
    rel = throw.release
    scene = catch_scene(rel.position, rel.velocity, rel.g, **kwargs)
    scene["throw"] = name
    scene["release_time"] = throw.duration
    return scene
