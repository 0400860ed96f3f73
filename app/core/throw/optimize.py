"""The throw optimizer (eqs. 4.5, 4.6): the farthest throw under every limit, over Bezier control
points, theta_b, theta_e, psi and k, and the bound that the joint speed limits alone allow
(tests/test_throwing.py).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Dict, List, Optional, Tuple

import numpy as np
from numpy.polynomial import chebyshev as npcheb

from ..ballistics import landing_distance
from ..errors import UserError
from .arm import ThrowingArm
from .bezier import ChebPieces, bernstein, cheb_tables
from .config import Q1_MIN_EQ_4_5, Progress, SpecBatch, ThrowSpec, VHCError, thesis_throw
from .reduced import Feasibility, Throw, integrate


@dataclass
class SpeedBound:
    """The farthest throw that the joint speed limits alone allow (no dynamics, no torques)."""
    convention: str             # "physical" (ball velocity J q') or "thesis" (speed theta_dot along psi)
    distance_from_base: float
    q: np.ndarray
    dq: np.ndarray
    psi: Optional[float]        # thesis convention: the rotation of the theta axis [rad]
    position: np.ndarray
    velocity: np.ndarray


def landing(arm: ThrowingArm, pos, vel):
    """Landing distance from the base of balls released at ``pos`` (y clipped at the ground) with ``vel``."""
    return landing_distance(pos[0], np.maximum(pos[1], 0.0), vel[0], vel[1], arm.g)


def speed_limit_bound(arm: ThrowingArm, convention: str = "physical", starts: int = 10,
                      seed: int = 0, progress: Progress = None) -> SpeedBound:
    """Maximize the landing distance from the base over every configuration in the joint ranges
    (q1 >= pi/6 as in eq. 4.5) and every joint velocity within the speed limits of Table A.2.

    No throw can land farther (in the same convention): its release state is one of these. In the
    thesis convention the speed is theta_dot = (J q') . (cos psi, sin psi), launched along psi.
    ``progress(fraction, message)`` is called before each local polish (and may stop the work by raising).
    """
    from scipy.optimize import minimize

    if convention not in ("physical", "thesis"):
        raise UserError(f"convention must be 'physical' or 'thesis', got {convention!r}")
    lim = arm.limits
    vmax = lim["speed"]
    qlo = np.maximum(lim["lower"], [Q1_MIN_EQ_4_5, -np.inf, -np.inf])
    bounds = list(zip(qlo, lim["upper"])) + [(-v, v) for v in vmax]
    if convention == "thesis":
        bounds.append((-math.pi / 2, math.pi / 2))

    def state(z):
        q, dq = z[:3], z[3:6]
        pos, vel = arm.ball_position(q), arm.ball_velocity(q, dq)
        if convention == "thesis":
        # only the component along psi counts, launched along psi
            e = np.array([math.cos(z[6]), math.sin(z[6])])
            vel = (vel @ e) * e
        return q, dq, pos, vel

    def neg(z):
        _q, _dq, pos, vel = state(z)
        return -float(landing(arm, pos, vel))

    rng = np.random.default_rng(seed)
    lo = np.array([b[0] for b in bounds])
    hi = np.array([b[1] for b in bounds])
    Z = lo + (hi - lo) * rng.random((20000, lo.size))      # screen many states at once, polish the best
    q, dq = Z[:, :3].T, Z[:, 3:6].T
    pos, vel = arm.ball_position(q), arm.ball_velocity(q, dq)
    if convention == "thesis":
        e = np.stack([np.cos(Z[:, 6]), np.sin(Z[:, 6])])
        vel = np.sum(vel * e, axis=0) * e
    order = np.argsort(-landing(arm, pos, vel))
    best = None
    for k, j in enumerate(order[:starts]):
        if progress:
            progress(k / starts, f"speed-limit bound: polish {k + 1}/{starts}")
        r = minimize(neg, Z[j], bounds=bounds, method="L-BFGS-B")
        if best is None or r.fun < best.fun:
            best = r
    q, dq, pos, vel = state(best.x)
    return SpeedBound(convention, -float(best.fun), q, dq, float(best.x[6]) if convention == "thesis" else None,
                      pos, vel)


# ====================================================================== optimization
@dataclass
class OptimizationResult:
    """The best throw found, re-solved with the adaptive quadrature and checked on a dense grid."""
    spec: ThrowSpec
    throw: Throw
    feasibility: Feasibility
    objective: str                # "thesis" (speed theta_dot along psi) or "physical" (J q')
    distance_from_base: float     # in the objective's convention [m]
    bound: SpeedBound             # what the speed limits alone allow, same convention
    evaluations: int              # throw-model evaluations (one per throw and finite-difference point)
    local_runs: int
    elapsed: float                # [s]
    history: List[Tuple[float, float]] = field(default_factory=list)   # (seconds, best feasible distance)
    evaluation_budget: int = 0    # the budget the run was given
    time_capped: bool = False     # the optional time cap ended the search (the result then depends on the machine)
    evaluation_history: List[Tuple[int, float]] = field(default_factory=list)   # (evaluations, best distance)


class _Timeout(Exception):
    pass


#: default evaluation budget of the optimizer (seed 0, thesis convention: its best throw, 2.9656 m, is
#: found after about 10 000 evaluations; see docs/throwing.md)
DEFAULT_EVALUATIONS = 12000


def _smooth_min(values: np.ndarray) -> np.ndarray:
    """Minimum over the last axis of samples on a uniform grid, refined by a parabola through the
    smallest sample and its neighbours (so that it moves smoothly with the function).

    >>> bool(abs(_smooth_min(np.array([(np.linspace(-1, 1, 9) - 0.1) ** 2]))[0]) < 1e-12)
    True
    """
    j = np.clip(np.argmin(values, axis=-1), 1, values.shape[-1] - 2)[..., None]
    f0, f1, f2 = (np.take_along_axis(values, j + d, axis=-1)[..., 0] for d in (-1, 0, 1))
    curv = f0 - 2.0 * f1 + f2
    with np.errstate(divide="ignore", invalid="ignore"):
        vertex = f1 - (f2 - f0) ** 2 / (8.0 * curv)
    inside = (curv > 0) & (np.abs(f2 - f0) < 2.0 * curv)
    return np.minimum(np.min(values, axis=-1), np.where(inside, vertex, np.inf))


class ThrowOptimizer:
    """Maximize the distance from the base over Bezier control points, theta_b, theta_e, psi and k
    (eq. 4.6) under every constraint of eq. (4.5): q1 in [pi/6, 7pi/6], |q2|, |q3| <= 2pi/3, the
    constraint reachable, joint speeds and torques within Table A.2, start from rest.

    Constraints are imposed at the nodes of a fixed Chebyshev mesh (value and finite-difference
    gradient are one vectorized call), with a small safety ``margin`` on speeds and torques; the
    result is re-solved adaptively and checked on a dense grid (the margin tightens if something
    slipped between nodes). Global stage: the speed-limit bound gives the ideal release pose;
    thousands of random joint-space swings ending near it (and the thesis's throws) are turned into
    Bezier VHCs and scored in batches; SLSQP runs from the best distinct ones until the budget ends.

    The wrist spring k ranges over [0, 2000] N m/rad, the stiffness range the thesis gives for the
    robot's joint impedance (section 2.2).
    """
    _progress: Progress = None      # during ``run``: reports by the clock from ``evaluate``
    _reported = 0.0

    def __init__(self, arm: ThrowingArm, degree: int = 6, objective: str = "thesis", pieces: int = 6,
                 nodes: int = 12, margin: float = 0.999, reach: float = 0.995, min_alpha: float = 0.02,
                 k_max: float = 2000.0):
        if objective not in ("thesis", "physical"):
            raise UserError(f"objective must be 'thesis' or 'physical', got {objective!r}")
        if not 2 <= degree <= 12:
            raise UserError(f"Bezier degree must be between 2 and 12, got {degree}")
        self.arm = arm
        self.degree = degree
        self.objective = objective
        self.mesh = ChebPieces(np.linspace(0.0, 1.0, pieces + 1), nodes)
        self.margin = self._margin = margin
        self.reach = reach
        self.min_alpha = min_alpha
        n = degree + 1
        reach_len = arm.l1 + arm.l2 + arm.l3
        lim = arm.limits
        self.lower = np.concatenate([np.full(n, max(lim["lower"][0], Q1_MIN_EQ_4_5)), np.full(n, lim["lower"][1]),
                                     [-reach_len, -reach_len, -math.pi / 6, 0.0]])
        self.upper = np.concatenate([np.full(n, lim["upper"][0]), np.full(n, lim["upper"][1]),
                                     [reach_len, reach_len, math.pi / 2, k_max]])
        self.scale = np.concatenate([np.ones(2 * n), [1.0, 1.0, 1.0, 100.0]])
        x_nodes, vinv, _ = cheb_tables(nodes)
        x_fine = np.linspace(-1.0, 1.0, 4 * nodes)
        self._fine = npcheb.chebvander(x_fine, nodes - 1) @ vinv      # node values -> fine-grid values
        self.evaluations = 0
        self._best: Tuple[float, Optional[np.ndarray]] = (-np.inf, None)
        self._deadline = np.inf
        self._max_evaluations = np.inf
        self._t0 = time.monotonic()
        self.history: List[Tuple[float, float]] = []     # (seconds into the run, best feasible distance)
        self.evaluation_history: List[Tuple[int, float]] = []

    # ------------------------------------------------------------------ vectors
    def to_vector(self, spec: ThrowSpec) -> np.ndarray:
        spec = spec.elevated(self.degree)
        return np.concatenate([spec.a, spec.b, [spec.theta_b, spec.theta_e, spec.psi, spec.k]])

    def to_spec(self, x: np.ndarray) -> ThrowSpec:
        n = self.degree + 1
        return ThrowSpec(float(x[2 * n]), float(x[2 * n + 1]), float(x[2 * n + 2]), float(x[2 * n + 3]),
                         tuple(x[:n]), tuple(x[n:2 * n]))

    # ------------------------------------------------------------------ evaluation
    def evaluate(self, X: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
        """Distances (B,) and constraint values (B, C) (feasible when all >= 0) for throws X (B, D)."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        n = self.degree + 1
        B = X.shape[0]
        self.evaluations += B
        self._report_by_clock(self.evaluations / self._max_evaluations, f"{self.evaluations} evaluations")
        thb = X[:, 2 * n:2 * n + 1]
        the = np.maximum(X[:, 2 * n + 1:2 * n + 2], thb + 1e-3)
        batch = SpecBatch(X[:, :n], X[:, n:2 * n], thb, the, X[:, 2 * n + 2:2 * n + 3], X[:, 2 * n + 3:2 * n + 4],
                       np.zeros((B, 1)), np.ones((B, 1)))
        arm, lim, m = self.arm, self.arm.limits, self.margin
        shape = (B,) + self.mesh.nodes.shape
        with np.errstate(all="ignore"):
            sol = integrate(arm, batch, self.mesh, with_time=False, strict=False, clip=0.99999)
            st = sol.state
            Y = sol.Y
            Yc = np.maximum(Y, 0.0)
            dq = st.dq.reshape((3,) + shape)
            a3 = st.alpha[2].reshape(shape)
            thdd = -(st.beta[2].reshape(shape) * Yc + st.gamma[2].reshape(shape)) / a3
            tau = (st.alpha[:2].reshape((2,) + shape) * thdd + st.beta[:2].reshape((2,) + shape) * Yc
                   + st.gamma[:2].reshape((2,) + shape))
            funcs = [1.0 - (st.u.reshape(shape) / self.reach) ** 2,
                     1.0 - (st.q[2].reshape(shape) / lim["upper"][2]) ** 2]
            funcs += [1.0 - dq[i] ** 2 * Yc / (m * lim["speed"][i]) ** 2 for i in range(3)]
            funcs += [1.0 - tau[i] ** 2 / (m * lim["torque"][i]) ** 2 for i in range(2)]
            # keeps moving forward: Y / sigma^2 > 0 (at sigma = 0 its limit Y'(theta_b) (theta_e - theta_b))
            Z = Y / self.mesh.nodes ** 2
            Z[:, 0, 0] = (-2.0 * st.gamma[2].reshape(shape) / a3)[:, 0, 0] * (the - thb)[:, 0]
            funcs.append(Z - 1e-3)
            funcs.append(np.sign(a3[:, :1, :1]) * a3 - self.min_alpha)  # alpha keeps its sign
            # the smallest value of each constraint per piece, from its interpolant on a fine grid
            cons = [_smooth_min(np.einsum("fp,bkp->bkf", self._fine, f)) for f in funcs]
            cons.append(X[:, 2 * n + 1:2 * n + 2] - thb - 0.05)     # theta_e - theta_b >= 5 cm
            C = np.concatenate(cons, axis=1)
            thd_e = np.sqrt(Yc[:, -1, -1])
            qe = st.q[:, :, -1]
            pos = arm.ball_position(qe)
            if self.objective == "thesis":
                psi = batch.psi[:, 0]
                vel = np.stack([thd_e * np.cos(psi), thd_e * np.sin(psi)])
            else:
                vel = arm.ball_velocity(qe, st.dq[:, :, -1] * thd_e)
            dist = landing(arm, pos, vel)
        bad = ~np.isfinite(dist) | ~np.all(np.isfinite(C), axis=1)
        dist = np.where(bad, -10.0, dist)
        C = np.where(bad[:, None], -1.0, C)
        ok = np.all(C >= -1e-7, axis=1)
        if ok.any():
            j = int(np.argmax(np.where(ok, dist, -np.inf)))
            if dist[j] > self._best[0]:
                self._best = (float(dist[j]), X[j].copy())
                self.history.append((time.monotonic() - self._t0, float(dist[j])))
                self.evaluation_history.append((self.evaluations, float(dist[j])))
        return dist, C

    def _local(self, x0: np.ndarray, maxiter: int = 150) -> None:
        """SLSQP from x0 with forward-difference gradients computed in one batched evaluation."""
        from scipy.optimize import minimize

        h = 1e-7
        cache: Dict[bytes, tuple] = {}

        def full(z):
            key = z.tobytes()
            if key not in cache:
                if self._out_of_budget(z.size + 1):
                    raise _Timeout
                x = z * self.scale
                dist, C = self.evaluate(np.vstack([x, x + np.diag(h * self.scale)]))
                cache.clear()
                cache[key] = (-dist[0], -(dist[1:] - dist[0]) / h, C[0], ((C[1:] - C[0]) / h).T)
            return cache[key]

        bounds = list(zip(self.lower / self.scale, self.upper / self.scale))
        z0 = np.clip(x0, self.lower, self.upper) / self.scale
        try:
            minimize(lambda z: full(z)[0], z0, jac=lambda z: full(z)[1], method="SLSQP", bounds=bounds,
                     constraints=[{"type": "ineq", "fun": lambda z: full(z)[2], "jac": lambda z: full(z)[3]}],
                     options={"maxiter": maxiter, "ftol": 1e-10})
        except _Timeout:
            pass

    def _report_by_clock(self, fraction: float, message: str) -> None:
        """During ``run``: report progress at most every 0.2 s (by the clock: the search itself
        never depends on it; the report may stop the run by raising)."""
        if self._progress is not None and time.monotonic() - self._reported > 0.2:
            self._reported = time.monotonic()
            self._progress(fraction, message)

    def _out_of_budget(self, next_batch: int = 0) -> bool:
        """The evaluation budget would be exceeded by the next batch, or the optional time cap passed."""
        if time.monotonic() > self._deadline:
            self._time_capped = True
            return True
        return self.evaluations + next_batch > self._max_evaluations

    def candidates(self, rng: np.random.Generator, count: int, release_pose: np.ndarray) -> np.ndarray:
        """Random joint-space swings from rest to near ``release_pose``, written as Bezier VHCs, and the
        thesis's throws one and two (the global stage's pool)."""
        n = self.degree + 1
        s = np.linspace(0.0, 1.0, 60)
        lim = self.arm.limits
        out = [self.to_vector(thesis_throw(name)) for name in ("throw1", "throw2")]
        tries = 0
        while len(out) < count and tries < 20 * count:
            tries += 1
            self._report_by_clock(0.0, f"global stage: {len(out)} of {count} swings drawn")
            q_end = release_pose + rng.normal(0.0, [0.15, 0.15, 0.2])
            q_start = np.array([rng.uniform(q_end[0] + 0.2, lim["upper"][0] - 0.5), rng.uniform(-0.3, 1.2),
                                rng.uniform(-0.5, 1.2)])
            w = s ** rng.uniform(0.7, 1.5)
            bump = rng.normal(0.0, 0.2, 3)[:, None] * np.sin(np.pi * s)[None, :]
            Q = q_start[:, None] * (1 - w) + q_end[:, None] * w + bump
            psi = math.radians(rng.uniform(5.0, 30.0))
            theta = self.arm.theta_of_q(Q, psi)
            if np.any(np.diff(theta) <= 0):
                continue
            basis = bernstein(n - 1, (theta - theta[0]) / (theta[-1] - theta[0]))
            a = np.linalg.lstsq(basis, Q[0], rcond=None)[0]
            b = np.linalg.lstsq(basis, Q[1], rcond=None)[0]
            k = math.exp(rng.uniform(math.log(5.0), math.log(self.upper[-1])))
            out.append(np.clip(np.concatenate([a, b, [theta[0], theta[-1], psi, k]]), self.lower, self.upper))
        return np.array(out)

    def run(self, seed: int = 0, evaluations: int = DEFAULT_EVALUATIONS, max_seconds: Optional[float] = None,
            candidates: int = 4000, starts: int = 16, stop_within: float = 0.002,
            progress: Progress = None, bound: Optional[SpeedBound] = None) -> OptimizationResult:
        """Global stage, then SLSQP from the best distinct candidates until ``evaluations`` throw
        evaluations are spent or the best throw is within ``stop_within`` (relative) of the speed-limit
        bound, which no throw can beat. The budget is counted in evaluations, so the same seed gives the
        same throw on any machine; ``max_seconds`` is an optional extra cap (``time_capped`` says when
        it ended the search, and the result then depends on the machine's speed). ``bound``: a speed-limit
        bound computed before (same objective and seed), to save its computation."""
        if not evaluations > 0:
            raise UserError(f"the evaluation budget must be positive (got {evaluations})")
        if max_seconds is not None and not max_seconds > 0:
            raise UserError(f"the time cap must be positive seconds (got {max_seconds})")
        t0 = self._t0 = time.monotonic()
        self._deadline = t0 + max_seconds if max_seconds is not None else np.inf
        self._max_evaluations = evaluations
        self._time_capped = False
        self.evaluations = 0
        self.history = []
        self.evaluation_history = []
        self.margin = self._margin
        self._best = (-np.inf, None)
        rng = np.random.default_rng(seed)

        def report(frac, msg):
            if progress:
                progress(min(frac, 0.99), msg)

        report(0.0, "speed-limit bound")
        if bound is None or bound.convention != self.objective:
            bound = speed_limit_bound(self.arm, self.objective, seed=seed,
                                      progress=lambda f, m: report(0.02 * f, m))
        self._reported = time.monotonic()
        self._progress = report if progress else None
        try:
            pool = self.candidates(rng, candidates, bound.q)
            pool = pool[:max(1, min(len(pool), evaluations))]        # the global stage fits in the budget too
            scores = np.full(len(pool), -np.inf)
            for i in range(0, len(pool), 250):
                if i and self._out_of_budget(0):
                    break
                dist, C = self.evaluate(pool[i:i + 250])
                scores[i:i + 250] = dist + 20.0 * np.sum(np.minimum(C, 0.0), axis=1)
            report(self.evaluations / evaluations, f"global stage: {int(np.isfinite(scores).sum())} candidates scored")
            chosen: List[np.ndarray] = []
            span = self.upper - self.lower
            for j in np.argsort(-scores):
                if not np.isfinite(scores[j]):
                    break
                if all(np.max(np.abs(pool[j] - c) / span) > 0.02 for c in chosen):
                    chosen.append(pool[j])
                if len(chosen) >= starts:
                    break
            runs = 0
            for x0 in chosen:
                if self._out_of_budget(len(x0) + 1) or self._best[0] >= (1.0 - stop_within) * bound.distance_from_base:
                    break
                self._local(x0)
                runs += 1
                best = f"best {self._best[0]:.4f} m" if self._best[1] is not None else "no feasible throw yet"
                report(self.evaluations / evaluations, f"local run {runs}/{len(chosen)}, {self.evaluations} evaluations: {best}")
            if self._best[1] is None:
                raise VHCError("the optimizer found no throw that satisfies every constraint; raise the budget")
            for _attempt in range(4):   # dense verification; tighten the margin if something slipped between nodes
                best = self._best[1]
                spec = self.to_spec(best)
                throw = self.arm.solve(spec)
                feas = throw.check(q1_min=Q1_MIN_EQ_4_5)
                if feas.feasible:
                    break
                self.margin *= 0.995
                self._best = (-np.inf, None)
                self._deadline = np.inf      # the repair is bounded by evaluations only
                self._max_evaluations = self.evaluations + max(2000, evaluations // 10)
                self._local(best)
                if self._best[1] is None:
                    self._best = (-np.inf, best)
            rel = throw.release
            d = rel.distance_from_base_thesis if self.objective == "thesis" else rel.distance_from_base
        finally:
            self._progress = None           # a cancelled or failed run leaves no report behind
        if progress:
            progress(1.0, f"best {d:.4f} m from the base")
        return OptimizationResult(spec, throw, feas, self.objective, float(d), bound, self.evaluations, runs,
                                  time.monotonic() - t0, list(self.history), evaluations, self._time_capped,
                                  list(self.evaluation_history))


