"""Redundancy resolution at velocity, acceleration and torque level with the robot's own model
(core: app.core.dynamic_redundancy), symbolic or at a numeric state. Values follow the
conventions of ``context`` (TaskView).

``dynamic_redundancy``: for the symbolic Jacobian of an earlier ``jacobian`` task (its task
  function f(q) gives the feedback terms):
  - ``level``: ``velocity`` (J q' = r, r = x'_d + K_P (x_d - f)) or ``acceleration`` (default:
    J q'' = r, r = x''_d - J' q' + K_D (x'_d - J q') + K_P (x_d - f), M q'' + n = tau);
  - ``task``: x'_d or x''_d (numbers, expressions, a given name; symbols allowed when symbolic);
  - ``feedback``: ``{kp, kd, target, velocity}`` (gains: a number, a symbol or one entry per task
    row, default kp1.., kd1..; target x_d default x1_d..; velocity x'_d default 0);
  - ``objective`` (acceleration level): ``acceleration`` (default, min 1/2 |q'' - q''_0|_W^2)
    or ``torque`` (min 1/2 |tau - tau_0|_W^2);
  - ``weights``: diagonal list, matrix, ``inertia`` (M), ``inverse_inertia`` (M^-1),
    ``inverse_inertia_squared`` (M^-2) or ``{norm_of: [expressions linear in q]}`` (W = T^T T for
    the norm of y = T q, e.g. absolute link angles);
  - ``preferred``: x_0, as ``{expression: [...], gravity: k, damping: kv}`` -> expression + k g(q)
    - diag(kv) q' (or a plain list of expressions of q, q');
  - ``fixed``: {joint (from 1): expression of q, q'}: imposed joint accelerations (velocities);
    the other joints solve the task (joint-space decomposition);
  - ``symbolic``: keep q, q' and the parameters as symbols (default false: numbers at the
    Jacobian's configuration with ``velocity`` q', default rest); ``substitute``: parameter ->
    value applied to the model (e.g. ``{g0: 0}``); ``limits``: {symbol: value} limits of the
    symbolic solution (e.g. ``{w1: oo}``);
  - ``simulate``: ``{duration, step}`` (numeric, objective acceleration): integrates q'' = a(q, q')
    (the robot after feedback linearization, tau = M a + n) from the state.
  Answers: ``<name>`` (q' at velocity level, tau at acceleration level), ``<name>_ddq``,
  ``<name>_pinv`` (J_W^# of the free columns, or A_W^# for the torque objective),
  ``<name>_projector``, ``<name>_target`` (r), ``<name>_drift`` (J' q'), ``<name>_A`` (J M^-1)
  and ``<name>_d`` (r + J M^-1 n) for the torque objective, ``<name>_achieved`` (J q'' + J' q',
  or J q' at velocity level), ``<name>_weights``, ``<name>_limit_<symbol>``; numeric only:
  ``<name>_kkt_gap`` (distance from the minimizer of the optimality conditions), ``<name>_norm``,
  ``<name>_ddq_norm``; with ``simulate``: ``<name>_final_q``, ``<name>_final_dq``,
  ``<name>_final_task_error`` (x_d - f(q) at the end), ``<name>_min_sigma`` (smallest singular
  value of the solved Jacobian along the motion).

Example (2023-02-13#1): ``{kind: dynamic_redundancy, name: tau_C, jacobian: J, task: ddp,
weights: inertia}`` gives tau = M J_M^# p''_d.
"""
from __future__ import annotations

import hashlib
from typing import Dict

import numpy as np
import sympy as sp

from .. import dynamic_redundancy as dr
from ..errors import UserError
from ..latex import mat, num, sig, vec
from ..numeric import compiled_function
from ..steps import to_latex
from . import task
from .context import TaskView, tidy_quotient_matrix

_MODEL_WEIGHTS = ("inertia", "inverse_inertia", "inverse_inertia_squared")


class _Problem:
    """The symbolic pieces of a redundancy problem (robot model, task function, Jacobian) as
    expressions of q and q' (parameters replaced by numbers unless ``symbolic``), and their
    values at a state."""

    def __init__(self, ctx, spec):
        self.ctx, self.spec = ctx, spec
        self.d = TaskView(ctx)
        self.robot = ctx.robot
        self.symbolic = bool(spec.get("symbolic", False))
        ref = spec.get("jacobian", "J")
        obj = self.d.objects.get(ref) if isinstance(ref, str) else None
        if obj is None or obj["sym"] is None or obj["q"] is None:
            raise self.d._fail("dynamic_redundancy.jacobian: name an earlier jacobian task defined on the robot")
        self.J_sym, self.f_sym, self.q0 = obj["sym"], obj["r"], obj["q"]
        self.subs = {sp.Symbol(str(k), real=True): self.expr(v, f"substitute.{k}")
                     for k, v in (spec.get("substitute") or {}).items()}
        n = self.robot.n
        self.dq0 = self.d.array(spec["velocity"], "velocity").reshape(-1) if "velocity" in spec else np.zeros(n)
        if self.dq0.size != n:
            raise self.d._fail(f"dynamic_redundancy.velocity: expected {n} values")
        self.state_symbols = list(self.robot.q) + list(self.robot.dq)
        self.params = {} if self.symbolic else {sp.Symbol(k, real=True): float(v) for k, v in self.d.params.items()}

    # ---------------------------------------------------------------- input
    def fail(self, what: str):
        return self.d._fail(f"dynamic_redundancy.{what}")

    def expr(self, value, where: str):
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            return sp.sympify(value)
        return self.d.expression(value, f"dynamic_redundancy.{where}")

    def vector(self, value, size: int, where: str) -> sp.Matrix:
        """A vector option: a list, a given name, an answer name or one expression -> sympy column."""
        key = value.strip() if isinstance(value, str) else None
        if key in self.ctx.given and isinstance(self.ctx.given[key], list):
            value = self.ctx.given[key]
        elif key in self.ctx.answers:
            value = np.asarray(self.ctx.answers[key], dtype=object).reshape(-1).tolist()
        if not isinstance(value, (list, tuple)):
            value = [value] * size
        if len(value) != size:
            raise self.fail(f"{where}: expected {size} entries, got {len(value)}")
        return sp.Matrix([self.expr(v, where) for v in value])

    def gains(self, value, size: int, where: str, default: str) -> sp.Matrix:
        if value is None:
            value = [f"{default}{i + 1}" for i in range(size)]
        return sp.diag(*self.vector(value, size, where))

    # ---------------------------------------------------------------- evaluation
    def sym(self, X) -> sp.Matrix:
        """X with the exercise's substitutions; numeric mode: every symbol other than q, q' gets
        its number (robot parameters, then the exercise's given values)."""
        X = sp.Matrix(X)
        if self.subs:
            X = X.xreplace(self.subs)
        if self.symbolic:
            return X
        X = X.xreplace(self.params)
        extra = {}
        for s in X.free_symbols - set(self.state_symbols):
            try:
                extra[s] = self.d.number(s.name, s.name)
            except UserError:
                raise self.fail(f"no number for {s.name} (give it, or use symbolic: true)") from None
        return X.xreplace(extra) if extra else X

    def at(self, X, q, dq) -> np.ndarray:
        """Numbers of a ``sym`` expression at a state."""
        state = {s: float(v) for s, v in zip(self.state_symbols, list(q) + list(dq))}
        return np.array(sp.Matrix(X).xreplace(state).evalf(), dtype=float)

    def function(self, X):
        """A compiled numeric function (q, q') -> matrix of a ``sym`` expression."""
        X = sp.Matrix(X)
        tag = "dynamic_redundancy:" + hashlib.sha1(sp.srepr(X).encode()).hexdigest()
        f = compiled_function(self.robot, tag, self.state_symbols, X)
        return lambda q, dq: np.asarray(f(*q, *dq), dtype=float).reshape(X.shape)

    def show(self, X) -> str:
        if self.symbolic:
            return to_latex(sp.Matrix(X), self.robot.coordinates)
        X = np.asarray(X, float)
        return vec(X) if X.ndim == 1 else mat(X)


def _weights(p: _Problem, spec, M):
    """(W as a sym expression or None, its LaTeX)."""
    raw = spec.get("weights")
    if raw is None:
        return None, ""
    n = p.robot.n
    if isinstance(raw, str) and raw in _MODEL_WEIGHTS:
        # from the inertia matrix at the state (numbers), or symbolically
        return raw, {"inertia": "W = M(q)", "inverse_inertia": "W = M^{-1}(q)", "inverse_inertia_squared": "W = M^{-2}(q)"}[raw]
    if isinstance(raw, dict) and "norm_of" in raw:
        exprs = sp.Matrix([p.expr(e, "weights.norm_of") for e in raw["norm_of"]])
        T = exprs.jacobian(sp.Matrix(p.robot.q))
        if any(e.free_symbols & set(p.state_symbols) for e in T):
            raise p.fail("weights.norm_of: the quantities must be linear in the coordinates")
        return p.sym(T.T * T), r"W = T^T T,\ T = " + to_latex(T)
    if isinstance(raw, list) and raw and not isinstance(raw[0], list):
        W = sp.diag(*p.vector(raw, n, "weights"))
    elif isinstance(raw, list):
        W = sp.Matrix([[p.expr(v, "weights") for v in row] for row in raw])
    else:
        raise p.fail("weights: a list, a matrix, inertia, inverse_inertia, inverse_inertia_squared or {norm_of: [...]}")
    if W.shape != (n, n):
        raise p.fail(f"weights: expected {n}x{n}")
    return p.sym(W), "W = " + to_latex(W)


def _preferred(p: _Problem, spec, g):
    raw = spec.get("preferred")
    if raw is None:
        return None
    n = p.robot.n
    if isinstance(raw, (list, str)):
        raw = {"expression": raw}
    if not isinstance(raw, dict):
        raise p.fail("preferred: a list of expressions, a given name or {expression, gravity, damping}")
    x0 = sp.zeros(n, 1)
    if "expression" in raw:
        x0 += p.vector(raw["expression"], n, "preferred.expression")
    if "gravity" in raw:
        x0 += p.expr(raw["gravity"], "preferred.gravity") * g
    if "damping" in raw:
        x0 -= p.gains(raw["damping"], n, "preferred.damping", "kv") * sp.Matrix(p.robot.dq)
    return p.sym(x0)


def _target(p: _Problem, spec, level: str, drift):
    """r of J x = r (a sym expression) and its LaTeX."""
    m = p.J_sym.rows
    r = p.vector(spec.get("task", 0), m, "task")
    tex = r"\ddot x_d" if level == "acceleration" else r"\dot x_d"
    fb = spec.get("feedback")
    if fb is not None:
        if not isinstance(fb, dict):
            raise p.fail("feedback: expected {kp, kd, target, velocity}")
        x_d = p.vector(fb.get("target", [f"x{i + 1}_d" for i in range(m)]), m, "feedback.target")
        r = r + p.gains(fb.get("kp"), m, "feedback.kp", "kp") * (x_d - p.f_sym)
        tex += r" + K_P (x_d - f(q))"
        if level == "acceleration":
            dx_d = p.vector(fb.get("velocity", [0] * m), m, "feedback.velocity")
            r = r + p.gains(fb.get("kd"), m, "feedback.kd", "kd") * (dx_d - p.J_sym * sp.Matrix(p.robot.dq))
            tex += r" + K_D (\dot x_d - J \dot q)"
    r = p.sym(r)
    if level == "acceleration":
        r = r - drift
        tex += r" - \dot J \dot q"
    return r, tex


class _Pieces:
    """Everything the resolution needs, as sym expressions of (q, q')."""

    def __init__(self, p: _Problem, spec, ctx):
        robot = p.robot
        self.level = spec.get("level", "acceleration")
        if self.level not in ("velocity", "acceleration"):
            raise p.fail("level: velocity or acceleration")
        self.objective = spec.get("objective", "acceleration")
        if self.objective not in ("acceleration", "torque"):
            raise p.fail("objective: acceleration or torque")
        self.J = p.sym(p.J_sym)
        dq = sp.Matrix(robot.dq)
        self.drift = p.sym(sum((p.J_sym.diff(qk) * dqk for qk, dqk in zip(robot.q, robot.dq)), sp.zeros(*p.J_sym.shape)) * dq)
        self.M = self.n = self.g = None
        if self.level == "acceleration" or spec.get("weights") in _MODEL_WEIGHTS:
            dyn = ctx.dynamics()
            self.M = p.sym(dyn.M)
            self.n = p.sym(dyn.c + dyn.g + dyn.spring + dyn.friction)
            self.g = p.sym(dyn.g + dyn.spring)
        self.r, self.r_tex = _target(p, spec, self.level, self.drift if self.level == "acceleration" else None)
        self.W, self.W_tex = _weights(p, spec, self.M)
        self.x0 = _preferred(p, spec, self.g)
        self.fixed = {}
        for k, v in (spec.get("fixed") or {}).items():
            i = int(k) - 1
            if not 0 <= i < robot.n:
                raise p.fail(f"fixed: joint {k} does not exist")
            self.fixed[i] = p.sym(sp.Matrix([p.expr(v, f"fixed.{k}")]))[0, 0]
        self.fixed_values = sp.Matrix(list(self.fixed.values()))

    @staticmethod
    def model_weight(kind, M, inv):
        """W = M, M^-1 or M^-2 (``inv`` inverts a matrix of the right kind)."""
        if kind == "inertia":
            return M
        Mi = inv(M)
        return Mi if kind == "inverse_inertia" else Mi * Mi if isinstance(Mi, sp.MatrixBase) else Mi @ Mi

    def numeric(self, p: _Problem, q, dq, evaluate=None):
        """The resolution at a state (numbers): ``evaluate`` maps a sym expression to numbers."""
        ev = evaluate or (lambda X: p.at(X, q, dq))
        J = ev(self.J)
        r = ev(self.r).reshape(-1)
        x0 = ev(self.x0).reshape(-1) if self.x0 is not None else None
        fixed = dict(zip(self.fixed, ev(self.fixed_values).reshape(-1))) if self.fixed else {}
        M = ev(self.M) if self.M is not None else None
        nv = ev(self.n).reshape(-1) if self.n is not None else None
        if isinstance(self.W, str):
            W = self.model_weight(self.W, M, lambda X: dr._inv(X, False))
        else:
            W = ev(self.W) if self.W is not None else None
        if self.level == "velocity":
            sol = dr.minimum_weighted_norm(J, r, W, x0, fixed)
            return J, r, W, x0, M, nv, dr.TorqueSolution(sol.x, None, sol)
        return J, r, W, x0, M, nv, dr.resolve_torque(J, r, M, nv, self.objective, W, x0, fixed)

    def symbolic(self):
        if isinstance(self.W, str):
            self.W = self.model_weight(self.W, self.M, lambda X: dr._inv(X, True))
        if self.level == "velocity":
            sol = dr.minimum_weighted_norm(self.J, self.r, self.W, self.x0, self.fixed)
            return dr.TorqueSolution(sol.x, None, sol)
        return dr.resolve_torque(self.J, self.r, self.M, self.n, self.objective, self.W, self.x0, self.fixed)


def _compact(X):
    """Symbolic results keep the structure of their formula (as written by hand): common factors
    are pulled out, nothing is expanded."""
    return sp.Matrix(X).applyfunc(sp.factor_terms)


@task("dynamic_redundancy")
def dynamic_redundancy_task(ctx, spec):
    """Redundancy resolution at velocity, acceleration or torque level (see the module docstring)."""
    p = _Problem(ctx, spec)
    robot = p.robot
    name = spec.get("name", "tau")
    P = _Pieces(p, spec, ctx)
    level, objective = P.level, P.objective
    torque_level = level == "acceleration" and objective == "torque"
    try:
        if p.symbolic:
            res = P.symbolic()
            J, r, drift, W = P.J, P.r, P.drift, P.W
            tidy = _compact
        else:
            J, r, W, x0, M, nv, res = P.numeric(p, p.q0, p.dq0)
            drift = p.at(P.drift, p.q0, p.dq0).reshape(-1)
            tidy = lambda X: np.asarray(X, float)
    except (dr.DynamicRedundancyError, ValueError, ZeroDivisionError) as exc:
        raise p.fail(str(exc)) from None
    conf = {c: float(v) for c, v in zip(robot.coordinates, p.q0)} if not p.symbolic else {}
    x_tex = r"\dot q" if level == "velocity" else r"\ddot q"
    ctx.step("Task constraint", rf"J(q)\,{x_tex} = r,\quad r = {P.r_tex} = {p.show(tidy(r))}",
             (r"Differentiate the task twice: $\ddot x = J \ddot q + \dot J \dot q$." if level == "acceleration"
              else r"First-order differential kinematics $\dot x = J \dot q$.")
             + (" Feedback on the task error recovers it exponentially." if "feedback" in spec else ""),
             configuration=conf)
    if W is not None:
        ctx.step("Weight of the norm", P.W_tex + ("" if p.symbolic else " = " + mat(W)),
                 "The norm minimized is that of the joint "
                 + ("torques." if torque_level else ("velocities." if level == "velocity" else "accelerations.")))
    sol = res.solution
    if torque_level:
        ctx.step("Task in the torques", rf"A = J M^{{-1}} = {p.show(tidy(res.A))},\quad A\tau = r + A n = d = {p.show(tidy(res.d))}",
                 r"Substitute $\ddot q = M^{-1} (\tau - n)$: the task becomes linear in the torques.")
        ctx.answer(f"{name}_A", tidy(res.A))
        ctx.answer(f"{name}_d", tidy(res.d))
    pinv_tex = r"A_W^\#" if torque_level else r"J_W^\#"
    ctx.step("Weighted pseudoinverse", rf"{pinv_tex} = W^{{-1}} (\cdot)^T ((\cdot) W^{{-1}} (\cdot)^T)^{{-1}} = {p.show(tidy(sol.pinv))}",
             "Pseudoinverse of the columns of the free joints; the imposed ones move to the task side."
             if P.fixed else "The minimizer of the weighted norm among all solutions (full row rank).")
    if P.x0 is not None:
        ctx.step("Null-space term", rf"(I - {pinv_tex}(\cdot))\,x_0 = {p.show(tidy(sol.homogeneous))}",
                 "The preferred motion projected so that it does not disturb the task.")
    if level == "velocity":
        main = tidy(res.ddq)
        ctx.step("Joint velocity", rf"\dot q = {p.show(main)}", "", configuration=conf)
        ctx.answer(name, main)
        ctx.answer(f"{name}_achieved", _achieved(p, J, res.ddq, r, None))
    else:
        ddq, main = tidy(res.ddq), tidy(res.tau)
        ctx.step("Joint acceleration and torque", rf"\ddot q = {p.show(ddq)},\quad \tau = M\ddot q + n = {p.show(main)}",
                 "The torque that produces this acceleration with the full model.", configuration=conf,
                 joints=[b.name for b in robot.bodies])
        ctx.answer(name, main)
        ctx.answer(f"{name}_ddq", ddq)
        ctx.answer(f"{name}_drift", tidy(drift))
        ctx.answer(f"{name}_achieved", _achieved(p, J, res.ddq, r, drift))
    ctx.answer(f"{name}_pinv", tidy(sol.pinv))
    ctx.answer(f"{name}_projector", tidy(sol.projector))
    ctx.answer(f"{name}_target", tidy(r))
    if W is not None:
        ctx.answer(f"{name}_weights", tidy(W))
    if p.symbolic:
        _limits(p, spec, name, main)
        return
    _numeric_checks(p, name, level, objective, J, r, M, nv, W, x0, res, P.fixed)
    if spec.get("simulate"):
        _simulate(p, P, spec["simulate"], name)


def _achieved(p: _Problem, J, x, r, drift):
    """J x (+ J' q'): what the joints produce in the task. Numbers are computed; a symbolic result
    is checked at random numeric points against r (+ J' q'), which it equals when J has full row
    rank, instead of simplifying a large expression."""
    if not p.symbolic:
        return J @ x + (drift if drift is not None else 0)
    zero = sp.zeros(J.rows, 1)
    out = J * x + (drift if drift is not None else zero)
    claim = r + (drift if drift is not None else zero)
    gap = out - claim
    rng = np.random.default_rng(11)
    syms = sorted(gap.free_symbols, key=lambda s: s.name)
    for _ in range(5):
        point = {s: float(rng.uniform(0.3, 1.3)) for s in syms}
        size = 1 + np.abs(np.array(claim.xreplace(point).evalf(), dtype=float)).max()
        if np.abs(np.array(gap.xreplace(point).evalf(), dtype=float)).max() > 1e-8 * size:
            return _compact(out)          # not the task (e.g. a rank-deficient J): leave it whole
    return claim.applyfunc(sp.expand)


def _limits(p: _Problem, spec, name: str, value):
    for key, target in (spec.get("limits") or {}).items():
        s = sp.Symbol(str(key), real=True)
        to = sp.oo if str(target) in ("oo", "inf") else p.expr(target, f"limits.{key}")
        out = tidy_quotient_matrix(sp.Matrix(value).applyfunc(lambda e: sp.limit(e, s, to)))
        p.ctx.step(f"Limit for ${sp.latex(s)} \\to {sp.latex(to)}$", rf"\lim_{{{sp.latex(s)} \to {sp.latex(to)}}} = {p.show(out)}", "")
        p.ctx.answer(f"{name}_limit_{key}", out)


def _numeric_checks(p, name, level, objective, J, r, M, nvec, W, x0, res, fixed: Dict):
    ctx = p.ctx
    n = p.robot.n
    ctx.answer(f"{name}_norm", float(np.linalg.norm(res.tau if level == "acceleration" else res.ddq)))
    if level == "acceleration":
        ctx.answer(f"{name}_ddq_norm", float(np.linalg.norm(res.ddq)))
    if fixed or np.linalg.matrix_rank(J) < J.shape[0]:
        return
    Wm = np.eye(n) if W is None else np.asarray(W, float)
    x0v = np.zeros(n) if x0 is None else np.asarray(x0, float).reshape(-1)
    if level == "acceleration" and objective == "torque":
        # min 1/2 (M q'' + n - tau_0)^T W (M q'' + n - tau_0) over q''
        best = M @ dr.kkt_minimizer(J, r, M.T @ Wm @ M, M.T @ Wm @ (nvec - x0v)) + nvec
        gap = float(np.linalg.norm(best - res.tau))
    else:
        gap = float(np.linalg.norm(dr.kkt_minimizer(J, r, Wm, -Wm @ x0v) - res.ddq))
    ctx.step("Optimality check", rf"\|x - x_{{KKT}}\| {_gap(gap)}",
             "The closed form coincides with the minimizer from the optimality conditions of the constrained problem.")
    ctx.answer(f"{name}_kkt_gap", gap)


def _simulate(p: _Problem, P: _Pieces, opts, name: str):
    """Integrate q'' = a(q, q') (classic Runge-Kutta) from the task's state."""
    if P.level != "acceleration" or P.objective != "acceleration":
        raise p.fail("simulate: needs level acceleration with objective acceleration (q'' = a after feedback linearization)")
    if not isinstance(opts, dict):
        opts = {}
    T = p.d.number(opts.get("duration", 5.0), "simulate.duration")
    h = p.d.number(opts.get("step", 0.005), "simulate.step")
    if not (0 < h <= T) or T / h > 20000:
        raise p.fail("simulate: need 0 < step <= duration and at most 20000 steps")
    funcs = {}

    def evaluate(X, q, dq):
        key = id(X)
        if key not in funcs:
            funcs[key] = p.function(X)
        return funcs[key](q, dq)

    free = [j for j in range(p.robot.n) if j not in P.fixed]
    sigma = [np.inf]

    def accel(q, dq):
        J, *_rest, res = P.numeric(p, q, dq, evaluate=lambda X: evaluate(X, q, dq))
        sigma[0] = min(sigma[0], float(np.linalg.svd(J[:, free], compute_uv=False).min()))
        return res.ddq

    q, dq = np.array(p.q0, float), np.array(p.dq0, float)
    for _ in range(int(round(T / h))):
        k1q, k1v = dq, accel(q, dq)
        k2q, k2v = dq + h / 2 * k1v, accel(q + h / 2 * k1q, dq + h / 2 * k1v)
        k3q, k3v = dq + h / 2 * k2v, accel(q + h / 2 * k2q, dq + h / 2 * k2v)
        k4q, k4v = dq + h * k3v, accel(q + h * k3q, dq + h * k3v)
        q = q + h / 6 * (k1q + 2 * k2q + 2 * k3q + k4q)
        dq = dq + h / 6 * (k1v + 2 * k2v + 2 * k3v + k4v)
    fb = p.spec.get("feedback") or {}
    m = p.J_sym.rows
    x_d = p.sym(p.vector(fb.get("target", [0] * m), m, "feedback.target"))
    err = (evaluate(x_d - p.sym(p.f_sym), q, dq)).reshape(-1)
    p.ctx.step("Simulated motion", rf"t = {num(T)}:\ q = {vec(q)},\ \dot q = {vec(dq)},\ x_d - f(q) = {vec(err)}",
               rf"$\ddot q = a(q, \dot q)$ integrated with step {num(h)} s; smallest singular value of the solved "
               f"Jacobian along the way {num(sigma[0])} (no singularity when it stays away from 0).",
               configuration={c: float(v) for c, v in zip(p.robot.coordinates, q)})
    p.ctx.answer(f"{name}_final_q", q)
    p.ctx.answer(f"{name}_final_dq", dq)
    p.ctx.answer(f"{name}_final_task_error", err)
    p.ctx.answer(f"{name}_min_sigma", sigma[0])


def _gap(gap: float) -> str:
    """The optimality gap for display: round-off (below 1e-9) shown as such, not as noise digits."""
    return r"\le 10^{-9}" if gap < 1e-9 else "= " + sig(gap, 2)
