"""Redundancy-resolution tasks (numeric, at a configuration): pseudoinverse and its weighted,
damped and projected-gradient variants, task priority, reduced gradient, SNS, and the
weighted-pseudoinverse identities. Values follow the conventions of ``context`` (TaskView).

``pseudoinverse``: ``jacobian`` (name of a jacobian task or a matrix), ``task`` (vector);
  options ``weights`` (diagonal list, matrix, matrix of expressions of q, or ``inertia`` for
  the robot's M(q)), ``damping`` (mu of damped least squares), ``gradient`` ({objective:
  expression of q}, {joint_range: {lower, upper}}, {potential: true} (gravity potential energy,
  gradient g(q)) or {clearance: {point or points, center, radius}} (distance of a point, or the
  smallest over several points, from a circular or spherical obstacle), with ``alpha`` (default 1),
  ``maximize`` (default false): q'_0 = -/+ alpha grad H projected in the null space, and ``safety``
  (epsilon: where H <= epsilon the task is dropped and q' = -/+ alpha grad H alone), ``preferred`` (q'_0),
  ``fixed`` ({joint index from 1: value}), ``bounds`` ({max} or {lower, upper}: smallest task
  scaling keeping the null-space term), ``check`` ({jacobian name: task vector}: errors on other
  tasks), ``q``.
  Answers: ``<name>``, ``<name>_error``, ``<name>_error_norm``, ``<name>_norm``, ``<name>_pinv``, ``<name>_task``,
  ``<name>_null``, ``<name>_projector``, ``<name>_gradient``, ``<name>_objective`` (H at q),
  ``<name>_cost`` (1/2 q'^T W q', with W the weights or the option ``cost``), ``<name>_half_norm2``,
  ``<name>_clearance_point``, ``<name>_closest_point``, ``<name>_clearance_vector`` (clearance),
  ``<name>_clearances`` and ``<name>_closest_index`` (several points), ``<name>_task_active`` (safety),
  ``<name>_scale``/``<name>_unscaled`` (with bounds), ``<name>_error_<J>`` and
  ``<name>_error_<J>_norm`` (checks).
``task_priority``: ``tasks`` [{jacobian, task}, ...] by decreasing priority. Answers ``<name>``,
  ``<name>_error_<k>`` (k = 1, 2, ...), ``<name>_error`` (stacked), ``<name>_error_norm``,
  ``<name>_projected_<k>`` (J_k P_(k-1)) and ``<name>_projected_pinv_<k>``, ``<name>_algorithmic_singularities`` (the levels k where
  J_k P_(k-1) has lower rank than J_k).
``reduced_gradient``: ``jacobian``, ``task``, ``gradient`` ({objective}), ``alpha``, ``maximize``
  (default true). Answers ``<name>``, ``<name>_minors``, ``<name>_gradient_b``, ``<name>_grad``.
``sns``: ``jacobian``, ``task``, ``bounds``, ``level`` (velocity | acceleration), ``drift``
  (J' q' at acceleration level, subtracted from the task) or ``joint_velocity`` (q', from which
  J' q' is computed), ``minimum_norm`` (bool). Instead of ``bounds``, ``limits``: {``position``
  ({lower, upper} or ``robot`` for the robot file's limits), ``velocity`` (V), ``acceleration``
  (A, acceleration level), ``sampling_time`` (T)} give the bounds over the next interval T:
  velocity level max((q_min - q)/T, -V) <= q' <= min((q_max - q)/T, V); acceleration level
  max(2 (q_min - q - q' T)/T^2, (-V - q')/T, -A) <= q'' <= min(2 (q_max - q - q' T)/T^2, (V - q')/T, A)
  (answers ``<name>_lower``, ``<name>_upper``).
  Answers ``<name>``, ``<name>_scale``, ``<name>_norm``, ``<name>_iterations`` and per iteration k
  ``<name>_candidate_<k>``, ``<name>_task_<k>``, ``<name>_pinv_<k>`` (pseudoinverse of the
  columns of the free joints).
``fastest_stop``: ``jacobian`` (a symbolic jacobian task), ``joint_velocity``, ``bounds`` on the
  joint accelerations: the fastest deceleration p'' = -lambda p'. Answers ``<name>`` (u*),
  ``<name>_lambda``, ``<name>_a``, ``<name>_b``, ``<name>_drift``, ``<name>_ddp``,
  ``<name>_feasible`` (1 or 0).
``weighted_pinv_identity``: ``jacobian``, ``weights``: J_W^# computed as W^-1 J^T (J W^-1 J^T)^-1
  and as W^(-1/2) (J W^(-1/2))^#, and the three Moore-Penrose-like identities. Answers
  ``<name>`` (J_W^#), ``<name>_direct``, ``<name>_identities`` (list of residual norms).
"""
from __future__ import annotations

import numpy as np
import sympy as sp

from .. import redundancy as red
from ..latex import mat, num, vec
from ..steps import symbol_latex
from . import task
from .context import TaskView


def _bounds(d, spec, n):
    return d.bounds(spec, n, "bounds") if spec is not None else (None, None)


def _gradient(d, spec, q, n, extra=None):
    """(grad H at q, latex of H, H at q) from {objective: expr}, {joint_range: {lower, upper}},
    {potential: true} (gravity potential, grad = g(q)) or {clearance: {point, center, radius}}
    (H = |p(q) - center| - radius, grad = J^T (p - center) / |p - center|; ``extra`` receives the
    point, the closest obstacle point and the clearance vector H (p - center) / |p - center|)."""
    robot = d.robot
    if spec.get("potential"):
        g = np.asarray(d.ctx.numeric.g(q), float).reshape(-1)
        return g, r"H = U_g(q),\ \nabla_q H = g(q)", float(d.ctx.numeric.energy(q, np.zeros(n))[1])
    if "clearance" in spec:
        from .contact_forces import _point_jacobian
        c = spec["clearance"]
        center = d.array(c["center"], "gradient.clearance.center").reshape(-1)
        radius = d.number(c.get("radius", 0.0), "gradient.clearance.radius")
        points = c["points"] if isinstance(c.get("points"), list) and c["points"] else [c.get("point", "ee")]
        candidates = []
        for k, point in enumerate(points, 1):
            J, p = _point_jacobian(d, point, q)
            diff = p - center
            dist = float(np.linalg.norm(diff))
            if dist <= 1e-12:
                raise d._fail("gradient.clearance: a point is at the obstacle centre; the clearance has no gradient")
            candidates.append((dist - radius, k, J, p, diff, dist))
        H, k, J, p, diff, dist = min(candidates, key=lambda x: x[0])
        if extra is not None:
            extra.update(clearance_point=p, closest_point=center + radius * diff / dist, clearance_vector=H * diff / dist)
            if len(points) > 1:
                extra.update(clearances=[x[0] for x in candidates], closest_index=k)
        tex = r"H = \|p(q) - c\| - r,\ \nabla_q H = J^T(q)\,\frac{p - c}{\|p - c\|}"
        if len(points) > 1:
            tex = (r"H = \min_k \left(\|p_k(q) - c\| - r\right) = " + num(H) + rf"\ (\text{{point {k}}}),\ "
                   r"\nabla_q H = J_k^T(q)\,\frac{p_k - c}{\|p_k - c\|}")
        return J.T @ diff / dist, tex, H
    if "objective" in spec:
        H = d.expression(spec["objective"], "gradient.objective")
        subs = {sp.Symbol(k, real=True): v for k, v in d.scalars().items() if k not in robot.coordinates}
        H = H.xreplace(subs)
        grad = sp.Matrix([sp.diff(H, s) for s in robot.q])
        values = {s: float(v) for s, v in zip(robot.q, q)}
        g = np.array([float(e.xreplace(values)) for e in grad])
        return g, sp.latex(H), float(H.xreplace(values))
    if "joint_range" in spec:
        rng = spec["joint_range"]
        if rng == "robot" or rng is True:
            lims = [robot.limits.get(c) for c in robot.coordinates]
            if any(l is None or l.position is None for l in lims):
                raise d._fail("gradient.joint_range: the robot file has no position limits for every joint")
            lo = np.array([l.position[0] for l in lims])
            hi = np.array([l.position[1] for l in lims])
        else:
            lo, hi = d.bounds(rng, n, "gradient.joint_range")
        mid, width = (lo + hi) / 2, hi - lo
        g = (q - mid) / (n * width ** 2)
        value = float(np.sum(((q - mid) / width) ** 2) / (2 * n))
        return g, r"H_{range} = \frac{1}{2n}\sum_i \left(\frac{q_i - \bar q_i}{q_{M,i} - q_{m,i}}\right)^2", value
    raise d._fail("gradient: expected {objective: expression}, {joint_range: {lower, upper}}, {potential: true} or {clearance: {point, center, radius}}")


def _weights(d, spec, q, n):
    if isinstance(spec, str) and spec.strip() == "inertia":
        return d.ctx.numeric.M(q)
    W = d.array(spec, "weights", q=q)
    return red.weighted_matrix(W, n)


@task("pseudoinverse")
def pseudoinverse_task(ctx, spec):
    """q' = J^+ v (+ null-space term), J^+ the plain, weighted or damped pseudoinverse."""
    d = TaskView(ctx)
    name = spec.get("name", "dq")
    J = d.jacobian(spec.get("jacobian", "J"))
    m, n = J.shape
    v = d.array(spec.get("task", "v"), "task").reshape(-1)
    needs_q = any(k in spec for k in ("gradient",)) or (isinstance(spec.get("weights"), str) and spec["weights"] == "inertia") \
        or _has_text(spec.get("weights")) or _has_text(spec.get("cost"))
    q = d.configuration(spec.get("q")) if needs_q else None
    W = _weights(d, spec["weights"], q, n) if spec.get("weights") is not None else None
    if W is not None:
        ctx.step("Weight matrix", "W = " + mat(W), r"The norm minimized is $\dot q^T W \dot q$.")
    preferred = d.array(spec["preferred"], "preferred").reshape(-1) if "preferred" in spec else None
    grad = None
    if "gradient" in spec:
        gspec = spec["gradient"]
        extra = {}
        grad, H_tex, H_value = _gradient(d, gspec, q, n, extra)
        for key, value in extra.items():
            ctx.answer(f"{name}_{key}", value)
        alpha = d.number(gspec.get("alpha", 1.0), "gradient.alpha")
        sign = 1.0 if gspec.get("maximize") else -1.0
        preferred = sign * alpha * grad
        ctx.step("Objective gradient", H_tex + r",\quad \nabla_q H = " + vec(grad),
                 ("Ascend" if sign > 0 else "Descend") + f" the gradient with step {num(alpha)}, projected in the null space of the task.",
                 vectors=[{"label": "grad H", "joint_space": True, "vector": grad.tolist(), "role": "gradient"}])
        ctx.answer(f"{name}_gradient", grad)
        ctx.answer(f"{name}_objective", H_value)
        if "safety" in gspec:
            epsilon = d.number(gspec["safety"], "gradient.safety")
            ctx.answer(f"{name}_task_active", bool(H_value > epsilon))
            if H_value <= epsilon:
                dq = preferred
                ctx.step("Avoidance only", rf"H = {num(H_value)} \le \epsilon = {num(epsilon)}:\quad \dot q = "
                         + ("" if sign > 0 else "-") + rf"\alpha \nabla_q H = {vec(dq)}",
                         "Too close to the obstacle: the task is dropped and the joints follow the gradient alone.")
                ctx.answer(name, dq)
                ctx.answer(f"{name}_error", v - J @ dq)
                ctx.answer(f"{name}_error_norm", float(np.linalg.norm(v - J @ dq)))
                return
    fixed = None
    if "fixed" in spec:
        fixed = {int(k) - 1: d.number(v, f"fixed.{k}") for k, v in spec["fixed"].items()}
    lo, hi = _bounds(d, spec.get("bounds"), n)
    res = red.resolve(J, v, weights=W, damping=d.number(spec["damping"]) if "damping" in spec else None,
                      preferred=preferred, threshold=float(spec.get("threshold", red.DEFAULT_THRESHOLD)),
                      fixed=fixed, lower=lo, upper=hi)
    ctx.steps.extend(res.steps)
    ctx.answer(name, res.dq)
    ctx.answer(f"{name}_error", res.error)
    ctx.answer(f"{name}_error_norm", float(np.linalg.norm(res.error)))
    ctx.answer(f"{name}_norm", res.norm)
    ctx.answer(f"{name}_pinv", res.inverse)
    ctx.answer(f"{name}_task", res.dq_task)
    ctx.answer(f"{name}_null", res.dq_null)
    ctx.answer(f"{name}_projector", res.projector)
    Wc = _weights(d, spec["cost"], q if q is not None else d.configuration(spec.get("q")), n) if "cost" in spec else W
    if Wc is not None:
        ctx.answer(f"{name}_cost", float(0.5 * res.dq @ Wc @ res.dq))
    ctx.answer(f"{name}_half_norm2", float(0.5 * res.dq @ res.dq))
    if res.scale is not None:
        ctx.answer(f"{name}_scale", res.scale)
        ctx.answer(f"{name}_unscaled", res.dq_unscaled)
    for jname, task_vec in (spec.get("check") or {}).items():
        Jo = d.jacobian(jname)
        vo = d.array(task_vec, f"check.{jname}").reshape(-1)
        e = vo - Jo @ res.dq
        ctx.step(f"Error on task ${symbol_latex(jname)}$", rf"e = v - {symbol_latex(jname)}\,\dot q = " + vec(e), f"Norm {num(np.linalg.norm(e))}.")
        ctx.answer(f"{name}_error_{jname}", e)
        ctx.answer(f"{name}_error_{jname}_norm", float(np.linalg.norm(e)))


def _has_text(value) -> bool:
    if isinstance(value, str):
        return True
    if isinstance(value, list):
        return any(_has_text(v) for v in value)
    return False


@task("task_priority")
def task_priority_task(ctx, spec):
    """Recursive task-priority solution for tasks listed by decreasing priority."""
    d = TaskView(ctx)
    name = spec.get("name", "dq_tp")
    items = spec.get("tasks") or []
    if not items:
        raise d._fail("task_priority: 'tasks' must list {jacobian, task} entries")
    tasks = [(d.jacobian(t["jacobian"]), d.array(t["task"], "task").reshape(-1)) for t in items]
    tp = red.task_priority(tasks, float(spec.get("threshold", red.DEFAULT_THRESHOLD)))
    ctx.steps.extend(tp.steps)
    ctx.answer(name, tp.dq)
    errors = []
    for k, lev in enumerate(tp.levels, 1):
        ctx.answer(f"{name}_error_{k}", lev.error)
        ctx.answer(f"{name}_error_{k}_norm", float(np.linalg.norm(lev.error)))
        ctx.answer(f"{name}_projected_{k}", lev.projected)
        ctx.answer(f"{name}_projected_pinv_{k}", red.pinv(lev.projected))
        errors.append(lev.error)
    e = np.concatenate(errors)
    ctx.answer(f"{name}_error", e)
    ctx.answer(f"{name}_error_norm", float(np.linalg.norm(e)))
    ctx.answer(f"{name}_algorithmic_singularities", [k for k, lev in enumerate(tp.levels, 1) if lev.algorithmic_singularity])


@task("reduced_gradient")
def reduced_gradient_task(ctx, spec):
    """Reduced-gradient solution (minor of largest |det|)."""
    d = TaskView(ctx)
    name = spec.get("name", "dq_rg")
    J = d.jacobian(spec.get("jacobian", "J"))
    v = d.array(spec.get("task", "v"), "task").reshape(-1)
    q = d.configuration(spec.get("q"))
    grad, H_tex, _ = _gradient(d, spec.get("gradient") or {}, q, J.shape[1])
    ctx.step("Objective gradient", H_tex + r",\quad \nabla_q H = " + vec(grad), "")
    rg = red.reduced_gradient(J, v, grad, d.number(spec.get("alpha", 1.0)), bool(spec.get("maximize", True)))
    ctx.steps.extend(rg.steps)
    ctx.answer(name, rg.dq)
    ctx.answer(f"{name}_minors", list(rg.minors.values()))
    ctx.answer(f"{name}_gradient_b", rg.gradient_b)
    ctx.answer(f"{name}_grad", grad)


@task("sns")
def sns_task(ctx, spec):
    """Saturation in the null space at velocity or acceleration level, with its iterations."""
    d = TaskView(ctx)
    name = spec.get("name", "dq_sns")
    J = d.jacobian(spec.get("jacobian", "J"))
    m, n = J.shape
    target = d.array(spec.get("task", "v"), "task").reshape(-1)
    level = spec.get("level", "velocity")
    if level not in ("velocity", "acceleration"):
        raise d._fail("sns.level: velocity or acceleration")
    sym, tsym = (r"\dot q", "v") if level == "velocity" else (r"\ddot q", r"\ddot p")
    if "drift" in spec or "joint_velocity" in spec:
        drift = (d.array(spec["drift"], "drift").reshape(-1) if "drift" in spec
                 else d.drift(spec.get("jacobian", "J"), spec["joint_velocity"]))
        target = target - drift
        ctx.step("Task without the drift term", rf"\ddot p - \dot J \dot q = {vec(target)}", r"At acceleration level the task is $J \ddot q = \ddot p - \dot J \dot q$.")
    if spec.get("limits") is not None:
        lo, hi = _bounds_from_limits(ctx, d, spec, level, n)
    else:
        lo, hi = d.bounds(spec.get("bounds") or {}, n)
    out = red.sns(J, target, lo, hi, minimum_norm=bool(spec.get("minimum_norm", False)),
                  threshold=float(spec.get("threshold", red.DEFAULT_THRESHOLD)), symbol=sym, task_symbol=tsym)
    if m == (2 if d.robot.is_planar else 3):     # a Cartesian task: its arrows at the end effector
        out.steps[-1].highlight["vectors"] = [
            {"label": "task", "vector": [float(x) for x in target] + [0.0] * (3 - m), "role": "desired"},
            {"label": "executed", "vector": [float(x) for x in J @ out.dq] + [0.0] * (3 - m), "role": "achieved"}]
    ctx.steps.extend(out.steps)
    ctx.answer(name, out.dq)
    ctx.answer(f"{name}_scale", out.scale)
    ctx.answer(f"{name}_norm", out.norm)
    ctx.answer(f"{name}_iterations", len(out.iterations))
    for k, it in enumerate(out.iterations, 1):
        ctx.answer(f"{name}_candidate_{k}", it.candidate)
        ctx.answer(f"{name}_task_{k}", it.target)
        cols = [i - 1 for i in it.active]
        ctx.answer(f"{name}_pinv_{k}", red.pinv(J[:, cols]) if cols else np.zeros((0, m)))


def _bounds_from_limits(ctx, d, spec, level: str, n: int):
    """Bounds on q' (velocity level) or q'' (acceleration level) over the next sampling interval
    from joint range, velocity and acceleration limits (``limits``)."""
    lim = spec["limits"]
    if not isinstance(lim, dict) or "sampling_time" not in lim:
        raise d._fail("sns.limits: expected {position, velocity, acceleration (acceleration level), sampling_time}")
    T = d.number(lim["sampling_time"], "sns.limits.sampling_time")
    if T <= 0:
        raise d._fail("sns.limits.sampling_time: must be positive")
    ref = spec.get("jacobian", "J")
    obj = d.objects.get(ref) if isinstance(ref, str) else None
    q = d.configuration(spec.get("q")) if "q" in spec or obj is None or obj["q"] is None else obj["q"]
    pos = lim.get("position", "robot")
    if pos == "robot":
        rng = [d.robot.limits.get(c) for c in d.robot.coordinates]
        if any(r is None or r.position is None for r in rng):
            raise d._fail("sns.limits.position: the robot file has no position limits for every joint; give {lower, upper}")
        q_min, q_max = np.array([r.position[0] for r in rng]), np.array([r.position[1] for r in rng])
    else:
        q_min, q_max = d.bounds(pos, n, "sns.limits.position")
    v_max = d.array(lim["velocity"], "sns.limits.velocity") * np.ones(n)
    sym = r"\dot q" if level == "velocity" else r"\ddot q"
    if level == "velocity":
        lo, hi = red.velocity_bounds(q, q_min, q_max, v_max, T)
        cands = (rf"\frac{{q_{{min}} - q}}{{T}},\ -V", rf"\frac{{q_{{max}} - q}}{{T}},\ V")
    else:
        if "acceleration" not in lim:
            raise d._fail("sns.limits.acceleration: needed at acceleration level")
        dq = d.array(spec.get("joint_velocity", [0.0] * n), "sns.joint_velocity").reshape(-1)
        a_max = d.array(lim["acceleration"], "sns.limits.acceleration") * np.ones(n)
        lo, hi = red.acceleration_bounds(q, dq, q_min, q_max, v_max, a_max, T)
        cands = (rf"\frac{{2(q_{{min}} - q - \dot q T)}}{{T^2}},\ \frac{{-V - \dot q}}{{T}},\ -A",
                 rf"\frac{{2(q_{{max}} - q - \dot q T)}}{{T^2}},\ \frac{{V - \dot q}}{{T}},\ A")
    ctx.step("Bounds from the joint limits",
             rf"{sym}_{{min}} = \max\left({cands[0]}\right) = {vec(lo)},\quad {sym}_{{max}} = \min\left({cands[1]}\right) = {vec(hi)}",
             f"Over the next sampling interval T = {num(T)} s the joints must stay within their range, speed"
             + (" and acceleration" if level == "acceleration" else "") + " limits.",
             joint_values=[{"label": "bounds", "values": [0.0] * n, "lower": lo.tolist(), "upper": hi.tolist()}])
    name = spec.get("name", "dq_sns")
    ctx.answer(f"{name}_lower", lo)
    ctx.answer(f"{name}_upper", hi)
    bad = [i + 1 for i in range(n) if lo[i] > hi[i] + red.FEASIBILITY_TOLERANCE]
    if bad:
        raise d._fail(f"sns.limits: the limits cannot all be respected at joint(s) {bad} (the joint cannot stop "
                      "before its range limit within its acceleration limit): lower bound above the upper one")
    stop = [i + 1 for i in range(n) if lo[i] > red.FEASIBILITY_TOLERANCE or hi[i] < -red.FEASIBILITY_TOLERANCE]
    if stop:
        raise d._fail(f"sns.limits: joint(s) {stop} must accelerate or brake whatever the task (zero is outside "
                      "their bounds); SNS needs bounds that contain zero")
    return lo, hi


@task("weighted_pinv_identity")
def weighted_pinv_identity_task(ctx, spec):
    """J_W^# = W^-1 J^T (J W^-1 J^T)^-1 = W^(-1/2) (J W^(-1/2))^#, and the identities it satisfies."""
    d = TaskView(ctx)
    name = spec.get("name", "JW")
    J = d.jacobian(spec.get("jacobian", "J"))
    W = red.weighted_matrix(d.array(spec["weights"], "weights"), J.shape[1])
    Wi = np.linalg.inv(W)
    A = red.weighted_pinv(J, W)
    ctx.step("Square root of the weight", r"W^{-1/2} = " + mat(red.inverse_sqrt(W)), "$W$ symmetric positive definite.")
    ctx.step("Weighted pseudoinverse", r"J_W^\# = W^{-1/2} (J W^{-1/2})^\# = " + mat(A), "Defined for any rank of $J$.")
    ctx.answer(name, A)
    if np.linalg.matrix_rank(J) == J.shape[0]:
        direct = Wi @ J.T @ np.linalg.inv(J @ Wi @ J.T)
        ctx.step("Direct formula", r"W^{-1} J^T (J W^{-1} J^T)^{-1} = " + mat(direct), "Full row rank: the two expressions coincide.")
        ctx.answer(f"{name}_direct", direct)
    ids = [np.linalg.norm(J @ A @ J - J), np.linalg.norm(A @ J @ A - A), np.linalg.norm((J @ A).T - J @ A),
           np.linalg.norm((W @ A @ J).T - W @ A @ J)]
    ctx.step("Identities", r"\|J J_W^\# J - J\| = %s,\ \|J_W^\# J J_W^\# - J_W^\#\| = %s,\ \|(J J_W^\#)^T - J J_W^\#\| = %s,\ \|(W J_W^\# J)^T - W J_W^\# J\| = %s"
             % tuple(num(x, 12) for x in ids), "All zero (to round-off).")
    ctx.answer(f"{name}_identities", [float(x) for x in ids])


@task("fastest_stop")
def fastest_stop_task(ctx, spec):
    """Stop the end effector as fast as possible along its current direction with bounded joint
    accelerations: p'' = -lambda p', u = J^# (p'' - J' q') = lambda a + b, the largest feasible
    lambda (a one-dimensional linear program)."""
    d = TaskView(ctx)
    name = spec.get("name", "u")
    ref = spec.get("jacobian", "J")
    J = d.jacobian(ref)
    dq = d.array(spec["joint_velocity"], "joint_velocity").reshape(-1)
    h = d.drift(ref, dq)
    lo, hi = d.bounds(spec.get("bounds") or {}, J.shape[1])
    Jp = red.pinv(J)
    dp = J @ dq
    a, b = -Jp @ dp, -Jp @ h
    lam = red.max_scaling(a, b, lo, hi, np.inf)
    ctx.step("Affine family of commands", rf"\dot p = {vec(dp)},\ \dot J \dot q = {vec(h)},\quad u(\lambda) = \lambda a + b,\ a = -J^\# \dot p = {vec(a)},\ b = -J^\# \dot J\dot q = {vec(b)}",
             r"Every $\lambda \ge 0$ decelerates the end effector along its velocity; the bounds limit $\lambda$ from above and possibly from below.")
    ctx.answer(f"{name}_a", a)
    ctx.answer(f"{name}_b", b)
    ctx.answer(f"{name}_drift", h)
    if lam is None:
        ctx.step("Infeasible", r"\{\lambda \ge 0 : u_{min} \le \lambda a + b \le u_{max}\} = \emptyset",
                 "No joint acceleration within the bounds decelerates the end effector along its velocity.")
        ctx.answer(f"{name}_feasible", 0)
        return
    u = lam * a + b
    ctx.step("Fastest stop", rf"\lambda^* = {num(lam)},\quad u^* = {vec(u)},\quad \ddot p = {vec(J @ u + h)}",
             r"The largest $\lambda$ keeping every joint acceleration within its bounds.",
             joint_values=[{"label": "u*", "values": u.tolist(), "lower": lo.tolist(), "upper": hi.tolist()}])
    ctx.answer(f"{name}_feasible", 1)
    ctx.answer(f"{name}_lambda", lam)
    ctx.answer(name, u)
    ctx.answer(f"{name}_ddp", J @ u + h)
