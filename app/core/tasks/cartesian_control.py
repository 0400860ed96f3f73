"""Cartesian computed torque and task-frame decoupling (symbolic, from the robot's model).

``cartesian_computed_torque``: u = M J^-1 (a - J' q') + c + g for a point whose Jacobian is square,
  with a = p''_d + K_D (p'_d - J q') + K_P (p_d - p) (``reference: tracking``) or
  a = K_P (p_d - p) - K_D J q' (``regulation``, the default); then p'' = a and each error
  component obeys e'' + k_D e' + k_P e = 0. Options: ``point`` (default ee), ``components``
  (default x, y), ``gains: {KP: [...], KD: [...]}`` (diagonal, numbers or expressions; default
  symbols kp_x, kd_x, ...), ``frame: {angle, axes}`` (planar: the diagonal gains act along the
  axes of a task frame rotated by a constant angle, e.g. along and across a straight path, so
  K = R diag(k) R^T; gain symbols kp_t, kp_n, ...), ``reference``, ``check`` (default true:
  p'' = a at random states with the robot file's numbers). Answers: ``p``, ``J``, ``J_dot``,
  ``Jdot_dq``, ``M``, ``c``, ``g``, ``u``, ``a``, ``R``, ``K_P``, ``K_D`` (these four with
  ``frame``), ``error_polys`` (s^2 + k_D s + k_P per component), ``poles`` (per component, rows
  [real, imaginary]), ``damping`` (zeta per component), ``oscillatory`` (complex poles),
  ``closed_loop_check`` (largest |p'' - a|).
``task_frame_errors``: errors in a planar task frame rotated by alpha_d(t) (``app.core.task_frame``).
  Options: ``axes`` (labels of x_t, y_t; default [n, t]), ``gains`` (label -> {omega, zeta}:
  k_P = omega^2, k_D = 2 zeta omega). Answers: ``R``, ``S``, ``D``, ``te``, ``te_dot``,
  ``te_ddot``, ``a``, ``K_P_t``, ``K_D_t``, ``K_P_const`` and ``K_D_const`` (alpha' = alpha'' = 0),
  ``closed_loop_residual`` (te'' + tK_D te' + tK_P te under a: zero), ``k_P_<label>``,
  ``k_D_<label>``.
``gains_from_response``: PD gains that give prescribed error transients e(t) (one expression of t
  per label, e.g. ``{e1: "e10*(1 + 5*t)*exp(-5*t)"}``): e'' + k_D e' + k_P e = 0 identically.
  Answers ``k_P_<label>``, ``k_D_<label>``, ``K_P``, ``K_D`` (diagonal), ``de0_<label>`` (e'(0)).

Symbols: desired position ``p_dx``, ``p_dy``, ``p_dz``, velocity ``dp_dx``, ..., acceleration
``ddp_dx``, ...; task-frame angle ``alpha_d`` with ``dalpha_d``, ``ddalpha_d``; base-frame errors
``e_x``, ``e_y`` and derivatives ``de_x``, ``dde_x``; task gains ``k_P_<label>``, ``k_D_<label>``.

Example (2019-06-17#4):

    - kind: cartesian_computed_torque
      gains: {KP: [100, 50], KD: [20, 10]}
"""
from __future__ import annotations

import numpy as np
import sympy as sp

from .. import jacobians as jac
from .. import linear_control as lc
from .. import task_frame as tf
from ..errors import UserError
from ..exercise import ExerciseError
from ..expressions import ExpressionError, parse_expression, symbol
from ..numeric import numeric_function
from . import task
from .context import TaskView
from .underactuated import _inverse

_AXES = ("x", "y", "z")


def _expr(value, where):
    try:
        return parse_expression(value)
    except ExpressionError as exc:
        raise ExerciseError(f"{where}: {exc}") from None


def _diag(values, labels, prefix, where):
    if values is None:
        return [symbol(f"{prefix}_{c}") for c in labels]
    values = values if isinstance(values, list) else [values] * len(labels)
    if len(values) != len(labels):
        raise ExerciseError(f"{where}: expected {len(labels)} diagonal gains")
    return [_expr(v, where) for v in values]


def _time_derivative(mat, m):
    out = sp.zeros(*mat.shape)
    for qk, dk in zip(m.q, m.dq):
        out += mat.diff(qk) * dk
    return out


def _pole_rows(kp, kd):
    """Roots of s^2 + kd s + kp as sorted [real, imaginary] rows (numbers when the gains are)."""
    s = lc.s
    roots = sp.Poly(s ** 2 + kd * s + kp, s).all_roots() if kp.is_number and kd.is_number else sp.solve(s ** 2 + kd * s + kp, s)
    rows = [[sp.re(r), sp.im(r)] for r in roots]
    if all(x.is_number for row in rows for x in row):
        rows.sort(key=lambda r: (float(r[0]), float(r[1])))
    return rows


@task("cartesian_computed_torque")
def cartesian_computed_torque_task(ctx, spec):
    """Feedback linearization in Cartesian space (see the module docstring)."""
    m = TaskView(ctx)
    comps = list(spec.get("components", ["x", "y"]))
    if not set(comps) <= set(_AXES):
        raise ExerciseError("cartesian_computed_torque.components: a list among x, y, z")
    if len(comps) != len(m.coords):
        raise ExerciseError(f"cartesian_computed_torque: the Jacobian must be square ({len(comps)} components, "
                            f"{len(m.coords)} coordinates)")
    try:
        p = jac.task_function(m.robot, spec.get("point", "ee"), comps)
    except UserError as exc:
        raise ExerciseError(f"cartesian_computed_torque.point: {exc}") from None
    p = m.tidy_matrix(p)
    J = m.tidy_matrix(p.jacobian(m.q))
    J_dot = m.tidy_matrix(_time_derivative(J, m))
    Jdot_dq = m.tidy_matrix(J_dot * m.dq)
    gains = spec.get("gains") or {}
    frame = spec.get("frame")
    if frame is not None and (not isinstance(frame, dict) or "angle" not in frame or len(comps) != 2):
        raise ExerciseError("cartesian_computed_torque.frame: {angle, axes} of a planar task frame (two components)")
    labels = list(frame.get("axes", ["t", "n"])) if frame else comps
    if len(labels) != len(comps):
        raise ExerciseError("cartesian_computed_torque.frame.axes: two labels (x_t, y_t)")
    kp = _diag(gains.get("KP"), labels, "kp", "cartesian_computed_torque.gains.KP")
    kd = _diag(gains.get("KD"), labels, "kd", "cartesian_computed_torque.gains.KD")
    Kp, Kd = sp.diag(*kp), sp.diag(*kd)
    if frame:
        R = tf.rotation2(_expr(frame["angle"], "cartesian_computed_torque.frame.angle"))
        Kp, Kd = (R * Kp * R.T).applyfunc(sp.expand), (R * Kd * R.T).applyfunc(sp.expand)
        ctx.answer("R", R)
        ctx.answer("K_P", Kp)
        ctx.answer("K_D", Kd)
        ctx.step("Gains in the task frame", rf"R = {m.L(R)},\quad K_P = R\,{{}}^tK_P R^T = {m.L(Kp)},\quad "
                 rf"K_D = R\,{{}}^tK_D R^T = {m.L(Kd)}",
                 r"Diagonal gains along the axes of a task frame rotated by a constant angle ($\dot\alpha = 0$): with "
                 r"${}^te = R^T e$ the error obeys ${}^t\ddot e + {}^tK_D\, {}^t\dot e + {}^tK_P\, {}^te = 0$, one "
                 "decoupled second-order system per axis of the task frame.")
    p_d = sp.Matrix([symbol(f"p_d{c}") for c in comps])
    dp_d = sp.Matrix([symbol(f"dp_d{c}") for c in comps])
    ddp_d = sp.Matrix([symbol(f"ddp_d{c}") for c in comps])
    mode = spec.get("acceleration", spec.get("reference", "regulation"))
    if mode not in ("regulation", "tracking", "free"):
        raise ExerciseError("cartesian_computed_torque.reference: regulation or tracking (acceleration: free)")
    if mode == "tracking":
        a = ddp_d + Kd * (dp_d - J * m.dq) + Kp * (p_d - p)
        a_tex = r"\ddot p_d + K_D(\dot p_d - J\dot q) + K_P(p_d - p)"
    elif mode == "regulation":
        a = Kp * (p_d - p) - Kd * J * m.dq
        a_tex = r"K_P(p_d - p) - K_D J \dot q"
    else:
        a = sp.Matrix([symbol(f"a_{c}") for c in comps])
        a_tex = r"(a_x, a_y)\ \text{(any commanded acceleration)}"
    g = m.dyn.g + m.dyn.spring
    c = m.dyn.c + m.dyn.friction
    if frame:      # the rotated gains make a long: tidy the law with a as symbols, then substitute it
        a = a.applyfunc(sp.expand)
        a_syms = sp.Matrix([symbol(f"a_{c}") for c in comps])
        u = m.tidy_matrix(m.M * _inverse(J) * (a_syms - Jdot_dq) + c + g).xreplace(dict(zip(a_syms, a)))
        ctx.answer("a", a)
    else:
        u = m.tidy_matrix(m.M * _inverse(J) * (a - Jdot_dq) + c + g)
    for name, value in (("p", p), ("J", J), ("J_dot", J_dot), ("Jdot_dq", Jdot_dq), ("M", m.M), ("c", m.dyn.c),
                        ("g", g), ("u", u)):
        ctx.answer(name, value)
    bodies = [b.name for b in m.robot.bodies]
    ctx.step("Kinematics of the task", rf"p = {m.L(p)},\quad J = {m.L(J)},\quad \dot J = {m.L(J_dot)}",
             "Direct kinematics, its Jacobian and the time derivative of the Jacobian.", bodies=bodies)
    ctx.step("Control law", rf"u = M J^{{-1}}\left(a - \dot J \dot q\right) + c + g,\quad a = " + a_tex,
             r"With $u$, $\ddot q = J^{-1}(a - \dot J \dot q)$, hence $\ddot p = J \ddot q + \dot J \dot q = a$: each error "
             r"component is a decoupled second-order linear system ($J$ nonsingular).", joints=bodies)
    if spec.get("check", True):
        ctx.answer("closed_loop_check", _closed_loop_check(m, u, a, J, Jdot_dq, kp, kd, p_d, dp_d, ddp_d))
    if mode == "free":
        return
    polys, poles, zetas, osc = [], [], [], []
    for kp_, kd_ in zip(kp, kd):
        polys.append(lc.s ** 2 + kd_ * lc.s + kp_)
        poles.append(_pole_rows(kp_, kd_))
        zetas.append(sp.nsimplify(kd_ / (2 * sp.sqrt(kp_))))
        osc.append(bool(kd_ ** 2 < 4 * kp_) if (kp_.is_number and kd_.is_number) else None)
    ctx.answer("error_polys", sp.Matrix(polys))
    ctx.answer("poles", poles)
    ctx.answer("damping", sp.Matrix(zetas))
    if all(o is not None for o in osc):
        ctx.answer("oscillatory", osc)
    rows = [rf"e_{c_}:\ {m.L(pl)} = 0,\ \zeta = {m.L(z)}" for c_, pl, z in zip(labels, polys, zetas)]
    ctx.step("Error transients", r",\quad ".join(rows),
             r"Complex poles ($\zeta < 1$) give a damped oscillation with overshoot; a double real pole ($\zeta = 1$) none.")


def _closed_loop_check(m, u, a, J, Jdot_dq, kp, kd, p_d, dp_d, ddp_d, trials=5, seed=0):
    """Largest |p'' - a| with q'' = M^-1 (u - c - g) at random states (robot file's numbers)."""
    from ..numeric import NumericModel
    rng = np.random.default_rng(seed)
    values = {p.symbol: float(p.value) for p in m.robot.parameters.values()}
    gains = {x: float(rng.uniform(1, 10)) for x in set().union(*[sp.sympify(v).free_symbols for v in kp + kd])}
    num_model = NumericModel(m.robot)
    syms = list(m.q) + list(m.dq) + list(p_d) + list(dp_d) + list(ddp_d) + sorted(
        set().union(*[x.free_symbols for x in a]) - set(m.q) - set(m.dq) - set(p_d) - set(dp_d) - set(ddp_d)
        - set(gains) - set(values), key=lambda s_: s_.name)
    f_u = numeric_function(syms, u.xreplace({**values, **gains}), "numpy")
    f_a = numeric_function(syms, a.xreplace({**values, **gains}), "numpy")
    f_J = numeric_function(syms, J.xreplace(values), "numpy")
    f_Jd = numeric_function(syms, Jdot_dq.xreplace(values), "numpy")
    worst = 0.0
    for _ in range(trials):
        args = list(rng.uniform(0.2, 1.2, len(syms)))
        q, dq = np.array(args[:len(m.q)]), np.array(args[len(m.q):2 * len(m.q)])
        uu = np.asarray(f_u(*args), float).reshape(-1)
        ddq = num_model.forward_dynamics(q, dq, uu)
        pdd = np.asarray(f_J(*args), float) @ ddq + np.asarray(f_Jd(*args), float).reshape(-1)
        worst = max(worst, float(np.max(np.abs(pdd - np.asarray(f_a(*args), float).reshape(-1)))))
    return worst


@task("task_frame_errors")
def task_frame_errors_task(ctx, spec):
    """Decoupled errors along the axes of a rotating planar task frame (see the module docstring)."""
    axes = list(spec.get("axes", ["n", "t"]))
    if len(axes) != 2 or not all(isinstance(a, str) and a.isidentifier() for a in axes):
        raise ExerciseError("task_frame_errors.axes: two labels (x_t, y_t)")
    f = tf.rotating_frame_errors(axes)
    sy = f.symbols
    zero = {sy["dalpha"]: 0, sy["ddalpha"]: 0}
    answers = {"R": f.R, "S": f.S, "D": f.D, "te": f.te, "te_dot": f.te_dot, "te_ddot": f.te_ddot, "a": f.a,
               "K_P_t": f.K_P_t, "K_D_t": f.K_D_t, "K_P_const": f.K_P_t.xreplace(zero).applyfunc(sp.expand),
               "K_D_const": f.K_D_t.xreplace(zero), "closed_loop_residual": f.residual}
    for k, v in answers.items():
        ctx.answer(k, v)
    L = lambda x: sp.latex(x)
    ctx.step("Errors in the task frame", rf"{{}}^t e = R^T(\alpha_d) e,\quad {{}}^t\dot e = {L(f.te_dot)},\quad "
             rf"{{}}^t\ddot e = {L(f.te_ddot)}",
             r"Differentiating $R^T e$ with a time-varying angle: $\dot R = S(\dot\alpha_d) R$, and $\ddot R$ brings "
             r"$S(\ddot\alpha_d)$ and $-\dot\alpha_d^2 I$.")
    ctx.step("Acceleration that decouples the task errors", rf"a = {L(f.a)},\quad K_P(t) = {L(f.K_P_t)},\quad K_D(t) = {L(f.K_D_t)}",
             r"Imposing ${}^t\ddot e + {}^tK_D\, {}^t\dot e + {}^tK_P\, {}^t e = 0$ with $\ddot p = a$; written with base-frame "
             r"errors the gains vary with the frame and gain extra terms from its rotation (they become $R\, {}^tK R^T$ "
             "on a straight path).")
    for label, g in (spec.get("gains") or {}).items():
        if label not in axes or not isinstance(g, dict) or "omega" not in g:
            raise ExerciseError(f"task_frame_errors.gains.{label}: {{omega, zeta}} for an axis among {axes}")
        w = _expr(g["omega"], f"task_frame_errors.gains.{label}.omega")
        z = _expr(g.get("zeta", 1), f"task_frame_errors.gains.{label}.zeta")
        ctx.answer(f"k_P_{label}", sp.expand(w ** 2))
        ctx.answer(f"k_D_{label}", sp.expand(2 * z * w))
        ctx.step(f"Gains along {label}", rf"s^2 + k_D s + k_P = s^2 + 2\zeta\omega s + \omega^2:\ "
                 rf"k_{{P,{label}}} = {L(sp.expand(w ** 2))},\ k_{{D,{label}}} = {L(sp.expand(2 * z * w))}",
                 r"Natural frequency $\omega$ and damping $\zeta$ of the error along this axis ($\zeta = 1$: critically damped).")


@task("gains_from_response")
def gains_from_response_task(ctx, spec):
    """PD gains from prescribed error transients (see the module docstring)."""
    errors = spec.get("errors")
    if not isinstance(errors, dict) or not errors:
        raise ExerciseError("gains_from_response.errors: label -> e(t)")
    t = symbol("t")
    kps, kds = [], []
    for label, text in errors.items():
        e = _expr(text, f"gains_from_response.errors.{label}")
        try:
            kp, kd = lc.second_order_gains(e, t)
        except lc.LinearLoopError as exc:
            raise ExerciseError(f"gains_from_response.errors.{label}: {exc}") from None
        kps.append(kp)
        kds.append(kd)
        ctx.answer(f"k_P_{label}", kp)
        ctx.answer(f"k_D_{label}", kd)
        ctx.answer(f"de0_{label}", sp.simplify(e.diff(t).subs(t, 0)))
        ctx.step(f"Gains for {label}", rf"{sp.latex(e)}:\quad \ddot e + k_D \dot e + k_P e \equiv 0 \Rightarrow "
                 rf"k_P = {sp.latex(kp)},\ k_D = {sp.latex(kd)}",
                 "The prescribed error must solve the closed-loop error equation for every $t$: its exponentials fix "
                 "the two poles, hence the gains.")
    ctx.answer("K_P", sp.diag(*kps))
    ctx.answer("K_D", sp.diag(*kds))
