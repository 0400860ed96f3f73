"""Minimum time along a given path (time-optimal path parametrization) under joint velocity,
acceleration and torque bounds.

Along a joint path q(s), s in [0, 1], with q' = q_s s' and q'' = q_s s'' + q_ss s'^2, every bound
takes the form  lower <= a(s) s'' + b(s) s'^2 + c(s) <= upper:

- torque:        a = M(q) q_s,  b = M(q) q_ss + C(q, q_s) q_s,  c = g(q) + k(q) (springs);
- acceleration:  a = q_s,       b = q_ss,                       c = 0;
- velocity:      a = 0,         b = q_s^2 (upper bound V^2),     c = 0.

In the phase plane (s, x = s'^2) the bounds allow, at each (s, x), an interval of s'' = x_s / 2;
it is empty above the maximum velocity curve (MVC). The minimum-time motion follows maximum
acceleration or maximum deceleration, or slides along the MVC, switching between these arcs at
switching points. Here the phase plane is computed on a grid by reachability (the method known as
TOPP-RA): the backward pass builds the controllable sets K_k = [x_min, x_max] from which the end
can still be reached (its upper boundary is the maximum-deceleration curve integrated backward from
the goal, clipped by the MVC); the forward pass integrates maximum acceleration from the start,
clipped by K. Within an interval s'' is constant, so times are exact:
dt = 2 ds / (s'_k + s'_{k+1}). A switch that falls inside an interval is located there by extending
the two neighbouring arcs, which makes the result exact when the coefficients are constant
(bang-bang and bang-coast-bang); otherwise the error shrinks with the grid step.

>>> s = np.linspace(0.0, 1.0, 101)
>>> double_integrator = PathConstraints.build(s, a=1.0, b=0.0, c=0.0, lower=-2.0, upper=2.0)
>>> res = time_optimal(double_integrator)
>>> round(res.T, 9), [a.kind for a in res.arcs]          # bang-bang: T = 2 sqrt(1 / 2)
(1.414213562, ['accelerate', 'decelerate'])
>>> limited = PathConstraints.build(s, a=[1.0, 0.0], b=[0.0, 1.0], c=0.0, lower=[-2.0, -np.inf], upper=[2.0, 0.25])
>>> round(time_optimal(limited).T, 9)                     # bang-coast-bang: 1/V + V/A, V = 0.5
2.25
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, List, Optional, Sequence, Tuple

import numpy as np

from .latex import num
from .numeric import numeric_function
from .planning import PlanningError
from .steps import Step


# ====================================================================== paths
@dataclass
class JointPath:
    """A joint path q(s), s in [0, 1], with its first and second derivatives (arrays (k,) -> (k, n))."""
    q: Callable[[np.ndarray], np.ndarray]
    q_s: Callable[[np.ndarray], np.ndarray]
    q_ss: Callable[[np.ndarray], np.ndarray]

    @staticmethod
    def line(start, goal) -> "JointPath":
        """The straight joint-space segment start -> goal.

        >>> JointPath.line([0, 1], [2, 1]).q(np.array([0.5])).round(12).tolist()
        [[1.0, 1.0]]
        """
        q0 = np.asarray(start, float).reshape(-1)
        d = np.asarray(goal, float).reshape(-1) - q0
        return JointPath(lambda s: q0 + np.outer(np.atleast_1d(s), d),
                         lambda s: np.tile(d, (np.size(s), 1)),
                         lambda s: np.zeros((np.size(s), d.size)))

    @staticmethod
    def from_expressions(exprs, s_symbol) -> "JointPath":
        """From sympy expressions of ``s_symbol`` (one per coordinate), differentiated exactly."""
        import sympy as sp
        exprs = [sp.sympify(e) for e in exprs]
        extra = set().union(*(e.free_symbols for e in exprs)) - {s_symbol}
        if extra:
            raise PlanningError(f"the path may only depend on s; unknown names {sorted(str(x) for x in extra)}")
        fns = [numeric_function([s_symbol], sp.Matrix([sp.diff(e, s_symbol, k) for e in exprs]), "numpy") for k in range(3)]

        def column(f):
            return lambda s: np.array([np.asarray(f(float(x)), float).reshape(-1) for x in np.atleast_1d(s)])
        return JointPath(*(column(f) for f in fns))


# ====================================================================== constraints in the phase plane
@dataclass
class PathConstraints:
    """Rows lower <= a s'' + b s'^2 + c <= upper at the grid nodes s (arrays (N+1, m))."""
    s: np.ndarray
    a: np.ndarray
    b: np.ndarray
    c: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    labels: List[str] = field(default_factory=list)
    mid: Optional["PathConstraints"] = None     # the same rows at the interval midpoints

    @staticmethod
    def build(s, a, b, c, lower, upper, labels=None) -> "PathConstraints":
        """Broadcast scalars or per-row values to every node."""
        s = np.asarray(s, float).reshape(-1)
        if s.size < 2 or np.any(np.diff(s) <= 0):
            raise PlanningError("the grid of s must have at least two increasing values")
        arrs = [np.asarray(v, float) for v in (a, b, c, lower, upper)]
        m = max(x.shape[-1] if x.ndim else 1 for x in arrs)
        arrs = [np.broadcast_to(x if x.ndim == 2 else x.reshape(1, -1) if x.ndim else x.reshape(1, 1), (s.size, m)).copy()
                for x in arrs]
        return PathConstraints(s, *arrs, labels=list(labels or [f"row {i + 1}" for i in range(m)]))

    def stack(self, other: "PathConstraints") -> "PathConstraints":
        mid = self.mid.stack(other.mid) if self.mid is not None and other.mid is not None else None
        return PathConstraints(self.s, *(np.hstack([getattr(self, k), getattr(other, k)]) for k in ("a", "b", "c", "lower", "upper")),
                               labels=self.labels + other.labels, mid=mid)

    def rows(self, k: int):
        """(alpha, beta, lo, hi) of node k: lo <= alpha s'' + beta x <= hi."""
        return self.a[k], self.b[k], self.lower[k] - self.c[k], self.upper[k] - self.c[k]

    def interval_rows(self, k: int):
        """Rows on (s'' on interval k, x_k). With midpoint rows, x = x_k + ds s'' at the midpoint
        (second order); rows without s'' (velocity limits) also hold at the node itself. Returns
        the rows and a mask of those that bound s'' through the dynamics (not velocity limits)."""
        na, nb, nl, nh = self.rows(k)
        flat = np.abs(na) <= _TINY * np.maximum(1.0, np.abs(nb))
        if self.mid is None:
            return (na, nb, nl, nh), ~flat
        al, be, lo, hi = self.mid.rows(k)
        ds = self.s[k + 1] - self.s[k]
        dynamic = np.abs(al) > _TINY * np.maximum(1.0, np.abs(be))
        rows = (np.concatenate([al + ds * be, na[flat]]), np.concatenate([be, nb[flat]]),
                np.concatenate([lo, nl[flat]]), np.concatenate([hi, nh[flat]]))
        return rows, np.concatenate([dynamic, np.zeros(int(flat.sum()), bool)])


def path_constraints(path: JointPath, s, numeric=None, torque=None, velocity=None, acceleration=None,
                     names: Optional[Sequence[str]] = None, midpoints: bool = True) -> PathConstraints:
    """Bounds along ``path`` at the nodes ``s`` (and at the interval midpoints): ``torque`` =
    (lower, upper) arrays (needs a ``NumericModel``), ``velocity`` = V (|q'_i| <= V_i),
    ``acceleration`` = A (|q''_i| <= A_i)."""
    s = np.asarray(s, float).reshape(-1)
    if midpoints:
        out = path_constraints(path, s, numeric, torque, velocity, acceleration, names, False)
        out.mid = path_constraints(path, (s[:-1] + s[1:]) / 2, numeric, torque, velocity, acceleration, names, False)
        return out
    q, qs, qss = path.q(s), path.q_s(s), path.q_ss(s)
    n = q.shape[1]
    names = list(names or [f"q{i + 1}" for i in range(n)])
    parts = []
    if torque is not None:
        if numeric is None:
            raise PlanningError("torque bounds need the robot's dynamic model")
        probe = numeric.friction(np.linspace(0.3, 0.7, n))
        if np.any(np.abs(probe) > 0):
            raise PlanningError("torque bounds with joint friction are not supported (the friction torque is not quadratic in s')")
        lo, hi = (np.asarray(x, float) * np.ones(n) for x in torque)
        a = np.empty((s.size, n))
        b = np.empty((s.size, n))
        c = np.empty((s.size, n))
        for k in range(s.size):
            M = numeric.M(q[k])
            a[k] = M @ qs[k]
            b[k] = M @ qss[k] + numeric.c(q[k], qs[k])
            c[k] = numeric.g(q[k]) + numeric.spring(q[k])
        parts.append(PathConstraints.build(s, a, b, c, lo, hi, [f"torque {x}" for x in names]))
    if acceleration is not None:
        A = np.asarray(acceleration, float) * np.ones(n)
        parts.append(PathConstraints.build(s, qs, qss, 0.0, -A, A, [f"acceleration {x}" for x in names]))
    if velocity is not None:
        V = np.asarray(velocity, float) * np.ones(n)
        parts.append(PathConstraints.build(s, 0.0, qs ** 2, 0.0, -np.inf, V ** 2, [f"velocity {x}" for x in names]))
    if not parts:
        raise PlanningError("give at least one of torque, velocity or acceleration bounds")
    out = parts[0]
    for p in parts[1:]:
        out = out.stack(p)
    return out


# ====================================================================== two-variable linear programs
_TINY = 1e-12


def _x_range(alpha, beta, lo, hi) -> Optional[Tuple[float, float]]:
    """Interval of x >= 0 for which some s'' satisfies every row lo <= alpha s'' + beta x <= hi
    (exact: a row without s'' bounds x directly; two rows bound x through their s''-intervals)."""
    xlo, xhi = 0.0, math.inf
    scale = np.maximum(1.0, np.abs(beta))
    flat = np.abs(alpha) <= _TINY * scale
    for be, l, h in zip(beta[flat], lo[flat], hi[flat]):
        if abs(be) <= _TINY:
            if l > 1e-9 * max(1.0, abs(l)) or h < -1e-9 * max(1.0, abs(h)):
                return None
            continue
        lo_x, hi_x = (l / be, h / be) if be > 0 else (h / be, l / be)
        xlo, xhi = max(xlo, lo_x), min(xhi, hi_x)
    al, be, l, h = alpha[~flat], beta[~flat], lo[~flat], hi[~flat]
    if al.size:
        pos = al > 0
        r = -be / al
        low_p = np.where(pos, l, h) / al            # s'' >= low_p + r x
        up_p = np.where(pos, h, l) / al             # s'' <= up_p + r x
        coef = r[:, None] - r[None, :]
        rhs = up_p[None, :] - low_p[:, None]
        ok = np.isfinite(rhs)
        coef, rhs = coef[ok], rhs[ok]
        tol = 1e-12 * np.maximum(1.0, np.abs(rhs))
        upper = coef > tol
        lower = coef < -tol
        if np.any(rhs[~upper & ~lower] < -1e-9 * np.maximum(1.0, np.abs(rhs[~upper & ~lower]))):
            return None
        if np.any(upper):
            xhi = min(xhi, float(np.min(rhs[upper] / coef[upper])))
        if np.any(lower):
            xlo = max(xlo, float(np.max(rhs[lower] / coef[lower])))
    if xlo > xhi + 1e-9 * max(1.0, abs(xhi)):
        return None
    return xlo, max(xlo, xhi)


def _u_range(alpha, beta, lo, hi, x) -> Tuple[float, float]:
    """Interval of s'' allowed by the rows at x (rows without s'' are ignored)."""
    act = np.abs(alpha) > _TINY * np.maximum(1.0, np.abs(beta))
    al, be, l, h = alpha[act], beta[act], lo[act], hi[act]
    if not al.size:
        return -math.inf, math.inf
    pos = al > 0
    low = (np.where(pos, l, h) - be * x) / al
    up = (np.where(pos, h, l) - be * x) / al
    return float(np.max(low)), float(np.min(up))


# ====================================================================== the time-optimal profile
@dataclass
class Piece:
    """A stretch of constant s'' from s0 to s1 (x = s'^2 from x0 to x1), starting at time t0."""
    s0: float
    s1: float
    x0: float
    x1: float
    u: float
    t0: float
    kind: str

    @property
    def dt(self) -> float:
        return 2 * (self.s1 - self.s0) / (math.sqrt(self.x0) + math.sqrt(self.x1))


@dataclass
class Arc:
    kind: str          # accelerate, decelerate or limit (sliding on a velocity limit / the MVC)
    s0: float
    s1: float
    t0: float
    t1: float


@dataclass
class TimeOptimal:
    T: float
    s: np.ndarray                  # grid nodes
    x: np.ndarray                  # s'^2 at the nodes
    u: np.ndarray                  # s'' on each interval
    t: np.ndarray                  # time at the nodes
    mvc: np.ndarray                # maximum velocity curve (largest admissible s'^2 at each node)
    controllable: np.ndarray       # upper boundary of the controllable sets (backward curve)
    pieces: List[Piece]
    arcs: List[Arc]
    steps: List[Step] = field(default_factory=list)

    @property
    def switch_points(self) -> List[Tuple[float, float]]:
        """(s, t) where the profile changes arc."""
        return [(a.s0, a.t0) for a in self.arcs[1:]]

    def sample(self, times) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(s, s', s'') at the given times (clamped to [0, T])."""
        times = np.clip(np.atleast_1d(np.asarray(times, float)), 0.0, self.T)
        starts = np.array([p.t0 for p in self.pieces])
        idx = np.clip(np.searchsorted(starts, times, side="right") - 1, 0, len(self.pieces) - 1)
        s, sd, sdd = (np.empty(times.size) for _ in range(3))
        for i, (tt, k) in enumerate(zip(times, idx)):
            p = self.pieces[k]
            tau = min(tt - p.t0, p.dt)
            v0 = math.sqrt(p.x0)
            sd[i] = max(v0 + p.u * tau, 0.0)
            s[i] = min(p.s0 + v0 * tau + 0.5 * p.u * tau ** 2, p.s1)
            sdd[i] = p.u
        return s, sd, sdd


def time_optimal(con: PathConstraints, start_speed: float = 0.0, end_speed: float = 0.0,
                 progress: Optional[Callable[[float, str], None]] = None) -> TimeOptimal:
    """Minimum-time parametrization s(t) of the path under the constraint rows (from rest to rest by
    default; ``start_speed``/``end_speed`` are s' at the ends)."""
    progress = progress or (lambda f, m: None)
    s = con.s
    N = s.size - 1
    ds = np.diff(s)
    mvc = np.empty(N + 1)
    for k in range(N + 1):
        rng = _x_range(*con.rows(k))
        if rng is None:
            raise PlanningError(f"the bounds cannot hold at s = {s[k]:.4g}, not even at rest (e.g. gravity exceeds a torque bound)")
        mvc[k] = rng[1]
    # backward pass: controllable sets
    K = np.empty((N + 1, 2))
    xe = end_speed ** 2
    if not mvc[N] >= xe - 1e-9 * max(1.0, xe):
        raise PlanningError("the final speed violates the bounds")
    K[N] = (xe, xe)
    rows, dynamic = zip(*[con.interval_rows(k) for k in range(N)])
    for k in range(N - 1, -1, -1):
        al, be, lo, hi = rows[k]
        rng = _x_range(np.append(al, 2 * ds[k]), np.append(be, 1.0), np.append(lo, K[k + 1, 0]), np.append(hi, K[k + 1, 1]))
        if rng is None:
            raise PlanningError(f"no admissible motion reaches the end of the path from s = {s[k]:.4g}")
        K[k] = rng
        if k % 200 == 0:
            progress(0.5 * (N - k) / N, "backward pass")
    x = np.empty(N + 1)
    x0 = start_speed ** 2
    if not (K[0, 0] - 1e-9 * max(1.0, K[0, 0]) <= x0 <= K[0, 1] + 1e-9 * max(1.0, K[0, 1])):
        raise PlanningError("the path cannot be followed from the initial speed within the bounds")
    x[0] = x0
    u = np.empty(N)
    for k in range(N):
        al, be, lo, hi = rows[k]
        _, up_u = _u_range(np.append(al, 2 * ds[k]), np.append(be, 1.0), np.append(lo, K[k + 1, 0]),
                              np.append(hi, K[k + 1, 1]), x[k])
        nxt = x[k] + 2 * ds[k] * up_u
        x[k + 1] = min(max(nxt, K[k + 1, 0], 0.0), K[k + 1, 1])
        u[k] = (x[k + 1] - x[k]) / (2 * ds[k])
        if k % 200 == 0:
            progress(0.5 + 0.5 * k / N, "forward pass")
    if np.any((x[:-1] <= 0) & (x[1:] <= 0)):
        k = int(np.flatnonzero((x[:-1] <= 0) & (x[1:] <= 0))[0])
        raise PlanningError(f"the bounds force the motion to stop at s = {s[k]:.4g}: the path cannot be traversed")
    labels = []
    for k in range(N):
        on_mvc = x[k] >= mvc[k] * (1 - 1e-7) and x[k + 1] >= mvc[k + 1] * (1 - 1e-7)
        L, U = _u_range(*(r[dynamic[k]] for r in rows[k]), x[k])
        tol = 1e-7 * max(1.0, abs(L), abs(U))
        labels.append("limit" if on_mvc else "accelerate" if abs(u[k] - U) <= tol
                      else "decelerate" if abs(u[k] - L) <= tol else "limit")
    pieces = _pieces(s, x, u, labels)
    t = 0.0
    for p in pieces:
        p.t0 = t
        t += p.dt
    T = float(t)
    if not np.isfinite(T):
        raise PlanningError("the minimum time is not finite: the path cannot be traversed within the bounds")
    t_nodes = np.empty(N + 1)
    t_nodes[0] = 0.0
    node = 1
    for p in pieces:
        if node <= N and abs(p.s1 - s[node]) <= 1e-14 * max(1.0, abs(s[node])):
            t_nodes[node] = p.t0 + p.dt
            node += 1
    arcs: List[Arc] = []
    for p in pieces:
        if arcs and arcs[-1].kind == p.kind:
            arcs[-1].s1, arcs[-1].t1 = float(p.s1), float(p.t0 + p.dt)
        else:
            arcs.append(Arc(p.kind, float(p.s0), float(p.s1), float(p.t0), float(p.t0 + p.dt)))
    res = TimeOptimal(T, s, x, u, t_nodes, mvc, K[:, 1].copy(), pieces, arcs)
    res.steps = _steps(res)
    progress(1.0, "done")
    return res


def _pieces(s, x, u, labels) -> List[Piece]:
    """Constant-s'' pieces; an interval between two different arcs is split where the neighbouring
    arcs, extended into it, meet (the switching point)."""
    N = len(u)
    out: List[Piece] = []
    for k in range(N):
        lab = labels[k]
        if 0 < k < N - 1 and lab == "limit" and (labels[k - 1] != lab or labels[k + 1] != lab):
            u1, u2 = u[k - 1], u[k + 1]
            d = s[k + 1] - s[k]
            if abs(u1 - u2) > 1e-9 * max(1.0, abs(u1), abs(u2)):
                sigma = (x[k + 1] - x[k] - 2 * u2 * d) / (2 * (u1 - u2))
                xm = x[k] + 2 * u1 * sigma
                if 1e-12 * d < sigma < d * (1 - 1e-12) and xm > 0:
                    out.append(Piece(s[k], s[k] + sigma, x[k], xm, u1, 0.0, labels[k - 1]))
                    out.append(Piece(s[k] + sigma, s[k + 1], xm, x[k + 1], u2, 0.0, labels[k + 1]))
                    continue
        out.append(Piece(s[k], s[k + 1], x[k], x[k + 1], u[k], 0.0, lab))
    return out


def _steps(res: TimeOptimal) -> List[Step]:
    stride = max(1, (len(res.s) - 1) // 200)
    plane = {"s": res.s[::stride].tolist(), "sdot": np.sqrt(np.maximum(res.x, 0))[::stride].tolist(),
             "mvc": np.sqrt(np.minimum(res.mvc, 1e12))[::stride].tolist(),
             "backward": np.sqrt(np.maximum(res.controllable, 0))[::stride].tolist(),
             "switches": [s for s, _ in res.switch_points]}
    arcs = "; ".join(f"{a.kind} for s in [{num(a.s0)}, {num(a.s1)}], t in [{num(a.t0)}, {num(a.t1)}]" for a in res.arcs)
    return [
        Step("Path dynamics", r"\tau = M(q)\,q_s\,\ddot s + \left(M(q)\,q_{ss} + C(q, q_s)\,q_s\right)\dot s^2 + g(q),\quad "
             r"\dot q = q_s \dot s,\ \ddot q = q_s \ddot s + q_{ss}\dot s^2",
             r"Along the path every bound is linear in $\ddot s$ and in $x = \dot s^2$: $\mathrm{lower} \le a(s) \ddot s + b(s) x + c(s) \le \mathrm{upper}$."),
        Step("Phase plane", r"x_{MVC}(s) = \max\{x : \exists\,\ddot s\ \text{within every bound}\},\quad "
             r"\dot s^*(s) = \min(\text{forward},\ \text{backward},\ \text{MVC})",
             "Forward: maximum acceleration from the start; backward: maximum deceleration into the goal "
             "(the controllable set); the optimum is the lowest of the curves.", {"phase_plane": plane}),
        Step("Switching structure", r"\text{" + (arcs.replace("_", r"\_") or "none") + "}",
             f"{len(res.arcs)} arc(s), {len(res.arcs) - 1} switching point(s)."),
        Step("Minimum time", rf"T^* = \int_0^1 \frac{{ds}}{{\dot s(s)}} = {num(res.T)}\ \mathrm{{s}}",
             r"Exact for constant $\ddot s$ on each grid interval: $\Delta t = 2 \Delta s / (\dot s_k + \dot s_{k+1})$."),
    ]


def minimum_time_along_path(path: JointPath, numeric=None, torque=None, velocity=None, acceleration=None,
                            nodes: int = 1000, names=None, progress=None) -> Tuple[TimeOptimal, PathConstraints]:
    """Time-optimal rest-to-rest motion along ``path`` (see ``path_constraints`` for the bounds)."""
    if nodes < 10:
        raise PlanningError("use at least 10 grid intervals")
    s = np.linspace(0.0, 1.0, int(nodes) + 1)
    con = path_constraints(path, s, numeric, torque, velocity, acceleration, names)
    return time_optimal(con, progress=progress), con


def joint_motion(res: TimeOptimal, path: JointPath, times):
    """(q, q', q'') at the given times of the time-optimal motion."""
    s, sd, sdd = res.sample(times)
    qs, qss = path.q_s(s), path.q_ss(s)
    return path.q(s), qs * sd[:, None], qs * sdd[:, None] + qss * (sd ** 2)[:, None]


def pendulum_bang_bang_shooting(inertia: float, mgd: float, torque: float, goal: float) -> Tuple[float, float]:
    """Reference for one link under gravity (I theta'' + mgd sin theta = u, |u| <= torque), rest at
    theta = 0 to rest at ``goal``: the bang-bang motion found by shooting on the switch time, with
    a tight ODE integrator. Independent of the phase-plane method; returns (T, switch time) [s].

    >>> T, ts = pendulum_bang_bang_shooting(1.0, 0.0, 1.0, 1.0)   # double integrator: T = 2 sqrt(goal)
    >>> round(T, 6), round(ts, 6)
    (2.0, 1.0)
    """
    from scipy.integrate import solve_ivp
    from scipy.optimize import brentq

    def arrival(ts):
        f = lambda t, y, u: [y[1], (u - mgd * math.sin(y[0])) / inertia]
        y = solve_ivp(f, [0, ts], [0.0, 0.0], args=(torque,), rtol=1e-12, atol=1e-12).y[:, -1]
        stop = lambda t, y, u: y[1]
        stop.terminal, stop.direction = True, -1
        out = solve_ivp(f, [0, 10], y, args=(-torque,), events=stop, rtol=1e-12, atol=1e-12)
        return out.y_events[0][0][0] - goal, ts + out.t_events[0][0]

    ts = brentq(lambda x: arrival(x)[0], 0.05, 3.0, xtol=1e-14)
    return float(arrival(ts)[1]), float(ts)
