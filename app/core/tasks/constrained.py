"""Constrained robots: reduced dynamics with pseudo-velocities, the constraint multiplier and hybrid
force/velocity laws (algebra in ``app.core.constraints``).

``reduced_dynamics``: holonomic constraint(s) h(q) = 0 on the robot's model M q'' + n = S u + A^T lambda.
  Constraint: ``constraint`` (an expression or a list); it may use ``px, py, pz`` of ``point`` (a
  named point or ``{body, at}``) and ``phi_<body>`` (the absolute angle of a link of a planar
  robot). Completion: ``D`` (rows completing A = dh/dq; pseudo-velocity v = D q') or
  ``pseudo_velocity: {point, direction}`` (v = speed of a point along a direction). Model:
  ``inertia: generic`` replaces M and n by symbols m_ij (symmetric) and n_i (results written
  with the entries of an unspecified inertia matrix); ``passive`` (unactuated coordinates);
  ``numeric_data`` (the exercise's numbers that are not robot parameters substituted after A(q));
  ``substitute`` (values of symbols of the constraint and of D, e.g. a special angle);
  ``suffix`` (appended to every answer name); ``multiplier: false`` leaves out the constraint force (lambda, lambda_v, A_pinv, P: costly
  with several constraints).
  Options for the answers: ``on_constraint: {solve_for: [coordinates]}`` (the coordinates
  eliminated by solving h = 0, with q' = F v: the model on the constraint and at rest there);
  ``hybrid`` (true, or ``{dv: [...], lambda: [...]}`` values of the commanded pseudo-acceleration
  and multiplier: the decoupling input); ``zero_force_inputs`` (inputs solved from lambda = 0);
  ``outer`` (pseudo-acceleration name -> expression, substituted in ``u_reduced``);
  ``min_norm`` (true, or values of the pseudo-accelerations: the smallest-norm input of the
  reduced model, and the inputs of each group of reduced equations that share no input); ``minimum_time: {row, length, bounds}`` (rest-to-rest
  bang-bang time along one decoupled pseudo-coordinate with bounded inputs); ``evaluate``
  (answers at one state: ``state``, or ``place: {point, at, guess}``, with ``dv`` or
  ``timing: {profile: cubic|quintic, length, duration, t}``).
  Answers: ``h``, ``A``, ``A_dot``, ``A_pinv`` (A#_M = M^-1 A^T (A M^-1 A^T)^-1), ``P``
  (I - A^T A#^T), ``lambda`` (the multiplier as a function of q, q', u: inputs u1..), ``D``,
  ``det_AD``, ``v``, ``v_dot`` (D q'' + D' q'), ``D_dot``, ``E``, ``F``, ``F_dot``, ``M_v``
  (F^T M F), ``M_F``, ``n_v`` (F^T (n - M (E A' + F D') q')), ``B_v`` (F^T S; M_v v' + n_v = B_v u),
  ``EMF`` (E^T M F), ``E_n`` (E^T n), ``E_S`` (E^T S), ``lambda_v`` (E^T (M (F v' + F' v) + n - S u)),
  ``qdd`` (F v' - (E A' + F D') q'), ``u_track`` (M q'' + n: v' with lambda = 0 when all joints are
  actuated), ``u_reduced`` ((F^T S)^-1 (M_v v' + n_v) over the inputs that enter the reduced model, when
  they are as many as the pseudo-velocities), ``u_reduced_outer``, on the constraint
  ``n_v_on``, ``lambda_v_on``, ``u_track_on``, ``dv_rest``, ``lambda_rest``, ``u_rest`` (the rest
  input with lambda = 0), with ``hybrid`` ``u_hybrid``, ``dv_hybrid`` and ``lambda_hybrid`` (v'
  and lambda of the model under u_hybrid, recomputed), ``u_zero_lambda``, ``u_min_norm``,
  ``u_group<k>`` (inputs of the k-th group of reduced equations), ``a_max``, ``T_min``, and with
  ``evaluate`` ``q_at``, ``M_at``, ``g_at``, ``F_at``, ``u_track_at``, ``u_reduced_at``,
  ``Delta``, ``dv_at``.

Example (2013-02-06#1, an RP end-effector on the line x = k, regulation of the tangent velocity and
of the normal force):

    - kind: reduced_dynamics
      point: ee
      constraint: "px - k"
      D: ["q2*cos(q1)", "sin(q1)"]
      hybrid: true
"""
from __future__ import annotations

from typing import Dict, List

import numpy as np
import sympy as sp

from .. import constraints as con
from .. import jacobians as jac
from ..errors import UserError
from ..exercise import ExerciseError
from ..expressions import ExpressionError, parse_expression, symbol
from ..kinematics import Kinematics
from ..mathtext import symbols_text
from ..numeric import numeric_function
from ..steps import to_latex
from . import task
from .context import TaskView
from .underactuated import _PROFILES, _given_values, _inverse

def _point_position(m: TaskView, point, where: str) -> sp.Matrix:
    try:
        body, local = jac.point_location(m.robot, point)
    except UserError as exc:
        raise ExerciseError(f"{where}: {exc}") from None
    return Kinematics(m.robot).point_position(body, local)


_PSEUDO = ["v"] + [f"v{i}" for i in range(1, 10)]


def _L(m: TaskView, expr) -> str:
    """LaTeX with the pseudo-velocities dotted like the coordinates (dv1 -> v'_1)."""
    return to_latex(expr, list(m.coords) + _PSEUDO)


def _names(prefix: str, count: int) -> List[sp.Symbol]:
    return [symbol(prefix)] if count == 1 else [symbol(f"{prefix}{i + 1}") for i in range(count)]


def _constraint(ctx, m: TaskView, spec) -> sp.Matrix:
    extra = {}
    if spec.get("point"):
        pos = _point_position(m, spec["point"], "reduced_dynamics.point")
        extra = {"px": pos[0], "py": pos[1], "pz": pos[2]}
    if m.robot.is_planar:
        extra.update({f"phi_{b.name}": jac.planar_angle(m.robot, b.name) for b in m.robot.bodies})
    raw = spec.get("constraint")
    if raw is None:
        raise ExerciseError("reduced_dynamics.constraint: give h(q) = 0 (an expression or a list)")
    raw = raw if isinstance(raw, list) else [raw]
    try:
        return m.tidy_matrix(sp.Matrix([parse_expression(c, extra=extra) for c in raw]))
    except ExpressionError as exc:
        raise ExerciseError(f"reduced_dynamics.constraint: {exc}") from None


def _completion_rows(ctx, m: TaskView, spec, data) -> sp.Matrix:
    if "D" in spec:
        rows = spec["D"]
        rows = rows if rows and isinstance(rows[0], list) else [rows]
        return sp.Matrix([[ctx.expr(e, "reduced_dynamics.D") for e in row] for row in rows]).subs(data)
    if "pseudo_velocity" in spec:
        pv = spec["pseudo_velocity"]
        if not isinstance(pv, dict) or "direction" not in pv:
            raise ExerciseError("reduced_dynamics.pseudo_velocity: expected {point: NAME, direction: [x, y, z]}")
        pos = _point_position(m, pv.get("point", spec.get("point")), "reduced_dynamics.pseudo_velocity.point")
        d = [ctx.expr(e, "reduced_dynamics.pseudo_velocity.direction").subs(data) for e in pv["direction"]]
        d = sp.Matrix(d + [0] * (3 - len(d)))
        return m.tidy_matrix((d.T / sp.sqrt((d.T * d)[0])) * pos.jacobian(m.q))
    return None


class _Suffixed:
    """The task context with a suffix on every answer name (several constrained models in one exercise)."""

    def __init__(self, ctx, suffix: str):
        self._ctx, self._suffix = ctx, suffix

    def answer(self, name, value):
        self._ctx.answer(name + self._suffix, value)

    def __getattr__(self, name):
        return getattr(self._ctx, name)


@task("reduced_dynamics")
def reduced_dynamics_task(ctx, spec):
    """Dynamics under holonomic constraints (see the module docstring)."""
    if spec.get("suffix"):
        ctx = _Suffixed(ctx, str(spec["suffix"]))
    m = TaskView(ctx)
    n = len(m.coords)
    generic = spec.get("inertia") == "generic"
    if spec.get("inertia") not in (None, "generic", "robot"):
        raise ExerciseError("reduced_dynamics.inertia: 'generic' or 'robot'")
    M, nvec = con.generic_inertia(n, symbol) if generic else (m.M, m.n)
    subs = {symbol(k_): ctx.expr(v, f"reduced_dynamics.substitute.{k_}") for k_, v in (spec.get("substitute") or {}).items()}
    h = m.tidy_matrix(_constraint(ctx, m, spec).xreplace(subs))
    k = h.rows
    A = m.tidy_matrix(h.jacobian(m.q))
    if all(con.is_zero(e) for e in A):
        raise ExerciseError("reduced_dynamics.constraint: h does not depend on the coordinates")
    A_dot = m.tidy_matrix(con.time_derivative(A, m.q, m.dq))
    passive = m.indices(spec["passive"], "reduced_dynamics.passive") if "passive" in spec else \
        [i for i, a in enumerate(m.robot.actuated) if not a]
    actuated = [i not in passive for i in range(n)]
    S = m.selection(actuated)
    u = sp.Matrix([symbol(f"u{i + 1}") for i in range(S.cols)])
    hb = m.bodies_of(range(n))
    ctx.step("Constraint", rf"h(q) = {_L(m, h)} = 0,\quad A(q) = \frac{{\partial h}}{{\partial q}} = {_L(m, A)},\quad "
             rf"\dot A = {_L(m, A_dot)}",
             r"The constraint holds at all times, so $A(q)\, \dot q = 0$ and $A \ddot q + \dot A \dot q = 0$.", bodies=hb)
    for name, value in (("h", h), ("A", A), ("A_dot", A_dot)):
        ctx.answer(name, value)
    data = {}
    if spec.get("numeric_data"):
        data = {k_: sp.nsimplify(v, rational=True) for k_, v in _given_values(ctx).items()
                if k_.name not in m.robot.parameters}
        A, A_dot = A.subs(data), A_dot.subs(data)
        ctx.step("Numbers of the constraint", rf"A(q) = {_L(m, A)}",
                 f"The data of the constraint ({symbols_text(s_.name for s_ in data)}) are substituted from here on.")
    if generic:
        ctx.step("Inertia written with its entries", rf"M = {_L(m, M)},\quad n = {_L(m, nvec)}",
                 "The entries of the unconstrained model are kept as symbols.")
    if spec.get("multiplier", True):
        _multiplier(ctx, m, M, nvec, S, u, A, A_dot, spec)
    D = _completion_rows(ctx, m, spec, data)
    if D is not None and subs:
        D = m.tidy_matrix(D.xreplace(subs))
    if D is None:
        return
    terms = _pseudo_velocities(ctx, m, spec, M, nvec, S, u, A, A_dot, D, hb)
    if spec.get("outer"):
        _outer(ctx, m, spec["outer"], terms)
    if spec.get("on_constraint"):
        _on_constraint(ctx, m, spec["on_constraint"], h, terms)
    if spec.get("hybrid"):
        _hybrid(ctx, m, spec["hybrid"], terms, actuated)
    if spec.get("min_norm") or spec.get("minimum_time"):
        _input_distribution(ctx, m, spec, terms)
    if spec.get("evaluate"):
        _evaluate_reduced(ctx, m, spec["evaluate"], terms)


def _multiplier(ctx, m, M, nvec, S, u, A, A_dot, spec):
    n = len(m.coords)
    adj, det_M = M.adjugate(), M.det()
    AMA_inv = _inverse((A * adj * A.T).applyfunc(sp.expand))
    A_pinv = m.tidy_matrix(adj * A.T * AMA_inv)
    P = m.tidy_matrix(sp.eye(n) - A.T * A_pinv.T)
    lam = m.tidy_matrix(-AMA_inv * (A * adj * (S * u - nvec) + det_M * A_dot * m.dq))
    ctx.step("Multiplier and projection",
             rf"M\ddot q + n = S u + A^T\lambda,\quad A^\#_M = M^{{-1}}A^T(AM^{{-1}}A^T)^{{-1}} = {_L(m, A_pinv)},\quad "
             rf"\lambda = {_L(m, lam)}",
             "Solve for the constraint force; substituting it gives the dynamically consistent "
             r"projection $M \ddot q = (I - A^T A^{\#T}_M)(S u - n) - M A^\#_M \dot A \dot q$.")
    ctx.answer("A_pinv", A_pinv)
    ctx.answer("P", P)
    ctx.answer("lambda", lam)
    zero = spec.get("zero_force_inputs")
    if zero:
        names = [zero] if isinstance(zero, str) else list(zero)
        unknowns = [symbol(x) for x in names]
        if any(x not in list(u) for x in unknowns) or len(unknowns) != lam.rows:
            raise ExerciseError(f"reduced_dynamics.zero_force_inputs: {lam.rows} of the inputs "
                                f"{', '.join(str(x) for x in u)}")
        sol = sp.solve(list(lam), unknowns, dict=True)
        if len(sol) != 1:
            raise ExerciseError("reduced_dynamics.zero_force_inputs: lambda = 0 does not fix these inputs")
        values = sp.Matrix([m.tidy(sol[0][x]) for x in unknowns])
        ctx.answer("u_zero_lambda", values)
        ctx.step("Inputs that need no constraint force",
                 rf"\lambda = 0 \iff {_L(m, sp.Matrix(unknowns))} = {_L(m, values)}",
                 "The multiplier is linear in the inputs: solved for the chosen ones.")


def _pseudo_velocities(ctx, m, spec, M, nvec, S, u, A, A_dot, D, hb):
    k = A.rows
    n = len(m.coords)
    try:
        E, F, det = con.completion(A, D, m.tidy)
    except con.ConstraintError as exc:
        raise ExerciseError(f"reduced_dynamics.D: {exc}") from None
    D_dot = m.tidy_matrix(con.time_derivative(D, m.q, m.dq))
    F_dot = m.tidy_matrix(con.time_derivative(F, m.q, m.dq))
    v = sp.Matrix(_names("v", n - k))
    dv = sp.Matrix(_names("dv", n - k))
    W = E * A_dot + F * D_dot
    M_F = m.tidy_matrix(M * F)
    M_v = m.tidy_matrix(F.T * M_F)
    n_v = m.tidy_matrix(F.T * (nvec - M * W * m.dq))
    B_v = m.tidy_matrix(F.T * S)
    qdd = m.tidy_matrix(F * dv - W * m.dq)
    u_track = m.tidy_matrix(M * qdd + nvec)
    with_force = spec.get("multiplier", True)
    lam_v = m.tidy_matrix(E.T * (M * (F * dv + F_dot * v) + nvec - S * u)) if with_force else None
    ctx.step("Pseudo-velocities", rf"v = D(q)\dot q = {_L(m, D * m.dq)},\quad \begin{{pmatrix}}A\\ D\end{{pmatrix}}^{{-1}} = "
             rf"\begin{{pmatrix}}E & F\end{{pmatrix}} = {_L(m, E.row_join(F))}",
             rf"The completion is nonsingular where $\det \begin{{pmatrix}}A\\ D\end{{pmatrix}} = {_L(m, det)}$ is not zero; "
             r"then $\dot q = F(q)\, v$ and $\ddot q = F \dot v + \dot F v$.",
             bodies=hb)
    ctx.step("Reduced dynamics", rf"F^T M F\,\dot v + F^T\left(n - M(E\dot A + F\dot D)\dot q\right) = F^T S u,\quad "
             rf"F^T M F = {_L(m, M_v)},\quad F^T S = {_L(m, B_v)}",
             r"Premultiplying by $F^T$ removes the constraint force ($F^T A^T = 0$): "
             f"{n - k} equation(s) in the pseudo-velocities.", bodies=hb)
    if with_force:
        ctx.step("Constraint force", rf"\lambda = E^T\left(M(F\dot v + \dot F v) + n - S u\right) = {_L(m, lam_v)}",
                 r"Premultiplying the constrained model by $E^T$ ($A E = I$) isolates the multiplier.")
    ctx.step("Input for a desired pseudo-acceleration", rf"u = M(q)\left(F\dot v - (E\dot A + F\dot D)\dot q\right) + n = {_L(m, u_track)}",
             r"With every joint actuated this input realizes $\dot v$ and needs no constraint force ($\lambda = 0$).",
             joints=hb)
    answers = {"D": D, "det_AD": det, "v": m.tidy_matrix(D * m.dq), "v_dot": m.tidy_matrix(D * m.ddq + D_dot * m.dq),
               "D_dot": D_dot, "E": E, "F": F, "F_dot": F_dot, "M_v": M_v, "M_F": M_F, "n_v": n_v, "B_v": B_v,
               "EMF": m.tidy_matrix(E.T * M_F), "E_n": m.tidy_matrix(E.T * nvec), "E_S": E.T * S,
               "lambda_v": lam_v, "qdd": qdd, "u_track": u_track}
    for name, value in answers.items():
        if value is not None:
            ctx.answer(name, value)
    terms = dict(A=A, D=D, E=E, F=F, F_dot=F_dot, M=M, n=nvec, S=S, u=u, v=v, dv=dv, M_v=M_v, n_v=n_v, B_v=B_v,
                 u_track=u_track, lam_v=lam_v, u_reduced=None,
                 g=(m.dyn.g + m.dyn.spring) if M is m.M else None)
    cols = [j for j in range(B_v.cols) if any(B_v[i, j] != 0 for i in range(B_v.rows))]
    if len(cols) == B_v.rows:      # the inputs that enter the reduced model fix v' one to one
        u_red = m.tidy_matrix(_inverse(B_v.extract(list(range(B_v.rows)), cols)) * (M_v * dv + n_v))
        names = _L(m, sp.Matrix([u[j] for j in cols]))
        ctx.step("Input of the reduced model", rf"{names} = (F^T S)^{{-1}}\left(F^T M F\,\dot v + n_v\right) = {_L(m, u_red)}",
                 r"The inputs that give the pseudo-acceleration $\dot v$ along the constraint (the constraint force does the rest).")
        ctx.answer("u_reduced", u_red)
        terms["u_reduced"] = u_red
    return terms


def _outer(ctx, m, spec, t):
    """Outer-loop pseudo-accelerations substituted in the input of the reduced model."""
    if t["u_reduced"] is None:
        raise ExerciseError("reduced_dynamics.outer: needs a square F^T S (as many inputs as pseudo-velocities)")
    names = {d.name: d for d in t["dv"]}
    if not isinstance(spec, dict) or not set(spec) <= set(names):
        raise ExerciseError(f"reduced_dynamics.outer: a mapping from {', '.join(names)} to expressions")
    subs = {names[k]: ctx.expr(v, f"reduced_dynamics.outer.{k}") for k, v in spec.items()}
    u_out = m.tidy_matrix(t["u_reduced"].xreplace(subs))
    ctx.answer("u_reduced_outer", u_out)
    ctx.step("With the outer loops", rf"{_L(m, sp.Matrix(list(subs)))} = {_L(m, sp.Matrix(list(subs.values())))}:\quad u = {_L(m, u_out)}",
             "Feedback linearization of the reduced model: each pseudo-acceleration follows its own linear loop.")


def _on_constraint(ctx, m, spec, h, t):
    """The model on the constraint: eliminated coordinates and q' = F v."""
    names = spec.get("solve_for") if isinstance(spec, dict) else None
    if not names:
        raise ExerciseError("reduced_dynamics.on_constraint: give solve_for: [coordinates to eliminate]")
    idx = m.indices(names, "reduced_dynamics.on_constraint.solve_for")
    try:
        pos = con.solve_linear_constraints(h, [m.q[i] for i in idx])
    except con.ConstraintError as exc:
        raise ExerciseError(f"reduced_dynamics.on_constraint: {exc}") from None
    vel = dict(zip(m.dq, t["F"] * t["v"]))

    def on(x):
        return m.tidy_matrix(sp.Matrix(x).xreplace(vel).xreplace(pos))
    rest = {**{d: 0 for d in m.dq}, **{v_: 0 for v_ in t["v"]}, **{d: 0 for d in t["dv"]}}
    if t["lam_v"] is None:
        raise ExerciseError("reduced_dynamics.on_constraint: needs the constraint force (multiplier: true)")
    out = {"n_v_on": on(t["n_v"]), "lambda_v_on": on(t["lam_v"]), "u_track_on": on(t["u_track"])}
    dv_rest = m.tidy_matrix(_inverse(t["M_v"]) * (t["B_v"] * t["u"] - t["n_v"])).xreplace(rest).xreplace(pos)
    out["dv_rest"] = m.tidy_matrix(dv_rest)
    out["lambda_rest"] = m.tidy_matrix(t["lam_v"].xreplace(rest).xreplace(pos))
    out["u_rest"] = m.tidy_matrix(t["u_track"].xreplace(rest).xreplace(pos))
    for name, value in out.items():
        ctx.answer(name, value)
    subs = ", ".join(f"${_L(m, k)} = {_L(m, v)}$" for k, v in pos.items())
    ctx.step("On the constraint", rf"{_L(m, sp.Matrix(list(pos)))} = {_L(m, sp.Matrix(list(pos.values())))},\quad "
             rf"\dot q = F v:\quad F^T M F\,\dot v + {_L(m, out['n_v_on'])} = F^T S u,\quad \lambda = {_L(m, out['lambda_v_on'])}",
             f"The constraint eliminates {subs}; the velocity terms that the constraint forbids vanish.")
    ctx.step("At rest on the constraint", rf"\dot v = {_L(m, out['dv_rest'])},\quad \lambda = {_L(m, out['lambda_rest'])},\quad "
             rf"u_{{\lambda = 0}} = {_L(m, out['u_rest'])}",
             r"Static equilibrium needs $\dot v = 0$: a family of inputs, each with its constraint force; "
             r"$\lambda = 0$ for the gravity torque alone.")


def _hybrid(ctx, m, spec, t, actuated):
    if not all(actuated):
        raise ExerciseError("reduced_dynamics.hybrid: the decoupling input needs every coordinate actuated")
    if t["lam_v"] is None:
        raise ExerciseError("reduced_dynamics.hybrid: needs the constraint force (multiplier: true)")
    k = t["A"].rows
    a = sp.Matrix(_names("a_v", t["v"].rows))
    b = sp.Matrix(_names("a_lambda", k))
    if isinstance(spec, dict):
        if "dv" in spec:
            a = sp.Matrix([ctx.expr(x, "reduced_dynamics.hybrid.dv") for x in spec["dv"]])
        if "lambda" in spec:
            b = sp.Matrix([ctx.expr(x, "reduced_dynamics.hybrid.lambda") for x in spec["lambda"]])
    F_dot_v = t["F_dot"] * t["v"]
    u_h = m.tidy_matrix(con.hybrid_input(t["M"], t["n"], t["A"], t["F"], F_dot_v, a, b))
    sub = dict(zip(t["u"], u_h))
    dv_h = m.tidy_matrix(_inverse(t["M_v"]) * (t["B_v"] * u_h - t["n_v"]).xreplace(dict(zip(m.dq, t["F"] * t["v"]))))
    lam_h = m.tidy_matrix(t["lam_v"].xreplace(sub).xreplace(dict(zip(t["dv"], a))))
    ctx.answer("u_hybrid", u_h)
    ctx.answer("dv_hybrid", dv_h)
    ctx.answer("lambda_hybrid", lam_h)
    ctx.step("Decoupling input (hybrid force and velocity control)",
             rf"u = M(F a_v + \dot F v) + n - A^T a_\lambda = {_L(m, u_h)}\ \Rightarrow\ \dot v = {_L(m, dv_h)},\ \lambda = {_L(m, lam_h)}",
             "Substituted in the reduced model and in the multiplier, the input gives the commanded "
             "pseudo-acceleration and constraint force independently (outer loops close on each).",
             joints=m.bodies_of(range(len(m.coords))))


def _input_distribution(ctx, m, spec, t):
    B_v, M_v, n_v = t["B_v"], t["M_v"], t["n_v"]
    rhs = M_v * t["dv"] + n_v
    mn = spec.get("min_norm")
    if isinstance(mn, dict):
        names = {d.name: d for d in t["dv"]}
        if not set(mn) <= set(names):
            raise ExerciseError(f"reduced_dynamics.min_norm: values for {', '.join(names)}")
        rhs = rhs.xreplace({names[k]: ctx.expr(v, f"reduced_dynamics.min_norm.{k}") for k, v in mn.items()})
    if mn:
        u_mn = m.tidy_matrix(B_v.pinv() * rhs)
        ctx.answer("u_min_norm", u_mn)
        parts = [rf"u = (F^T S)^\# (F^T M F \dot v + n_v) = {_L(m, u_mn)}"]
        for g, rows in enumerate(con.min_norm_rows(B_v), start=1):
            cols = [j for j in range(B_v.cols) if any(B_v[r, j] != 0 for r in rows)]
            sub = B_v.extract(rows, cols)
            u_g = m.tidy_matrix(sub.pinv() * rhs.extract(rows, [0]))
            ctx.answer(f"u_group{g}", u_g)
            parts.append(rf"{_L(m, sp.Matrix([t['u'][j] for j in cols]))} = {_L(m, u_g)}")
        ctx.step("Smallest inputs", r",\quad ".join(parts),
                 "Among the inputs that give the pseudo-accelerations, the one of least norm: each group of reduced "
                 "equations that shares no input is distributed on its own inputs.")
    mt = spec.get("minimum_time")
    if mt:
        row = int(mt.get("row", 1)) - 1
        if not 0 <= row < B_v.rows:
            raise ExerciseError(f"reduced_dynamics.minimum_time.row: 1..{B_v.rows}")
        others = [j for j in range(M_v.cols) if j != row]
        if any(M_v[row, j] != 0 for j in others) or (n_v[row].free_symbols & (set(m.dq) | set(m.q))):
            raise ExerciseError("reduced_dynamics.minimum_time: the pseudo-coordinate is not decoupled (M_v row or n_v)")
        bounds = {symbol(kk): ctx.expr(vv, f"minimum_time.bounds.{kk}") for kk, vv in (mt.get("bounds") or {}).items()}
        push = sum(sp.Abs(B_v[row, j]) * bounds.get(t["u"][j], 0) for j in range(B_v.cols))
        if n_v[row] != 0:
            raise ExerciseError("reduced_dynamics.minimum_time: a constant force along the pseudo-coordinate is not handled")
        a_max = sp.simplify(push / M_v[row, row])
        L = ctx.expr(mt.get("length", "L"), "minimum_time.length")
        T = sp.simplify(2 * sp.sqrt(L / a_max))
        ctx.answer("a_max", a_max)
        ctx.answer("T_min", T)
        ctx.step("Minimum time along the pseudo-coordinate",
                 rf"\ddot s_{{max}} = \frac{{\sum_j |B_{{v,j}}| u_{{j,max}}}}{{(F^T M F)_{{ss}}}} = {_L(m, a_max)},\quad "
                 rf"T^* = 2\sqrt{{L/\ddot s_{{max}}}} = {_L(m, T)}",
                 "Rest to rest with every input at its bound, accelerating for half the time and braking for the other half.")


def _evaluate_reduced(ctx, m: TaskView, spec, terms):
    """Answers at one state: the configuration (given, or placing a point by numeric inverse
    kinematics), the desired pseudo-acceleration (given, or from a rest-to-rest timing law)."""
    from scipy.optimize import least_squares
    values = _given_values(ctx)
    state = m.mapping(spec.get("state"), "reduced_dynamics.evaluate.state", keys="state")
    steps = []
    if "place" in spec:
        pl = spec["place"]
        pos = _point_position(m, pl.get("point", "ee"), "reduced_dynamics.evaluate.place.point")
        target = sp.Matrix([ctx.expr(e, "reduced_dynamics.evaluate.place.at") for e in pl["at"]]).subs(values)
        guess = m.mapping(pl.get("guess"), "reduced_dynamics.evaluate.place.guess")
        x0 = [float(guess.get(qk, 0.0)) for qk in m.q]
        defaults = {p.symbol: p.value for p in m.robot.parameters.values()}
        f = numeric_function([list(m.q)], list((pos[:len(target), 0] - target).subs(values).subs(defaults)), "numpy")
        sol = least_squares(lambda x: np.asarray(f(x), dtype=float), x0, xtol=1e-14, ftol=1e-14, gtol=1e-14)
        if np.max(np.abs(sol.fun)) > 1e-9:
            raise ExerciseError("reduced_dynamics.evaluate.place: the point cannot reach the target")
        for qk, val in zip(m.q, sol.x):
            state[qk] = sp.Float(val)
        steps.append(rf"q = {_L(m, sp.Matrix([state[qk] for qk in m.q]).evalf(6))}")
        ctx.answer("q_at", sp.Matrix([state[qk] for qk in m.q]))
    for d in m.dq:
        state.setdefault(d, 0)
    missing = [qk for qk in m.q if qk not in state]
    if missing:
        raise ExerciseError(f"reduced_dynamics.evaluate: no value for {', '.join(s.name for s in missing)}")
    dv_val = None
    if "timing" in spec:
        tm = spec["timing"]
        prof = _PROFILES.get(tm.get("profile", "cubic"))
        if prof is None:
            raise ExerciseError(f"reduced_dynamics.evaluate.timing.profile: one of {', '.join(_PROFILES)}")
        delta = ctx.expr(tm["length"], "timing.length").subs(values)
        T = ctx.expr(tm["duration"], "timing.duration").subs(values)
        s = sp.Symbol("sigma")
        sdd = (delta * prof(s)).diff(s, 2) / T ** 2
        dv_val = sdd.subs(s, ctx.expr(tm.get("t", 0), "timing.t").subs(values) / T)
        ctx.answer("Delta", delta)
        ctx.answer("dv_at", dv_val)
        steps.append(rf"\Delta = {_L(m, sp.N(delta, 6))},\ \dot v_d = {_L(m, sp.N(dv_val, 6))}")
    elif "dv" in spec:
        dv_val = ctx.expr(spec["dv"], "reduced_dynamics.evaluate.dv").subs(values)
    sub = {**values, **state}

    def at(x):
        return m.tidy_matrix(sp.Matrix(x).subs(sub))
    if terms["g"] is None:
        raise ExerciseError("reduced_dynamics.evaluate: needs the robot's inertia (not inertia: generic)")
    out = {"M_at": at(terms["M"]), "g_at": at(terms["g"]), "F_at": at(terms["F"])}
    dvs = {d: dv_val for d in terms["dv"]} if dv_val is not None else {}
    for key in ("u_track", "u_reduced"):
        if terms[key] is not None and (dv_val is not None or not (terms[key].free_symbols & set(terms["dv"]))):
            out[key + "_at"] = at(terms[key].subs(dvs))
    for name, val in out.items():
        ctx.answer(name, val)
    steps += [rf"M = {_L(m, out['M_at'])}", rf"g = {_L(m, out['g_at'])}", rf"F = {_L(m, out['F_at'])}"]
    steps += [rf"u = {_L(m, out[k])}" for k in ("u_track_at", "u_reduced_at") if k in out]
    ctx.step("At the given state", r",\quad ".join(steps),
             "Numbers of the exercise substituted (the configuration from inverse kinematics when a point is placed).")
