"""Redundancy resolution at velocity or acceleration level, each method returning its steps.

Everything works on numeric matrices (numpy): a task Jacobian J (m x n), a task velocity (or
acceleration) v, joint bounds. Pseudoinverses use the SVD with an explicit *absolute* threshold
on the singular values: two exam examples (a projected Jacobian that is exactly zero, a rank
deficient Jacobian) only come out right when round-off singular values (1e-17) are dropped, which a
threshold relative to the largest singular value does not guarantee.

Methods: pseudoinverse (``pinv``), weighted (``weighted_pinv``, via J_W^# = W^(-1/2) (J W^(-1/2))^#),
damped least squares (``damped_pinv``), null-space projection and projected gradient
(``resolve``), reduced gradient (``reduced_gradient``), task priority (``task_priority``, recursive,
with algorithmic singularities), and SNS (``sns``, saturation in the null space with task scaling,
with the minimum-norm variant) at velocity or acceleration level (bounds from ``velocity_bounds``,
``acceleration_bounds``).

>>> J = [[-1, -1, -0.5], [-0.366, -0.866, -0.866]]
>>> out = sns(J, [2, 1], lower=[-1, -1.5, -2], upper=[1, 1.5, 2])
>>> np.round(out.dq, 3).tolist(), out.scale         # exact: the scale is clamped at 1
([-1.0, -1.268, 0.536], 1.0)
"""
from __future__ import annotations

from dataclasses import dataclass, field
from itertools import combinations
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np

from .errors import UserError
from .jacobians import DEFAULT_THRESHOLD
from .latex import mat, num, sig, vec
from .steps import Step

FEASIBILITY_TOLERANCE = 1e-9


class RedundancyError(UserError):
    """Inconsistent data for a redundancy-resolution method (sizes, bounds, weights)."""


def _mat(J) -> np.ndarray:
    J = np.atleast_2d(np.asarray(J, dtype=float))
    if not np.all(np.isfinite(J)):
        raise RedundancyError("the matrix has entries that are not finite numbers")
    return J


def _vec(v, size: int, what: str) -> np.ndarray:
    v = np.asarray(v, dtype=float).reshape(-1)
    if v.size != size:
        raise RedundancyError(f"{what}: expected {size} components, got {v.size}")
    return v


# ====================================================================== pseudoinverses
def pinv(J, threshold: float = DEFAULT_THRESHOLD) -> np.ndarray:
    """Moore-Penrose pseudoinverse through the SVD; singular values <= threshold count as zero.

    >>> pinv([[0, 0, 0, 0], [2, 1.5, 1, 0.5]]).round(4)[:, 1].tolist()
    [0.2667, 0.2, 0.1333, 0.0667]
    """
    J = _mat(J)
    U, s, Vt = np.linalg.svd(J, full_matrices=False)
    inv = np.array([1.0 / x if x > threshold else 0.0 for x in s])
    return (Vt.T * inv) @ U.T


def inverse_sqrt(W: np.ndarray) -> np.ndarray:
    """W^(-1/2) of a symmetric positive definite matrix."""
    w, V = np.linalg.eigh(W)
    if w.min() <= 0:
        raise RedundancyError(f"the weight matrix must be symmetric positive definite (eigenvalues {np.round(w, 6).tolist()})")
    return (V / np.sqrt(w)) @ V.T


def weighted_matrix(W, n: int) -> np.ndarray:
    """A weight given as a list of n diagonal entries or an n x n matrix -> n x n matrix."""
    W = np.asarray(W, dtype=float)
    if W.ndim == 1:
        W = np.diag(W)
    if W.shape != (n, n):
        raise RedundancyError(f"weights: expected {n} diagonal entries or an {n}x{n} matrix, got shape {W.shape}")
    if not np.allclose(W, W.T, atol=1e-12):
        raise RedundancyError("weights: the weight matrix must be symmetric")
    return W


def weighted_pinv(J, W, threshold: float = DEFAULT_THRESHOLD) -> np.ndarray:
    """J_W^# = W^(-1/2) (J W^(-1/2))^#, which equals W^-1 J^T (J W^-1 J^T)^-1 when J has full row
    rank and stays defined when it does not: the minimizer of q'^T W q' among the least-squares
    solutions of J q' = v.

    >>> np.round(weighted_pinv([[1, 1]], [1, 3]), 4).ravel().tolist()
    [0.75, 0.25]
    """
    J = _mat(J)
    W = weighted_matrix(W, J.shape[1])
    Wm = inverse_sqrt(W)
    return Wm @ pinv(J @ Wm, threshold)


def damped_pinv(J, damping: float) -> np.ndarray:
    """Damped least squares J^T (J J^T + mu^2 I)^-1 (minimizes |v - J q'|^2 + mu^2 |q'|^2)."""
    J = _mat(J)
    if damping < 0:
        raise RedundancyError("damping must not be negative")
    return J.T @ np.linalg.inv(J @ J.T + damping ** 2 * np.eye(J.shape[0]))


def null_projector(J, threshold: float = DEFAULT_THRESHOLD) -> np.ndarray:
    """Orthogonal projector I - J^# J onto the null space of J."""
    J = _mat(J)
    return np.eye(J.shape[1]) - pinv(J, threshold) @ J


# ====================================================================== one task
@dataclass
class Resolution:
    """Result of ``resolve``: q' = q'_task + q'_null, with the pieces and the steps."""
    dq: np.ndarray
    dq_task: np.ndarray
    dq_null: np.ndarray
    inverse: np.ndarray
    projector: np.ndarray
    error: np.ndarray
    steps: List[Step] = field(default_factory=list)
    scale: Optional[float] = None            # task scaling applied to respect bounds (None: not needed)
    dq_unscaled: Optional[np.ndarray] = None

    @property
    def norm(self) -> float:
        return float(np.linalg.norm(self.dq))


def resolve(J, v, weights=None, damping: Optional[float] = None, preferred=None,
            threshold: float = DEFAULT_THRESHOLD, fixed: Optional[Dict[int, float]] = None,
            lower=None, upper=None, symbol: str = r"\dot q", task_symbol: str = "v") -> Resolution:
    """q' = J^+ v + (I - J^+ J) q'_0 with J^+ the pseudoinverse (weighted, damped) of J.

    ``preferred`` is q'_0 (e.g. -alpha grad H for a projected gradient); ``fixed`` maps 0-based
    joint indices to imposed values (those columns leave the problem: J_{-i} q'_{-i} = v - J_i q'_i).
    With ``lower``/``upper`` bounds, an infeasible result is fixed by the smallest task scaling
    k in [0, 1] keeping the null-space term: q' = k q'_task + q'_null.

    >>> r = resolve([[3, 1, 2], [1.5, 0.5, 1]], [2, 1])
    >>> np.round(r.dq, 4).tolist(), (np.round(r.error, 4) + 0.0).tolist()     # + 0.0: no -0.0
    ([0.4286, 0.1429, 0.2857], [0.0, 0.0])
    """
    J = _mat(J)
    m, n = J.shape
    v = _vec(v, m, "task vector")
    steps: List[Step] = []
    free = list(range(n))
    dq_fixed = np.zeros(n)
    if fixed:
        for i, value in fixed.items():
            if not 0 <= i < n:
                raise RedundancyError(f"fixed joint {i + 1} does not exist (n = {n})")
            dq_fixed[i] = value
        free = [j for j in range(n) if j not in fixed]
        v_red = v - J @ dq_fixed
        steps.append(Step("Fixed joints", rf"{task_symbol}' = {task_symbol} - \sum_{{i\,\mathrm{{fixed}}}} J_i {symbol}_i = {vec(v_red)}",
                          f"Joints {', '.join(str(i + 1) for i in sorted(fixed))} are imposed; their columns move to the task side.",
                          {"joint_values": [{"label": "fixed", "values": dq_fixed.tolist()}]}))
    else:
        v_red = v
    Jf = J[:, free]
    if weights is not None:
        W = weighted_matrix(weights, n)[np.ix_(free, free)]
        inv = weighted_pinv(Jf, W, threshold)
        steps.append(Step("Weighted pseudoinverse", r"J_W^\# = W^{-1/2}\,(J W^{-1/2})^\# = " + mat(inv),
                          r"Minimizes the weighted norm $\dot q^T W \dot q$ among the solutions (through $W^{-1/2}$)."))
    elif damping:
        inv = damped_pinv(Jf, damping)
        steps.append(Step("Damped least squares", rf"J_{{DLS}} = J^T (J J^T + \mu^2 I)^{{-1}} = " + mat(inv),
                          f"$\\mu = {num(damping)}$: trades task accuracy for bounded joint velocities near singularities."))
    else:
        inv = pinv(Jf, threshold)
        steps.append(Step("Pseudoinverse", r"J^\# = " + mat(inv),
                          f"From the SVD, singular values below ${sig(threshold)}$ (absolute) treated as zero."))
    dq_task = np.zeros(n)
    dq_task[free] = inv @ v_red
    dq_task += dq_fixed
    P = np.eye(len(free)) - inv @ Jf
    projector = np.zeros((n, n))
    projector[np.ix_(free, free)] = P
    dq_null = np.zeros(n)
    if preferred is not None:
        q0 = _vec(preferred, n, "preferred joint velocity")
        dq_null = projector @ q0
        steps.append(Step("Null-space projection", r"P = I - J^\# J = " + mat(projector) + r",\quad P\," + symbol + "_0 = " + vec(dq_null),
                          "The preferred motion is filtered so that it does not disturb the task."))
    dq = dq_task + dq_null
    steps.append(Step("Joint solution", symbol + " = " + vec(dq),
                      f"Norm {num(np.linalg.norm(dq))}.", {"joint_values": [{"label": "solution", "values": dq.tolist()}]}))
    err = v - J @ dq
    steps.append(Step("Task error", rf"e = {task_symbol} - J {symbol} = " + vec(err),
                      "Zero when the task is in the range of $J$; otherwise the least-squares residual."))
    res = Resolution(dq, dq_task, dq_null, inv, projector, err, steps)
    if lower is not None or upper is not None:
        lo = _vec(lower if lower is not None else -np.inf * np.ones(n), n, "lower bounds")
        hi = _vec(upper if upper is not None else np.inf * np.ones(n), n, "upper bounds")
        if np.any(dq < lo - FEASIBILITY_TOLERANCE) or np.any(dq > hi + FEASIBILITY_TOLERANCE):
            k = max_scaling(dq_task, dq_null, lo, hi, 1.0)
            if k is None:
                raise RedundancyError("no task scaling makes the solution feasible (the null-space term alone violates the bounds)")
            res.dq_unscaled = dq
            res.scale = k
            res.dq = k * dq_task + dq_null
            res.error = v - J @ res.dq
            res.steps.append(Step("Task scaling", rf"k^* = {num(k)},\quad {symbol}_s = k^* {symbol}_{{task}} + {symbol}_{{null}} = {vec(res.dq)}",
                                  r"The largest $k \le 1$ that brings every joint inside its bounds; the task is executed scaled.",
                                  {"joint_values": [{"label": "scaled", "values": res.dq.tolist(), "lower": lo.tolist(), "upper": hi.tolist()}],
                                   "scale": k}))
    return res


def max_scaling(a, b, lower, upper, s_max: float = 1.0) -> Optional[float]:
    """Largest s in [0, s_max] with lower <= a s + b <= upper (None when no s >= 0 works).

    >>> round(max_scaling([2.1076], [-0.0437], [-2], [2]), 4)
    0.9697
    """
    a, b = np.asarray(a, float), np.asarray(b, float)
    lo_s, hi_s = 0.0, s_max
    for ai, bi, l, u in zip(a, b, np.asarray(lower, float), np.asarray(upper, float)):
        if abs(ai) < 1e-14:
            if bi < l - FEASIBILITY_TOLERANCE or bi > u + FEASIBILITY_TOLERANCE:
                return None
            continue
        s1, s2 = (l - bi) / ai, (u - bi) / ai
        lo_s, hi_s = max(lo_s, min(s1, s2)), min(hi_s, max(s1, s2))
    if lo_s > hi_s + 1e-12:
        return None
    return float(hi_s)


# ====================================================================== reduced gradient
@dataclass
class ReducedGradient:
    dq: np.ndarray
    minors: Dict[Tuple[int, ...], float]
    chosen: Tuple[int, ...]                 # 1-based indices of the joints in J_a
    gradient_b: np.ndarray
    steps: List[Step]


def reduced_gradient(J, v, gradient, alpha: float = 1.0, maximize: bool = True) -> ReducedGradient:
    """Reduced-gradient method: split q = (q_a, q_b) with J_a the nonsingular m x m minor of largest
    |det|; q'_b = +/- alpha grad_b H' with grad_b H' = (-(J_a^-1 J_b)^T  I) T grad H;
    q'_a = J_a^-1 (v - J_b q'_b)."""
    J = _mat(J)
    m, n = J.shape
    v = _vec(v, m, "task vector")
    g = _vec(gradient, n, "gradient")
    minors = {}
    for cols in combinations(range(n), m):
        removed = tuple(j + 1 for j in range(n) if j not in cols)
        minors[removed] = float(np.linalg.det(J[:, cols]))
    best = max(minors, key=lambda k: abs(minors[k]))
    if abs(minors[best]) < DEFAULT_THRESHOLD:
        raise RedundancyError("every m x m minor of J is singular: the reduced gradient is not defined")
    b_idx = [i - 1 for i in best]
    a_idx = [j for j in range(n) if j not in b_idx]
    Ja, Jb = J[:, a_idx], J[:, b_idx]
    Jai = np.linalg.inv(Ja)
    grad_b = -(Jai @ Jb).T @ g[a_idx] + g[b_idx]
    dq_b = (1 if maximize else -1) * alpha * grad_b
    dq_a = Jai @ (v - Jb @ dq_b)
    dq = np.zeros(n)
    dq[a_idx], dq[b_idx] = dq_a, dq_b
    names = ", ".join(rf"\det J_{{-{','.join(map(str, k))}}} = {num(d)}" for k, d in minors.items())
    steps = [
        Step("Minors", names, f"$J_a$ is made of columns {', '.join(str(j + 1) for j in a_idx)} (the largest $|\\det|$)."),
        Step("Reduced gradient", r"\nabla_{q_b} H' = \begin{pmatrix} -(J_a^{-1}J_b)^T & I\end{pmatrix} T \nabla_q H = " + vec(grad_b),
             "Gradient of $H$ along the manifold of configurations that keep the task."),
        Step("Solution", r"\dot q_{RG} = T^T \begin{pmatrix} J_a^{-1}(v - J_b \dot q_b) \\ \dot q_b \end{pmatrix} = " + vec(dq),
             "The free joints follow the reduced gradient, the others realize the task.",
             {"joint_values": [{"label": "RG", "values": dq.tolist()}]}),
    ]
    return ReducedGradient(dq, minors, tuple(j + 1 for j in a_idx), grad_b, steps)


# ====================================================================== task priority
@dataclass
class PriorityLevel:
    jacobian: np.ndarray
    projected: np.ndarray         # J_k P_{k-1}
    rank: int                     # rank of J_k
    projected_rank: int           # rank of J_k P_{k-1}
    dq: np.ndarray                # cumulative solution after this level
    error: np.ndarray             # v_k - J_k dq (final)

    @property
    def algorithmic_singularity(self) -> bool:
        """J_k P_{k-1} loses rank although J_k does not: the tasks conflict."""
        return self.projected_rank < self.rank


@dataclass
class TaskPriority:
    dq: np.ndarray
    levels: List[PriorityLevel]
    steps: List[Step]


def task_priority(tasks: Sequence[Tuple[Sequence, Sequence]], threshold: float = DEFAULT_THRESHOLD,
                  symbol: str = r"\dot q") -> TaskPriority:
    """Recursive task priority: q'_k = q'_{k-1} + (J_k P_{k-1})^# (v_k - J_k q'_{k-1}),
    P_k = P_{k-1} - (J_k P_{k-1})^# (J_k P_{k-1}), starting from q'_0 = 0, P_0 = I.

    >>> tp = task_priority([([[1, 1, 1]], [0]), ([[-2.4142, -1.7071, -1], [1.4142, 0.7071, 0]], [2, -1])])
    >>> (np.round(tp.dq, 4) + 0.0).tolist()
    [-1.0607, 0.0, 1.0607]
    """
    if not tasks:
        raise RedundancyError("task priority needs at least one task")
    mats = [(_mat(J), np.asarray(v, float).reshape(-1)) for J, v in tasks]
    n = mats[0][0].shape[1]
    dq = np.zeros(n)
    P = np.eye(n)
    levels, steps = [], []
    for k, (J, v) in enumerate(mats, 1):
        if J.shape[1] != n or J.shape[0] != v.size:
            raise RedundancyError(f"task {k}: Jacobian {J.shape} and task vector of size {v.size} do not match n = {n}")
        JP = J @ P
        JPi = pinv(JP, threshold)
        rank_J = int(np.sum(np.linalg.svd(J, compute_uv=False) > threshold))
        rank_JP = int(np.sum(np.linalg.svd(JP, compute_uv=False) > threshold)) if JP.size else 0
        dq = dq + JPi @ (v - J @ dq)
        P = P - JPi @ JP
        levels.append(PriorityLevel(J, JP, rank_J, rank_JP, dq.copy(), np.zeros(v.size)))
        note = ""
        if rank_JP < rank_J:
            note = (rf" Algorithmic singularity: $\mathrm{{rank}}(J_{k} P_{{{k-1}}}) = {rank_JP} < \mathrm{{rank}}(J_{k}) = {rank_J}$; "
                    f"task {k} is only partly executed.")
        steps.append(Step(f"Priority level {k}",
                          rf"J_{k} P_{{{k-1}}} = {mat(JP)},\quad {symbol}_{k} = {vec(dq)}",
                          f"Task {k} is pursued in the null space of the higher-priority tasks.{note}",
                          {"joint_values": [{"label": f"level {k}", "values": dq.tolist()}]}))
    for lev, (J, v) in zip(levels, mats):
        lev.error = v - J @ dq
    errs = r",\quad ".join(rf"e_{k} = {vec(l.error)}" for k, l in enumerate(levels, 1))
    steps.append(Step("Task errors", errs, "Higher-priority tasks are exact unless their own Jacobian is singular."))
    return TaskPriority(dq, levels, steps)


# ====================================================================== bounds
def velocity_bounds(q, q_min, q_max, v_max, dt: float) -> Tuple[np.ndarray, np.ndarray]:
    """Joint velocity bounds over the next interval dt from range and speed limits."""
    q, q_min, q_max, v_max = (np.asarray(x, float) for x in (q, q_min, q_max, v_max))
    return np.maximum((q_min - q) / dt, -v_max), np.minimum((q_max - q) / dt, v_max)


def acceleration_bounds(q, dq, q_min, q_max, v_max, a_max, dt: float) -> Tuple[np.ndarray, np.ndarray]:
    """Joint acceleration bounds over the next interval dt from range, speed and acceleration limits."""
    q, dq, q_min, q_max, v_max, a_max = (np.asarray(x, float) for x in (q, dq, q_min, q_max, v_max, a_max))
    lo = np.maximum.reduce([2 * (q_min - q - dq * dt) / dt ** 2, (-v_max - dq) / dt, -a_max])
    hi = np.minimum.reduce([2 * (q_max - q - dq * dt) / dt ** 2, (v_max - dq) / dt, a_max])
    return lo, hi


# ====================================================================== SNS
@dataclass
class SNSIteration:
    active: List[int]             # 1-based indices of the joints still free (W_jj = 1)
    saturated: Dict[int, float]   # 1-based joint -> saturated value (q'_N)
    target: np.ndarray            # task left to the free joints: s v - J q'_N
    candidate: np.ndarray         # full joint vector of this iteration
    violating: List[int]          # 1-based joints out of bounds
    scale: Optional[float]        # task scaling factor computed at this iteration (None if feasible)
    critical: Optional[int]       # 1-based joint saturated next
    kind: str = "sns"             # "sns", "release" (minimum-norm step) or "block"


@dataclass
class SNSResult:
    dq: np.ndarray
    scale: float
    iterations: List[SNSIteration]
    steps: List[Step]
    lower: np.ndarray
    upper: np.ndarray

    @property
    def norm(self) -> float:
        return float(np.linalg.norm(self.dq))


def _out_of_bounds(x, lo, hi) -> List[int]:
    return [i for i in range(len(x)) if x[i] < lo[i] - FEASIBILITY_TOLERANCE or x[i] > hi[i] + FEASIBILITY_TOLERANCE]


def _scaling_factor(a, b, lo, hi, active) -> Tuple[float, int]:
    """SNS task scaling: largest s <= 1 keeping a s + b in bounds, and the most critical joint
    (the active joint whose bound limits s the most)."""
    s_max_i = np.full(len(a), np.inf)
    s_min_i = np.full(len(a), -np.inf)
    for i, (ai, bi) in enumerate(zip(a, b)):
        if active[i] and abs(ai) > 1e-14:
            s1, s2 = (lo[i] - bi) / ai, (hi[i] - bi) / ai
            s_min_i[i], s_max_i[i] = min(s1, s2), max(s1, s2)
    s_max, s_min = float(np.min(s_max_i)), float(np.max(s_min_i))
    critical = int(np.argmin(s_max_i))
    if s_min > s_max or s_max < 0:
        return 0.0, critical
    return min(s_max, 1.0), critical


def sns(J, target, lower, upper, minimum_norm: bool = False, threshold: float = DEFAULT_THRESHOLD,
        symbol: str = r"\dot q", task_symbol: str = "v") -> SNSResult:
    """Saturation in the null space (Flacco, De Luca, Khatib): saturate the most critical joint,
    remove its column from the task, and repeat until the solution respects the bounds; when no
    more joints can be saturated (rank(J W) < m), the task is scaled by the best factor found.

    Works at velocity level (target = task velocity, bounds on q') and at acceleration level
    (target = task acceleration - J' q', bounds on q''). With ``minimum_norm`` the result is then
    refined into the minimum-norm solution among all feasible ones for the same (scaled) task, by
    releasing saturated joints whose Lagrange multiplier has the wrong sign (an active-set QP
    step; the basic SNS solution is feasible but not always of minimum norm)."""
    J = _mat(J)
    m, n = J.shape
    x = _vec(target, m, "task")
    lo, hi = _vec(lower, n, "lower bounds"), _vec(upper, n, "upper bounds")
    if np.any(lo > hi):
        raise RedundancyError("a lower bound is above the upper bound")
    if np.any(lo > FEASIBILITY_TOLERANCE) or np.any(hi < -FEASIBILITY_TOLERANCE):
        raise RedundancyError("the bounds must contain zero (a joint at rest must be feasible)")
    w = np.ones(n, dtype=bool)            # active (not saturated) joints
    dq_n = np.zeros(n)
    s, s_best, w_best, dqn_best = 1.0, 0.0, w.copy(), dq_n.copy()
    iterations: List[SNSIteration] = []
    steps: List[Step] = []
    while True:
        JW = J * w
        JWi = pinv(JW, threshold)
        tk = s * x - J @ dq_n
        dq = dq_n + JWi @ tk
        bad = _out_of_bounds(dq, lo, hi)
        it = SNSIteration([i + 1 for i in range(n) if w[i]], {i + 1: float(dq_n[i]) for i in range(n) if not w[i]},
                          tk, dq.copy(), [i + 1 for i in bad], None, None)
        iterations.append(it)
        if not bad:
            break
        a = JWi @ x
        b = dq - a * s
        task_scale, j = _scaling_factor(a, b, lo, hi, w)
        it.scale, it.critical = task_scale, j + 1
        if task_scale > s_best:
            s_best, w_best, dqn_best = task_scale, w.copy(), dq_n.copy()
        w[j] = False
        dq_n[j] = hi[j] if dq[j] > hi[j] else lo[j]
        if np.linalg.matrix_rank(J * w, tol=threshold) < np.linalg.matrix_rank(J, tol=threshold) or not w.any():
            s, w, dq_n = s_best, w_best, dqn_best
            dq = dq_n + pinv(J * w, threshold) @ (s * x - J @ dq_n)
            iterations.append(SNSIteration([i + 1 for i in range(n) if w[i]], {i + 1: float(dq_n[i]) for i in range(n) if not w[i]},
                                           s * x - J @ dq_n, dq.copy(), [], s, None))
            break
    for k, it in enumerate(iterations, 1):
        sat = ", ".join(f"{symbol}_{{{i}}} = {num(v)}" for i, v in it.saturated.items())
        text = (f"Joints {', '.join(map(str, it.violating))} out of bounds; task scaling {num(it.scale)}, "
                f"joint {it.critical} is saturated next." if it.violating else "Every joint is within its bounds.")
        latex = (rf"{task_symbol}_{{{k-1}}} = {task_symbol} - J\,{symbol}_N = {vec(it.target)},\quad " if it.saturated else "") + \
            rf"{symbol}_{{({k})}} = {symbol}_N + (J W)^\# {task_symbol}_{{{k-1}}} = {vec(it.candidate)}" + (rf"\quad ({sat})" if sat else "")
        steps.append(Step(f"SNS iteration {k}", latex, text,
                          {"joint_values": [{"label": f"iteration {k}", "values": it.candidate.tolist(),
                                             "lower": lo.tolist(), "upper": hi.tolist(),
                                             "saturated": sorted(it.saturated), "violating": it.violating}]}))
    if minimum_norm:
        s_opt, _ = max_task_scale(J, x, lo, hi, threshold)
        s_opt = min(s_opt, 1.0)
        if s_opt > s + 1e-9:
            s = s_opt
            dq = feasible_point(J, s * x, lo, hi, threshold)
            steps.append(Step("Optimal task scaling", rf"s^* = {num(s)},\quad {symbol} = {vec(dq)}",
                              "The saturation sequence of SNS stopped at a smaller scaling; the largest feasible "
                              "scaling is found on the facet of the reachable task set J(bounds) crossed by the task direction.",
                              {"scale": s}))
        dq, extra = _minimum_norm_refinement(J, s * x, lo, hi, dq, threshold)
        for it in extra:
            iterations.append(it)
            what = "released (its multiplier shows the bound is not needed)" if it.kind == "release" else "blocked at its bound"
            steps.append(Step(f"Minimum-norm step {len(iterations)}",
                              rf"{symbol} = {vec(it.candidate)}",
                              f"Joint {it.critical} {what}.",
                              {"joint_values": [{"label": "minimum norm", "values": it.candidate.tolist(),
                                                 "lower": lo.tolist(), "upper": hi.tolist(), "saturated": sorted(it.saturated)}]}))
    steps.append(Step("SNS solution", rf"{symbol}^* = {vec(dq)},\quad s = {num(s)},\quad \|{symbol}^*\| = {num(np.linalg.norm(dq))}",
                      "Feasible; the task is executed " + ("exactly (no scaling needed)." if s >= 1 - 1e-12 else f"scaled by {num(s)}."),
                      {"joint_values": [{"label": "SNS", "values": dq.tolist(), "lower": lo.tolist(), "upper": hi.tolist()}],
                       "scale": s}))
    return SNSResult(dq, float(s), iterations, steps, lo, hi)


def _minimum_norm_refinement(J, t, lo, hi, x, threshold, max_iter: int = 100):
    """Primal active-set method for min |x|^2 s.t. J x = t, lo <= x <= hi, from a feasible x."""
    n = len(x)
    x = np.clip(x, lo, hi)
    active = {i: ("lo" if abs(x[i] - lo[i]) < 1e-9 else "hi") for i in range(n)
              if abs(x[i] - lo[i]) < 1e-9 or abs(x[i] - hi[i]) < 1e-9}
    extra: List[SNSIteration] = []
    for _ in range(max_iter):
        free = [i for i in range(n) if i not in active]
        xa = np.array([x[i] if i in active else 0.0 for i in range(n)])
        x_new = xa.copy()
        if free:
            x_new[free] = pinv(J[:, free], threshold) @ (t - J @ xa)
        p = x_new - x
        if np.linalg.norm(p) > 1e-12:
            alpha, block = 1.0, None
            for i in free:
                if p[i] > 1e-15 and x[i] + p[i] > hi[i]:
                    a = (hi[i] - x[i]) / p[i]
                elif p[i] < -1e-15 and x[i] + p[i] < lo[i]:
                    a = (lo[i] - x[i]) / p[i]
                else:
                    continue
                if a < alpha:
                    alpha, block = a, i
            x = x + alpha * p
            if block is not None:
                active[block] = "hi" if p[block] > 0 else "lo"
                x[block] = hi[block] if p[block] > 0 else lo[block]
                extra.append(SNSIteration([i + 1 for i in range(n) if i not in active], {i + 1: float(x[i]) for i in active},
                                          t, x.copy(), [], None, block + 1, "block"))
            continue
        if not active:
            break
        lam = -pinv(J[:, free].T, threshold) @ x[free] if free else np.zeros(J.shape[0])
        worst, worst_val = None, 1e-10
        for i, side in active.items():
            mu = -(x[i] + J[:, i] @ lam)
            wrong = -mu if side == "hi" else mu     # upper bound needs mu >= 0, lower bound mu <= 0
            if wrong > worst_val:
                worst, worst_val = i, wrong
        if worst is None:
            break
        del active[worst]
        extra.append(SNSIteration([i + 1 for i in range(n) if i not in active], {i + 1: float(x[i]) for i in active},
                                  t, x.copy(), [], None, worst + 1, "release"))
    return x, extra


# ====================================================================== exact task scaling
def max_task_scale(J, t, lower, upper, threshold: float = DEFAULT_THRESHOLD) -> Tuple[float, Optional[np.ndarray]]:
    """Largest s >= 0 with s t in J(box): the set of task vectors reachable within the bounds is a
    zonotope, and s is fixed by the facet that the ray s t crosses. Facet normals are orthogonal to
    (rank - 1) columns of J, so trying every such normal gives s exactly. Returns (s, normal); s is
    inf when t = 0 and 0 when t is outside the range of J.

    >>> s, d = max_task_scale([[1.0, 1.0]], [4.0], [-1, -1], [1, 1])
    >>> round(s, 12)
    0.5
    """
    J = _mat(J)
    t = np.asarray(t, float).reshape(-1)
    lo, hi = np.asarray(lower, float), np.asarray(upper, float)
    if np.linalg.norm(t) < 1e-14:
        return np.inf, None
    U, sv, _ = np.linalg.svd(J)
    rho = int(np.sum(sv > threshold))
    if rho == 0:
        return 0.0, None
    Ur = U[:, :rho]
    if np.linalg.norm(t - Ur @ (Ur.T @ t)) > 1e-9 * max(1.0, np.linalg.norm(t)):
        return 0.0, None
    G, tr = Ur.T @ J, Ur.T @ t
    if rho == 1:
        normals = [np.array([1.0]), np.array([-1.0])]
    else:
        normals = []
        for cols in combinations(range(G.shape[1]), rho - 1):
            S = G[:, cols]
            u, sing, _ = np.linalg.svd(S)
            if np.sum(sing > threshold) == rho - 1:
                d = u[:, -1]
                normals += [d, -d]
    best, best_d = np.inf, None
    for d in normals:
        dt = d @ tr
        if dt <= 1e-14:
            continue
        c = G.T @ d
        support = float(np.sum(np.maximum(c * hi, c * lo)))
        if support / dt < best:
            best, best_d = support / dt, Ur @ d
    return float(max(best, 0.0)), best_d


def feasible_point(J, t, lower, upper, threshold: float = DEFAULT_THRESHOLD) -> np.ndarray:
    """A joint vector within the bounds with J x = s t for the largest s <= 1 (``max_task_scale``):
    joints whose column points out of the crossed facet are saturated, the others solve the rest of
    the task recursively (a lower-dimensional problem)."""
    J = _mat(J)
    t = np.asarray(t, float).reshape(-1)
    lo, hi = np.asarray(lower, float), np.asarray(upper, float)
    n = J.shape[1]
    s, d = max_task_scale(J, t, lo, hi, threshold)
    if d is None:
        return np.zeros(n)
    x = np.zeros(n)
    c = J.T @ d
    tol = 1e-10 * max(1.0, np.abs(c).max())
    sat = [i for i in range(n) if abs(c[i]) > tol]
    free = [i for i in range(n) if abs(c[i]) <= tol]
    for i in sat:
        x[i] = hi[i] if c[i] > 0 else lo[i]
    if free:
        x[free] = feasible_point(J[:, free], s * t - J[:, sat] @ x[sat], lo[free], hi[free], threshold)
    return x / s if s > 1 else x
