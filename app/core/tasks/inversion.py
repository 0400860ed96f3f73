"""Higher-order inversion of differential kinematics, and task velocities of joint motions.
Values follow the conventions of ``context`` (TaskView).

``inversion``: joint acceleration (``order: 2``, default) or jerk (``order: 3``) realizing a task
  acceleration or jerk ``task`` for the symbolic Jacobian of an earlier ``jacobian`` task, at its
  configuration, with joint velocity ``joint_velocity`` (and ``joint_acceleration`` for order 3):
      order 2:  J q'' = p'' - J' q'               (drift n = J' q')
      order 3:  J q''' = p''' - 2 J' q'' - J'' q'  (drift n = 2 J' q'' + J'' q')
  solved as the minimizer of 1/2 |x - x_0|^2_W among the solutions: x = J_W^# (target - n) +
  (I - J_W^# J) x_0. The preferred x_0 is ``preferred`` (a vector) or, with ``damping`` K (number,
  list or matrix), -K times the joint velocity (order 2) or acceleration (order 3), e.g. 1/T_c for
  the smallest joint velocity after a sampling time T_c. ``weights``: W (default identity).
  Answers ``<name>`` (default ddq or dddq), ``<name>_drift``, ``<name>_target`` (task minus
  drift), ``<name>_preferred``, ``<name>_error`` (task residual), ``<name>_kkt_gap`` (distance from
  the minimizer computed independently from the optimality (KKT) conditions, 0 when J has full row
  rank).
``task_velocity``: ``jacobian`` (name or matrix) times ``velocity``: answer ``<name>`` (default v).
"""
from __future__ import annotations

import numpy as np
import sympy as sp

from .. import jacobians as jac
from .. import redundancy as red
from ..latex import mat, num, sig, vec
from ..steps import symbol_latex
from . import task
from .context import TaskView


def _time_derivative(J: sp.Matrix, robot) -> sp.Matrix:
    """d/dt of a matrix of q and q' (symbols dq, ddq of the robot)."""
    out = sp.zeros(*J.shape)
    for q, dq, ddq in zip(robot.q, robot.dq, robot.ddq):
        out += J.diff(q) * dq + J.diff(dq) * ddq
    return out


@task("inversion")
def inversion_task(ctx, spec):
    """Second-order (acceleration) or jerk-level inversion with a preferred null-space motion."""
    d = TaskView(ctx)
    robot = d.robot
    order = int(spec.get("order", 2))
    if order not in (2, 3):
        raise d._fail("inversion.order: 2 (accelerations) or 3 (jerks)")
    name = spec.get("name", "ddq" if order == 2 else "dddq")
    ref = spec.get("jacobian", "J")
    obj = d.objects.get(ref) if isinstance(ref, str) else None
    if obj is None or obj["sym"] is None or obj["q"] is None:
        raise d._fail("inversion.jacobian: name an earlier jacobian task defined on the robot (its derivatives are needed)")
    J_sym, q = obj["sym"], obj["q"]
    n = robot.n
    dq = d.array(spec["joint_velocity"], "joint_velocity").reshape(-1)
    ddq = d.array(spec["joint_acceleration"], "joint_acceleration").reshape(-1) if order == 3 else np.zeros(n)
    if dq.size != n or ddq.size != n:
        raise d._fail(f"inversion: joint velocity/acceleration need {n} values")
    Jdot = _time_derivative(J_sym, robot)
    drift_sym = Jdot * sp.Matrix(robot.dq) if order == 2 else 2 * Jdot * sp.Matrix(robot.ddq) + _time_derivative(Jdot, robot) * sp.Matrix(robot.dq)
    values = {s: float(v) for s, v in zip(robot.dq, dq)}
    values.update({s: float(v) for s, v in zip(robot.ddq, ddq)})
    drift = np.asarray(jac.evaluate(robot, d.substitute(drift_sym.xreplace(values)), q, d.params), float).reshape(-1)
    J = obj["num"]
    m = J.shape[0]
    p = d.array(spec["task"], "task").reshape(-1)
    if p.size != m:
        raise d._fail(f"inversion.task: expected {m} values")
    target = p - drift
    lower = dq if order == 2 else ddq
    if "preferred" in spec:
        x0 = d.array(spec["preferred"], "preferred").reshape(-1)
        how = "Given preferred motion."
    elif "damping" in spec:
        K = d.array(spec["damping"], "damping")
        K = np.diag(K * np.ones(n)) if K.ndim < 2 else K
        x0 = -K @ lower
        how = (r"$x_0 = -K \dot q$" if order == 2 else r"$x_0 = -K \ddot q$") + ": damps the joint motion in the null space."
    else:
        x0 = np.zeros(n)
        how = "Minimum norm."
    W = red.weighted_matrix(d.array(spec["weights"], "weights"), n) if "weights" in spec else np.eye(n)
    sym = r"\ddot q" if order == 2 else r"\dddot q"
    drift_tex = r"\dot J \dot q" if order == 2 else r"2 \dot J \ddot q + \ddot J \dot q"
    p_tex = r"\ddot p" if order == 2 else r"\dddot p"
    ctx.step("Drift term", rf"n = {drift_tex} = {vec(drift)},\quad {p_tex} - n = {vec(target)}",
             rf"Differentiating $\dot p = J \dot q$ {'once' if order == 2 else 'twice'} more; evaluated at "
             rf"$\dot q = {vec(dq)}$" + (rf", $\ddot q = {vec(ddq)}$" if order == 3 else "") + ".",
             configuration={c: float(v) for c, v in zip(robot.coordinates, q)})
    res = red.resolve(J, target, weights=W if "weights" in spec else None, preferred=x0, symbol=sym, task_symbol="t")
    ctx.steps.extend(res.steps)
    x = res.dq
    # independent check: KKT conditions of min 1/2 |x - x0|_W^2 s.t. J x = target
    kkt = np.block([[W, J.T], [J, np.zeros((m, m))]])
    gap = np.nan
    if np.linalg.matrix_rank(J) == m:
        sol = np.linalg.solve(kkt, np.concatenate([W @ x0, target]))
        gap = float(np.linalg.norm(sol[:n] - x))
        ctx.step("Optimality check", rf"\begin{{pmatrix}} W & J^T \\ J & 0 \end{{pmatrix}} \begin{{pmatrix}} x \\ \lambda \end{{pmatrix}} = \begin{{pmatrix}} W x_0 \\ t \end{{pmatrix}}:\ \|x - x_{{KKT}}\| {_gap(gap)}",
                 how + " The closed form is the constrained minimizer.")
    ctx.answer(name, x)
    ctx.answer(f"{name}_drift", drift)
    ctx.answer(f"{name}_target", target)
    ctx.answer(f"{name}_preferred", x0)
    ctx.answer(f"{name}_error", res.error)
    ctx.answer(f"{name}_kkt_gap", gap)


@task("task_velocity")
def task_velocity_task(ctx, spec):
    """v = J q' for a Jacobian and a joint velocity (e.g. the velocity of a second point)."""
    d = TaskView(ctx)
    name = spec.get("name", "v")
    J = d.jacobian(spec.get("jacobian", "J"))
    dq = d.array(spec["velocity"], "velocity").reshape(-1)
    if dq.size != J.shape[1]:
        raise d._fail(f"task_velocity.velocity: expected {J.shape[1]} values")
    v = J @ dq
    ctx.step(f"Task velocity ${symbol_latex(name)}$", rf"{symbol_latex(name)} = J \dot q = {mat(J)} {vec(dq)} = {vec(v)}", "")
    ctx.answer(name, v)


def _compare_inverses(J, xd, threshold):
    """Cartesian velocities of q'_A = J^# x'_d and q'_B = J^T x'_d, and the SVD quantities."""
    U, s, _ = np.linalg.svd(J)
    r = int(np.sum(s > threshold))
    w = U[:, :r].T @ xd
    xa = J @ red.pinv(J, threshold) @ xd
    xb = J @ J.T @ xd
    return xa, xb, float(w @ w), float(np.sum((s[:r] * w) ** 2)), r


@task("pinv_vs_transpose")
def pinv_vs_transpose_task(ctx, spec):
    """Pseudoinverse vs Jacobian transpose at a (possibly singular) J: with J = U S V^T and
    w = U_r^T x'_d, x'_d^T J J^# x'_d = |w|^2 >= 0 and x'_d^T J J^T x'_d = sum sigma_i^2 w_i^2 >= 0
    (angles at most pi/2); for x'_d in the range of J only the pseudoinverse is exact.

    Options ``jacobian``, ``task`` (x'_d), ``threshold``, ``random`` (count of random rank-deficient
    instances checked, seed 0). Answers ``<name>_A``, ``<name>_B`` (the Cartesian velocities),
    ``<name>_inner_A``, ``<name>_inner_B``, ``<name>_w_norm2``, ``<name>_sigma_w_norm2``, ``<name>_rank``,
    ``<name>_acute_A``, ``<name>_acute_B``, ``<name>_exact_A``, ``<name>_exact_B`` (yes/no), and with
    ``random``: ``<name>_random_acute`` (all angles <= pi/2), ``<name>_random_range_exact_A`` (J J^# x = x
    for every x in the range), ``<name>_random_range_exact_B_count`` (instances where J J^T x = x)."""
    d = TaskView(ctx)
    name = spec.get("name", "cmp")
    J = d.jacobian(spec.get("jacobian", "J"))
    xd = d.array(spec["task"], "task").reshape(-1)
    thr = float(spec.get("threshold", red.DEFAULT_THRESHOLD))
    xa, xb, w2, sw2, r = _compare_inverses(J, xd, thr)
    tol = 1e-9 * max(1.0, float(np.linalg.norm(xd)))
    ctx.step("Pseudoinverse command", rf"\dot x_A = J J^\# \dot x_d = U \Sigma \Sigma^\# U^T \dot x_d = {vec(xa)},\quad \dot x_d^T \dot x_A = \|w\|^2 = {num(w2)}",
             rf"Rank {r}: the projection of $\dot x_d$ on the range of $J$ ($w = U_r^T \dot x_d$); the angle with $\dot x_d$ is at most $\pi/2$.")
    ctx.step("Transpose command", rf"\dot x_B = J J^T \dot x_d = U \Sigma \Sigma^T U^T \dot x_d = {vec(xb)},\quad \dot x_d^T \dot x_B = \sum_i \sigma_i^2 w_i^2 = {num(sw2)}",
             r"Each range direction is scaled by $\sigma_i^2$: also at most $\pi/2$ from $\dot x_d$, but not equal to it.")
    ctx.answer(f"{name}_A", xa)
    ctx.answer(f"{name}_B", xb)
    ctx.answer(f"{name}_inner_A", float(xd @ xa))
    ctx.answer(f"{name}_inner_B", float(xd @ xb))
    ctx.answer(f"{name}_w_norm2", w2)
    ctx.answer(f"{name}_sigma_w_norm2", sw2)
    ctx.answer(f"{name}_rank", r)
    ctx.answer(f"{name}_acute_A", bool(xd @ xa >= -tol))
    ctx.answer(f"{name}_acute_B", bool(xd @ xb >= -tol))
    ctx.answer(f"{name}_exact_A", bool(np.linalg.norm(xa - xd) <= tol))
    ctx.answer(f"{name}_exact_B", bool(np.linalg.norm(xb - xd) <= tol))
    count = int(spec.get("random", 0))
    if count:
        rng = np.random.default_rng(0)
        acute, exact_a, exact_b = True, True, 0
        for _ in range(count):
            m = int(rng.integers(2, 4))
            n = int(rng.integers(m + 1, 7))
            rank = int(rng.integers(1, m))
            Jr = rng.normal(size=(m, rank)) @ rng.normal(size=(rank, n))
            x = rng.normal(size=m)
            a, b, *_ = _compare_inverses(Jr, x, 1e-9)
            acute &= bool(x @ a >= -1e-9 and x @ b >= -1e-9)
            x_range = Jr @ rng.normal(size=n)
            a, b, *_ = _compare_inverses(Jr, x_range, 1e-9)
            exact_a &= bool(np.linalg.norm(a - x_range) <= 1e-8 * max(1.0, np.linalg.norm(x_range)))
            exact_b += int(np.linalg.norm(b - x_range) <= 1e-8 * max(1.0, np.linalg.norm(x_range)))
        ctx.step("Random singular Jacobians", rf"{count}\ \text{{instances}}:\ \dot x_d^T \dot x_{{A,B}} \ge 0\ \text{{always}}: {'yes' if acute else 'no'}",
                 f"For $\\dot x_d$ in the range, the pseudoinverse was exact in {'all' if exact_a else 'not all'} instances, the transpose in {exact_b}.")
        ctx.answer(f"{name}_random_acute", acute)
        ctx.answer(f"{name}_random_range_exact_A", exact_a)
        ctx.answer(f"{name}_random_range_exact_B_count", exact_b)


def _gap(gap: float) -> str:
    """The optimality gap for display: round-off (below 1e-9) shown as such, not as noise digits."""
    return r"\le 10^{-9}" if gap < 1e-9 else "= " + sig(gap, 2)
