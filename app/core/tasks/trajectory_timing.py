"""Trajectory-planning tasks: timing laws, minimum time under torque bounds, uniform time scaling,
decoupled minimum-time motions, and Cartesian tracking in a task frame along a straight path.
Values follow the conventions of ``context`` (TaskView).

A *law* spec is {type: cubic | quintic | bang_bang | trapezoidal, T, V, A, Ts, ratio (Ts/T)}.

``timing_law``: ``law``, ``delta`` (displacement). Answers ``T``, ``Ts``, ``V``, ``A``.
``minimum_time``: smallest T of a law class (``law`` without T; ``ratio`` fixes Ts/T for a
  trapezoid) for a joint-space straight motion ``start`` -> ``goal`` under ``torque`` bounds
  (inverse dynamics of the robot, gravity included). Answers ``T_min``, ``A``, ``V``, ``Ts``,
  ``peak_time``, ``tau_peak`` (torques at the peak instant).
``time_scaling``: smallest uniform scaling k >= 1 (t' = k t) restoring ``bounds`` on the torques,
  for a ``trajectory`` ({law with T, start, goal}) or for torque ``samples`` [{q, tau}] or
  [{q, joint, tau}] (the nominal peaks and where they occur; gravity is computed at q unless given
  as ``g``). Answers ``k``,
  ``k_joints``, ``T_scaled`` (with ``T``), ``tau_nominal_max`` and ``tau_scaled_max`` (trajectory),
  ``g_samples``, ``g_peaks`` and ``tau_scaled`` (samples: at the sampled joint).
``decoupled_minimum_time``: robots with constant diagonal M and constant g (Cartesian): each joint
  moves bang-bang between ``start`` and ``goal`` with its own acceleration and deceleration bounds
  from ``torque`` bounds. Answers ``T_<coordinate>``, ``T_<coordinate>_switch``, ``T_star``,
  ``u_static`` (g, the force held at rest), ``initial_slope`` (q''_2/q''_1 at t = 0).
``path_minimum_time``: time-optimal rest-to-rest motion along a given joint ``path`` (phase-plane
  method, ``app.core.time_optimal``): ``path`` is {start, goal} (a joint-space segment) or
  {coordinate: expression of s} for s in [0, 1] (names of ``given`` allowed); bounds ``torque``
  (symmetric list, or {lower, upper}), ``velocity``, ``acceleration`` (any subset); ``nodes``
  (grid intervals, default 1000); ``at`` (times; expressions may use the answer T_min) for samples;
  ``suffix`` (appended to the answer names as ``_<suffix>``). Answers
  ``T_min``, ``arcs`` (kinds, in order), ``switch_s``, ``switch_times``, ``dq_peak`` (max |q'_i|),
  ``ddq_start`` and ``tau_start`` (q'' and torque just after the start), and at the times ``at``:
  ``q_at``, ``dq_at``, ``ddq_at``, ``tau_at`` (one row per time).
``cartesian_tracking``: feedback linearization of a point's motion along the straight path
  ``start`` -> ``goal`` with a ``law``, errors decoupled in the task frame (tangent t, normal n):
  e'' + K_D e' + K_P e = 0 with ``kp``, ``kd`` (task frame). Initial state ``q``, ``velocity``.
  Answers ``alpha`` (path angle), ``R`` (task frame), ``path_length``, ``A``, ``V``, ``ddp_d0``,
  ``error0_task``, ``u0``, and at ``time``: ``error_task_t``, ``error_t``, ``p_t``, ``p_d_t``.
"""
from __future__ import annotations

import numpy as np
import sympy as sp

from .. import jacobians as jac
from .. import planning as pl
from .. import time_optimal as topt
from ..errors import UserError
from ..latex import mat, num, vec
from . import task
from .context import TaskView


def _law(d, spec, delta, T=None):
    if not isinstance(spec, dict) or "type" not in spec:
        raise d._fail("law: expected {type: cubic | quintic | bang_bang | trapezoidal, ...}")
    kind = spec["type"]
    get = lambda k: d.number(spec[k], f"law.{k}") if k in spec else None
    T = T if T is not None else get("T")
    try:
        if kind in ("cubic", "quintic"):
            if T is None:
                raise pl.PlanningError(f"{kind} law: give T")
            return pl.TimingLaw.polynomial(kind, delta, T)
        if kind == "bang_bang":
            return pl.TimingLaw.bang_bang(delta, T=T, A=get("A"))
        if kind == "trapezoidal":
            return pl.TimingLaw.trapezoidal(delta, T=T, V=get("V"), A=get("A"), Ts=get("Ts"), ratio=get("ratio"))
    except UserError as exc:
        raise d._fail(str(exc)) from None
    raise d._fail(f"law.type: unknown '{kind}' (cubic, quintic, bang_bang, trapezoidal)")


def _law_answers(ctx, law, prefix=""):
    ctx.answer(prefix + "T", law.T)
    ctx.answer(prefix + "Ts", law.Ts)
    ctx.answer(prefix + "V", law.V)
    ctx.answer(prefix + "A", law.A)


@task("timing_law")
def timing_law_task(ctx, spec):
    """A rest-to-rest timing law from its data."""
    d = TaskView(ctx)
    law = _law(d, spec.get("law") or {}, d.number(spec.get("delta", 1.0), "delta"))
    ctx.steps.extend(law.steps(spec.get("unit", "m")))
    _law_answers(ctx, law)


def _joint_path(d, spec):
    q0 = d.array(spec["start"], "start").reshape(-1)
    q1 = d.array(spec["goal"], "goal").reshape(-1)
    if q0.size != d.robot.n or q1.size != d.robot.n:
        raise d._fail(f"start/goal: expected {d.robot.n} values")
    return q0, q1 - q0


def _torque_along(d, q0, dq_dir):
    num_model = d.ctx.numeric

    def torque(p, v, a):
        p, v, a = (np.atleast_1d(x) for x in (p, v, a))
        out = np.empty((p.size, d.robot.n))
        for k in range(p.size):
            out[k] = num_model.inverse_dynamics(q0 + p[k] * dq_dir, v[k] * dq_dir, a[k] * dq_dir)
        return out

    def gravity(p):
        return np.array([num_model.g(q0 + s * dq_dir) for s in np.atleast_1d(p)])
    return torque, gravity


@task("minimum_time")
def minimum_time_task(ctx, spec):
    """Minimum duration of a rest-to-rest joint motion of a given law class under torque bounds."""
    d = TaskView(ctx)
    q0, delta = _joint_path(d, spec)
    bounds = d.array(spec["torque"], "torque") * np.ones(d.robot.n)
    torque, gravity = _torque_along(d, q0, delta)
    lspec = dict(spec.get("law") or {})
    lspec.pop("T", None)
    if any(k in lspec for k in ("V", "A", "Ts")):
        raise d._fail("minimum_time: the law class must have a fixed shape (give ratio = Ts/T, not V, A or Ts)")
    ctx.step("Inverse dynamics along the path", r"\tau(t) = M(q)\ddot q + c(q, \dot q) + g(q),\quad q = q_0 + \sigma(t)\,\Delta q",
             f"Torque bounds ${vec(bounds)}$; the law class is {str(lspec.get('type')).replace('_', '-')}.")
    try:
        res = pl.minimum_time(lambda T: _law(d, lspec, 1.0, T), torque, gravity, bounds)
    except UserError as exc:
        raise d._fail(str(exc)) from None
    ctx.steps.extend(res.steps)
    law = res.law
    scale = float(delta[np.argmax(np.abs(delta))])
    ctx.answer("T_min", res.T)
    ctx.answer("Ts", law.Ts)
    ctx.answer("A", law.A * scale)
    ctx.answer("V", law.V * scale)
    ctx.answer("peak_time", res.peak_time)
    p, v, a = law(res.peak_time)
    ctx.answer("tau_peak", torque(p, v, a)[0])


@task("time_scaling")
def time_scaling_task(ctx, spec):
    """Smallest uniform time scaling that makes a trajectory torque-feasible."""
    d = TaskView(ctx)
    n = d.robot.n
    bounds = d.array(spec["bounds"], "bounds") * np.ones(n)
    T = None
    if "trajectory" in spec:
        tr = spec["trajectory"]
        q0, delta = _joint_path(d, tr)
        law = _law(d, tr.get("law") or {}, 1.0)
        T = law.T
        torque, gravity = _torque_along(d, q0, delta)
        t = pl.sample_times(law, 4001)
        p, v, a = law(t)
        tau = torque(p, v, a)
        g = gravity(p)
        k_peak = np.unravel_index(np.argmax(np.abs(tau) / bounds), tau.shape)
        ctx.step("Nominal torque", rf"\max_t |\tau_{k_peak[1] + 1}(t)| = {num(abs(tau[k_peak]))}\ \text{{at}}\ t = {num(t[k_peak[0]])}",
                 "Inverse dynamics along the nominal trajectory." +
                 (" The bound is exceeded." if np.any(np.abs(tau) > bounds * (1 + 1e-12)) else " The bound is respected."))
        ctx.answer("tau_nominal_max", float(abs(tau[k_peak])))
        ctx.answer("tau_nominal_peak_time", float(t[k_peak[0]]))
    else:
        samples = spec.get("samples") or []
        if not samples:
            raise d._fail("time_scaling: give a trajectory or torque samples")
        g = np.array([d.array(s["g"], "samples.g").reshape(-1) * np.ones(n) if "g" in s
                      else d.ctx.numeric.g(d.array(s["q"], "samples.q").reshape(-1)) for s in samples])
        tau = g.copy()
        joints = []
        for i, s_ in enumerate(samples):
            if "joint" in s_:
                j = int(s_["joint"]) - 1
                tau[i, j] = d.number(s_["tau"], "samples.tau")
                joints.append(j)
            else:
                tau[i] = d.array(s_["tau"], "samples.tau").reshape(-1)
                joints.append(None)
        if "T" in spec:
            T = d.number(spec["T"], "T")
        ctx.step("Gravity at the peaks", r"g(q(t_i)) = " + mat(g), "The part of the torque that time scaling does not change.")
        ctx.answer("g_samples", g)
    try:
        ts = pl.uniform_time_scaling(tau, g, bounds)
    except UserError as exc:
        raise d._fail(str(exc)) from None
    ctx.steps.extend(ts.steps)
    ctx.answer("k", ts.k)
    ctx.answer("k_joints", ts.per_joint)
    if T is not None:
        ctx.step("Scaled duration", rf"T' = k T = {num(ts.k * T)}", "The slowest uniformly scaled motion that respects the bounds.")
        ctx.answer("T_scaled", ts.k * T)
    scaled = ts.scaled_peaks
    if "samples" in spec:
        vals = [scaled[i, j] if j is not None else scaled[i] for i, j in enumerate(joints)]
        ctx.answer("g_peaks", np.array([g[i, j] if j is not None else g[i] for i, j in enumerate(joints)], dtype=float))
        ctx.step("Scaled torques", r"\tau_k = " + r",\ ".join(num(v) if np.ndim(v) == 0 else vec(v) for v in vals),
                 r"At the scaled instants $t' = k t$; the critical joint reaches its bound exactly.")
        ctx.answer("tau_scaled", np.array(vals, dtype=float))
    else:
        worst = np.unravel_index(np.argmax(np.abs(scaled) / bounds), scaled.shape)
        ctx.answer("tau_scaled_max", float(abs(scaled[worst])))


@task("decoupled_minimum_time")
def decoupled_minimum_time_task(ctx, spec):
    """Per-joint bang-bang minimum time for a robot with constant diagonal M and constant g."""
    d = TaskView(ctx)
    robot = d.robot
    n = robot.n
    M = d.ctx.numeric.M(np.zeros(n))
    q0 = d.array(spec["start"], "start").reshape(-1)
    q1 = d.array(spec["goal"], "goal").reshape(-1)
    g = d.ctx.numeric.g(q0)
    probe = np.random.default_rng(0).normal(size=n)
    if not (np.allclose(M, np.diag(np.diag(M))) and np.allclose(d.ctx.numeric.M(probe), M)
            and np.allclose(d.ctx.numeric.g(probe), g)):
        raise d._fail("decoupled_minimum_time needs a constant diagonal inertia matrix and constant gravity")
    U = d.array(spec["torque"], "torque") * np.ones(n)
    T_all = []
    acc0 = np.zeros(n)
    for i, c in enumerate(robot.coordinates):
        delta = q1[i] - q0[i]
        up, down = (U[i] - g[i]) / M[i, i], (U[i] + g[i]) / M[i, i]
        a1, a2 = (up, down) if delta >= 0 else (down, up)
        law = pl.bang_bang_min_time(delta, a1, a2) if abs(delta) > 0 else pl.TimingLaw("bang_bang", 0.0, 0.0)
        acc0[i] = np.sign(delta) * a1
        ctx.step(f"Joint {c}", rf"-\frac{{U + g_{i+1}}}{{M_{{{i+1}{i+1}}}}} \le \ddot{c} \le \frac{{U - g_{i+1}}}{{M_{{{i+1}{i+1}}}}}:\quad T_{{{c}}} = {num(law.T)},\ T_{{{c},sw}} = {num(law.Ts)}",
                 f"Full acceleration ({num(a1)}) then full deceleration ({num(a2)}) over {num(delta)}.")
        ctx.answer(f"T_{c}", law.T)
        ctx.answer(f"T_{c}_switch", law.Ts)
        T_all.append(law.T)
    T_star = max(T_all)
    ctx.step("Minimum transfer time", rf"T^* = \max_i T_i = {num(T_star)}",
             "The faster joint can be slowed down to arrive together; at rest at the goal the inputs hold $u = g$.")
    ctx.answer("T_star", T_star)
    ctx.answer("u_static", g)
    if n == 2 and abs(acc0[0]) > 0:
        ctx.answer("initial_slope", float(acc0[1] / acc0[0]))


@task("cartesian_tracking")
def cartesian_tracking_task(ctx, spec):
    """Task-frame feedback linearization along a straight path, u(0) and the error at a time."""
    d = TaskView(ctx)
    robot = d.robot
    point = spec.get("point", "ee")
    P0 = d.array(spec["start"], "start").reshape(-1)
    P1 = d.array(spec["goal"], "goal").reshape(-1)
    L = float(np.linalg.norm(P1 - P0))
    t_dir = (P1 - P0) / L
    alpha = float(np.arctan2(t_dir[1], t_dir[0]))
    R = np.array([[np.cos(alpha), -np.sin(alpha)], [np.sin(alpha), np.cos(alpha)]])
    ctx.step("Task frame", rf"\alpha = \mathrm{{atan2}}({num(t_dir[1])}, {num(t_dir[0])}) = {num(alpha)},\quad R(\alpha) = (t\ n) = {mat(R)}",
             f"Tangent along the path (length {num(L)}), normal rotated by +90 degrees.")
    law = _law(d, spec.get("law") or {}, L)
    ctx.steps.extend(law.steps("m"))
    q = d.configuration(spec.get("q"))
    dq = d.array(spec.get("velocity", [0] * robot.n), "velocity").reshape(-1)
    comps = ["x", "y"]
    J_sym = jac.jacobian(robot, point, comps)
    r_sym = jac.task_function(robot, point, comps)
    J = np.atleast_2d(jac.evaluate(robot, J_sym, q, d.params))
    p = np.asarray(jac.evaluate(robot, r_sym, q, d.params), float).reshape(-1)
    Jdot = sp.zeros(*J_sym.shape)
    for qk, vk in zip(robot.q, dq):
        if vk:
            Jdot += J_sym.diff(qk) * float(vk)
    h = np.atleast_2d(jac.evaluate(robot, Jdot, q, d.params)) @ dq
    s0, ds0, dds0 = (float(x) for x in law(0.0))
    pd0, dpd0, ddpd0 = P0 + s0 * t_dir, ds0 * t_dir, dds0 * t_dir
    e0, de0 = pd0 - p, dpd0 - J @ dq
    eR, deR = R.T @ e0, R.T @ de0
    kp = d.array(spec["kp"], "kp") * np.ones(2)
    kd = d.array(spec["kd"], "kd") * np.ones(2)
    aR = R.T @ ddpd0 + kd * deR + kp * eR
    ddq = np.linalg.solve(J, R @ aR - h)
    num_model = d.ctx.numeric
    u0 = num_model.M(q) @ ddq + num_model.c(q, dq) + num_model.g(q)
    ctx.step("Initial error", rf"p(0) = {vec(p)},\quad ^R e(0) = R^T (p_d(0) - p(0)) = {vec(eR)},\quad \ddot p_d(0) = {vec(ddpd0)}",
             "Tangential and normal components of the position error.",
             vectors=[{"label": "e(0)", "origin": list(p) + [0.0], "vector": list(e0) + [0.0], "role": "error"}],
             path=[list(P0) + [0.0], list(P1) + [0.0]])
    ctx.step("Control law", r"u = M(q)\left(J^{-1} R\,(^R\ddot p_d + K_D\,^R\dot e + K_P\,^R e) - J^{-1}\dot J \dot q\right) + c(q,\dot q) + g(q)"
             + rf",\quad u(0) = {vec(u0)}", "Exact linearization and decoupling of the tangential and normal errors.")
    ctx.answer("alpha", alpha)
    ctx.answer("R", R)
    ctx.answer("path_length", L)
    ctx.answer("A", law.A)
    ctx.answer("V", law.V)
    ctx.answer("ddp_d0", ddpd0)
    ctx.answer("error0_task", eR)
    ctx.answer("u0", u0)
    if "time" in spec:
        from scipy.linalg import expm
        tt = d.number(spec["time"], "time")
        eRt = np.zeros(2)
        for i in range(2):
            Acl = np.array([[0.0, 1.0], [-kp[i], -kd[i]]])
            eRt[i] = (expm(Acl * tt) @ np.array([eR[i], deR[i]]))[0]
        st = float(law(tt)[0])
        pdt = P0 + st * t_dir
        et = R @ eRt
        ctx.step(f"Error at $t = {num(tt)}$", rf"^R e(t) = {vec(eRt)},\quad e(t) = R\,^R e(t) = {vec(et)},\quad p(t) = p_d(t) - e(t) = {vec(pdt - et)}",
                 "Each task-frame error follows its own linear second-order dynamics.",
                 points=[{"label": "p(t)", "position": list(pdt - et) + [0.0]}, {"label": "p_d(t)", "position": list(pdt) + [0.0]}])
        ctx.answer("error_task_t", eRt)
        ctx.answer("error_t", et)
        ctx.answer("p_d_t", pdt)
        ctx.answer("p_t", pdt - et)


def _path(d, spec):
    """A JointPath from {start, goal} or {coordinate: expression of s}."""
    robot = d.robot
    if not isinstance(spec, dict):
        raise d._fail("path: expected {start, goal} or {coordinate: expression of s}")
    if "start" in spec or "goal" in spec:
        q0, delta = _joint_path(d, spec)
        return topt.JointPath.line(q0, q0 + delta)
    missing = [c for c in robot.coordinates if c not in spec]
    unknown = [k for k in spec if k not in robot.coordinates]
    if missing or unknown:
        raise d._fail(f"path: give one expression of s for each of {', '.join(robot.coordinates)}"
                      + (f" (unknown: {', '.join(map(str, unknown))})" if unknown else ""))
    s = sp.Symbol("s", real=True)
    values = {sp.Symbol(k, real=True): v for k, v in d.scalars().items() if k != "s"}
    exprs = [d.expression(str(spec[c]), f"path.{c}").xreplace(values) for c in robot.coordinates]
    try:
        return topt.JointPath.from_expressions(exprs, s)
    except UserError as exc:
        raise d._fail(f"path: {exc}") from None


@task("path_minimum_time")
def path_minimum_time_task(ctx, spec):
    """Minimum time along a given path under joint velocity, acceleration and torque bounds."""
    d = TaskView(ctx)
    robot = d.robot
    n = robot.n
    path = _path(d, spec.get("path"))
    torque = None
    if "torque" in spec:
        tq = spec["torque"]
        torque = d.bounds(tq, n, "torque") if isinstance(tq, dict) else (-d.array(tq, "torque") * np.ones(n), d.array(tq, "torque") * np.ones(n))
    velocity = d.array(spec["velocity"], "velocity") * np.ones(n) if "velocity" in spec else None
    acceleration = d.array(spec["acceleration"], "acceleration") * np.ones(n) if "acceleration" in spec else None
    try:
        res, _ = topt.minimum_time_along_path(path, ctx.numeric if torque is not None else None, torque, velocity, acceleration,
                                              nodes=int(spec.get("nodes", 1000)), names=robot.coordinates)
    except UserError as exc:
        raise d._fail(str(exc)) from None
    bounds = [f"${name} {vec(v)}$" for name, v in ((r"|\tau| \le", torque[1] if torque else None),
                                                   (r"|\dot q| \le", velocity), (r"|\ddot q| \le", acceleration))
              if v is not None]
    q_ends = path.q(np.array([0.0, 1.0]))
    ctx.step("Path", rf"q(0) = {vec(q_ends[0])},\ q(1) = {vec(q_ends[1])}", "Bounds: " + "; ".join(bounds) + ".",
             configuration={c: float(v) for c, v in zip(robot.coordinates, q_ends[0])})
    ctx.steps.extend(res.steps)
    sfx = f"_{spec['suffix']}" if spec.get("suffix") else ""

    def answer(key, value):
        ctx.answer(key + sfx, value)
    answer("T_min", res.T)
    answer("arcs", [a.kind for a in res.arcs])
    answer("switch_s", [s for s, _ in res.switch_points])
    answer("switch_times", [t for _, t in res.switch_points])
    t = np.linspace(0.0, res.T, 4001)
    q, dq, ddq = topt.joint_motion(res, path, t)
    answer("dq_peak", np.abs(dq).max(axis=0))
    q0, dq0, ddq0 = topt.joint_motion(res, path, [0.0])
    answer("ddq_start", ddq0[0])
    answer("tau_start", ctx.numeric.inverse_dynamics(q0[0], dq0[0], ddq0[0]))
    if "at" in spec:
        times = [d.number(x, "at") for x in (spec["at"] if isinstance(spec["at"], list) else [spec["at"]])]
        q, dq, ddq = topt.joint_motion(res, path, times)
        tau = np.array([ctx.numeric.inverse_dynamics(q[k], dq[k], ddq[k]) for k in range(len(times))])
        ctx.step("Samples of the optimal motion", ", ".join(rf"\tau({num(tt)}) = {vec(tau[k])}" for k, tt in enumerate(times)),
                 "Joint torques along the minimum-time motion.",
                 configuration={c: float(v) for c, v in zip(robot.coordinates, q[0])})
        answer("q_at", q)
        answer("dq_at", dq)
        answer("ddq_at", ddq)
        answer("tau_at", tau)
