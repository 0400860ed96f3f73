"""Closed loops of a robot with a control law: Lyapunov candidate, its derivative along the motion,
LaSalle's invariant set, steady motions under constant inputs (core: app.core.lyapunov).

``lyapunov``: the closed loop M(q) q'' + C q' = F(q, q') with F = S u + sum J_i^T F_i - g - k -
  friction. Options:
  - ``law``: the generalized forces of the control, as a list of expressions (one per coordinate,
    or one per actuated coordinate), the name of an earlier answer (e.g. ``u_fl``), or built from
    ``{gravity: true (+ g(q) + k(q)), pd: {kp, kd, target, on}, compensate: [{point, force}] (- J^T F),
    shaping: [...], extra: [...]}``; ``gains``: symbol -> value substituted in the law;
  - ``shaping``: artificial potentials ``[{name, potential, where: {coordinate: [lo, hi]}}]``
    (inside the open interval only, 0 elsewhere): u gets -dP/dq and V gets P;
  - ``external``: constant forces on the robot ``[{point, force, name}]`` (generalized J^T F);
  - ``candidate``: ``energy`` (default: V = T + P with P the potential of the position-dependent
    closed-loop forces, zero at the equilibrium), ``{kinetic: true, potential: expr}``, or false;
  - ``domain``: {coordinate: [lo, hi]} where the analysis holds (e.g. the stroke of a joint);
  - ``at``: a configuration where the closed-loop forces at rest (and, with numbers, q'') are given;
  - ``feedforward``: a target configuration; the constant u_ffw = -F(q_d, 0) is added to the law so
    that the target is an equilibrium (answer ``u_ffw``);
  - ``closed_loop: true``: q'' = M^-1 (F - C q') in closed form (small models);
  - ``substitute`` (applied to the model), ``suffix`` (appended to every answer name).
  Answers: ``u``, ``g`` and ``U`` (with the substitutions), ``F`` and ``F_rest`` (F(q, 0), whose
  zeros are the equilibria), ``V``, ``P``, ``V_dot``,
  ``D`` (V' = -q'^T D q'), ``damps_every_velocity`` (D positive definite: V' = 0 only at q' = 0),
  ``equilibria`` (rows), ``equilibria_count`` (when they have a closed form), else
  ``solved_<coordinate>`` for the coordinates that single equations fix, ``J_<name>`` and ``tau_<name>`` (J^T F) of each external force
  or compensated force, ``<shaping name>`` and ``d<shaping name>`` (potential and its gradient in
  its zone), ``F_at``, ``ddq_at``, ``closed_loop``.
``steady_motion``: motions under constant inputs with every velocity equal and constant (a chain
  of bodies linked by springs and dampers) or at rest. Options: ``inputs`` (coordinate ->
  expression, others 0), ``velocity``: ``common`` (default) or ``zero``. Answers:
  ``steady_velocity``, ``spring_<name>`` (each spring's deflection), ``steady_equations``.

Example (2016-10-28#2): ``{kind: lyapunov, law: {pd: {kp: [k_p], kd: [0], target: [q_d], on: [q1]}}}``
gives V = T + 1/2 (k1 (q1 - q2)^2 + k2 (q2 - q3)^2 + k_p (q_d - q1)^2) and V' = -d |q'|^2.
"""
from __future__ import annotations

import itertools
from typing import Dict, List

import numpy as np
import sympy as sp

from .. import lyapunov as ly
from ..errors import UserError
from ..expressions import symbol
from ..jacobians import JacobianError, point_location
from ..kinematics import Kinematics
from ..steps import to_latex
from . import task
from .equilibria import EquilibriumSolver
from .context import TaskView, tidy_quotient_matrix, wrap_angle


def _neat(e):
    """Polynomials expanded; rational expressions (e.g. repulsive potentials) left as built."""
    e = sp.sympify(e)
    return sp.expand(e) if e.is_polynomial(*e.free_symbols) else e


class _Loop:
    """Model terms of the robot with the exercise's substitutions, and input helpers."""

    def __init__(self, ctx, spec, kind: str):
        self.ctx, self.spec, self.kind = ctx, spec, kind
        self.d = TaskView(ctx)
        self.robot = ctx.robot
        self.dyn = ctx.dynamics()
        self.q, self.dq = list(self.robot.q), list(self.robot.dq)
        self.coords = list(self.robot.coordinates)
        self.n = len(self.q)
        self.suffix = str(spec.get("suffix", ""))
        self.subs = {symbol(str(k)): self.expr(v, f"substitute.{k}") for k, v in (spec.get("substitute") or {}).items()}
        ap = lambda X: sp.Matrix(X).xreplace(self.subs) if self.subs else sp.Matrix(X)
        self.M, self.C = ap(self.dyn.M), ap(self.dyn.C)
        self.g, self.k, self.friction = ap(self.dyn.g), ap(self.dyn.spring), ap(self.dyn.friction)
        self.kin = Kinematics(self.robot)

    def fail(self, what: str) -> UserError:
        return self.d._fail(f"{self.kind}.{what}")

    def expr(self, value, where: str) -> sp.Expr:
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            return sp.nsimplify(value) if isinstance(value, float) else sp.Integer(value)
        return self.d.expression(value, f"{self.kind}.{where}")

    def vector(self, value, size: int, where: str) -> sp.Matrix:
        key = value.strip() if isinstance(value, str) else None
        if key in self.ctx.given and isinstance(self.ctx.given[key], list):
            value = self.ctx.given[key]
        if not isinstance(value, (list, tuple)):
            value = [value] * size
        if len(value) != size:
            raise self.fail(f"{where}: expected {size} entries, got {len(value)}")
        return sp.Matrix([self.expr(v, where) for v in value])

    def L(self, X) -> str:
        return to_latex(X, self.coords)

    def answer(self, name: str, value) -> None:
        self.ctx.answer(name + self.suffix, value)

    def point_jacobian(self, point, where: str):
        try:
            body, local = point_location(self.robot, point)
        except JacobianError as exc:
            raise self.fail(f"{where}: {exc}") from None
        p3 = self.kin.point_position(body, self.d.substitute(local))
        p = p3[:2, :] if self.robot.is_planar else p3
        if self.subs:
            p = p.xreplace(self.subs)
        return p.applyfunc(sp.expand), p.jacobian(sp.Matrix(self.q)).applyfunc(sp.expand)

    def numbers(self) -> Dict[sp.Symbol, float]:
        """Numbers for every parameter and given scalar (for locating equilibria)."""
        return {symbol(k): v for k, v in self.d.scalars().items()}


def _force_terms(lp: _Loop, items, where: str, sign: int):
    """sum sign * J^T F over [{point, force, name}] with the steps and answers of each force."""
    total = sp.zeros(lp.n, 1)
    for i, item in enumerate(items or []):
        if not isinstance(item, dict) or "point" not in item or "force" not in item:
            raise lp.fail(f"{where}[{i}]: expected {{point, force, name}}")
        label = str(item.get("name", f"F{i + 1}"))
        p, J = lp.point_jacobian(item["point"], f"{where}[{i}].point")
        F = lp.vector(item["force"], J.rows, f"{where}[{i}].force")
        tau = (J.T * F).applyfunc(sp.expand)
        lp.ctx.step(f"Force ${lp.L(sp.Symbol(label))}$", rf"p_{{{label}}} = {lp.L(p)},\quad J_{{{label}}} = {lp.L(J)},\quad J^T F = {lp.L(tau)}",
                    r"Its generalized force, from the virtual work $F^T \delta p = (J^T F)^T \delta q$.")
        lp.answer(f"p_{label}", p)
        lp.answer(f"J_{label}", J)
        lp.answer(f"tau_{label}", tau)
        total += sign * tau
    return total


def _shaping(lp: _Loop, items):
    """[(name, P, coordinate, lo, hi)] of the artificial potentials and the sum of -dP/dq."""
    pieces, force = [], sp.zeros(lp.n, 1)
    for i, item in enumerate(items or []):
        if not isinstance(item, dict) or "potential" not in item:
            raise lp.fail(f"shaping[{i}]: expected {{name, potential, where}}")
        name = str(item.get("name", f"V{i + 1}"))
        P = lp.expr(item["potential"], f"shaping[{i}].potential")
        where = item.get("where") or {}
        if len(where) > 1:
            raise lp.fail(f"shaping[{i}].where: one coordinate per potential")
        zone = None
        for c, (lo, hi) in where.items():
            if c not in lp.coords:
                raise lp.fail(f"shaping[{i}].where: '{c}' is not a coordinate")
            zone = (symbol(c), lp.expr(lo, "where"), lp.expr(hi, "where"))
        grad = sp.Matrix([sp.diff(P, s) for s in lp.q]).applyfunc(sp.factor)
        span = (rf",\quad {lp.L(zone[1])} < {lp.L(zone[0])} < {lp.L(zone[2])}\ (0\ \text{{elsewhere}})" if zone else "")
        lp.ctx.step(f"Artificial potential ${lp.L(sp.Symbol(name))}$", rf"{name} = {lp.L(P)},\quad \nabla {name} = {lp.L(grad)}{span}",
                    "It grows without bound at the limit and vanishes, with its gradient, at the edge of its zone.")
        lp.answer(name, P)
        lp.answer(f"d{name}", grad if lp.n > 1 else grad[0])
        pieces.append((name, P, zone))
        force -= grad
    return pieces, force


def _law(lp: _Loop, spec):
    """u (one entry per coordinate; zero on the unactuated ones) and the shaping pieces."""
    raw = spec.get("law")
    if raw is None:
        raise lp.fail("law: required (a list, an answer name or {gravity, pd, compensate, shaping, extra})")
    pieces = []
    if isinstance(raw, str):
        if raw not in lp.ctx.answers:
            raise lp.fail(f"law: no earlier answer named '{raw}'")
        u = sp.Matrix(lp.ctx.answers[raw])
    elif isinstance(raw, list):
        act = [i for i, a in enumerate(lp.robot.actuated) if a] if len(raw) != lp.n else list(range(lp.n))
        if len(raw) != len(act):
            raise lp.fail(f"law: expected {lp.n} entries (or one per actuated coordinate, {len(act)})")
        u = sp.zeros(lp.n, 1)
        for i, e in zip(act, raw):
            u[i] = lp.expr(e, "law")
    elif isinstance(raw, dict):
        u = sp.zeros(lp.n, 1)
        if raw.get("gravity"):
            u += lp.g + lp.k
        if raw.get("pd") is not None:
            pd = raw["pd"]
            on = [lp.coords.index(c) for c in pd.get("on", lp.coords)]
            m = len(on)
            kp = lp.vector(pd.get("kp", [f"kp{i + 1}" for i in on]), m, "law.pd.kp")
            kd = lp.vector(pd.get("kd", [f"kd{i + 1}" for i in on]), m, "law.pd.kd")
            tgt = lp.vector(pd.get("target", [f"{lp.coords[i]}_d" for i in on]), m, "law.pd.target")
            for j, i in enumerate(on):
                u[i] += kp[j] * (tgt[j] - lp.q[i]) - kd[j] * lp.dq[i]
        u += _force_terms(lp, raw.get("compensate"), "law.compensate", -1)
        pieces, f_shape = _shaping(lp, raw.get("shaping"))
        u += f_shape
        if raw.get("extra") is not None:
            u += lp.vector(raw["extra"], lp.n, "law.extra")
    else:
        raise lp.fail("law: a list, an answer name or {gravity, pd, compensate, shaping, extra}")
    gains = {symbol(str(k)): lp.expr(v, f"gains.{k}") for k, v in (spec.get("gains") or {}).items()}
    if gains:
        u = u.xreplace(gains)
    return u.applyfunc(_neat), pieces


def _cells(lp: _Loop, pieces, domain, values):
    """Regions of configuration space where a fixed set of shaping potentials is active:
    [(bounds {coordinate: (lo, hi)}, active names)], with numbers for the breakpoints."""
    if not pieces:
        return [({}, [])]
    per_coord: Dict[sp.Symbol, List[float]] = {}
    for _name, _P, zone in pieces:
        if zone is None:
            continue
        c, lo, hi = zone
        try:
            pts = [float(lo.xreplace(values)), float(hi.xreplace(values))]
        except TypeError:
            raise lp.fail("shaping.where: the zone limits need numbers (give them) to split the configuration space") from None
        per_coord.setdefault(c, []).extend(pts)
    axes = []
    for c, pts in per_coord.items():
        lo_d, hi_d = domain.get(c, (-np.inf, np.inf))
        cuts = sorted(set([lo_d, hi_d] + [p for p in pts if lo_d < p < hi_d]))
        axes.append([(c, a, b) for a, b in zip(cuts[:-1], cuts[1:])])
    cells = []
    for combo in itertools.product(*axes):
        bounds = {c: (a, b) for c, a, b in combo}
        mid = {c: (a + b) / 2 if np.isfinite(a) and np.isfinite(b) else (b - 1 if np.isfinite(b) else a + 1)
               for c, (a, b) in bounds.items()}
        active = []
        for name, _P, zone in pieces:
            if zone is None:
                active.append(name)
                continue
            c, lo, hi = zone
            if float(lo.xreplace(values)) < mid[c] < float(hi.xreplace(values)):
                active.append(name)
        cells.append((bounds, active))
    return cells


def _equilibria(lp: _Loop, base: sp.Matrix, pieces, domain):
    """Rows of closed-loop equilibria (F(q, 0) = 0) over the cells where a fixed set of artificial
    potentials acts (``base``: the forces at rest without them), and a step per cell."""
    values = lp.numbers()
    rows, solved = [], {}
    for bounds, active in _cells(lp, pieces, domain, values):
        eq = sp.Matrix(base)
        for name, P, _zone in pieces:
            if name in active:
                eq -= sp.Matrix([sp.diff(P, s) for s in lp.q])
        if bounds and len(lp.q) == 1:
            sols = _zone_solutions(lp, eq[0], bounds, values)
            where = ", ".join(f"{lp.L(c)} \\in ({a:g}, {b:g})" for c, (a, b) in bounds.items())
            x = lp.q[0]
            lp.ctx.step("Equilibria in a zone", rf"{where}:\ {lp.L(eq[0])} = 0 \Rightarrow "
                        + (", ".join(f"{lp.L(x)} = {lp.L(s)}" for s in sols) if sols else r"\text{no solution}"),
                        "Active potentials: " + (", ".join(f"${lp.L(sp.Symbol(a))}$" for a in active) or "none") + ".")
            rows += [[s] for s in sols if [s] not in rows]
            continue
        found, part = _solve_all(lp, eq.applyfunc(sp.expand))
        rows += [r for r in found if r not in rows]
        solved.update(part)
    return rows, solved


def _zone_solutions(lp: _Loop, eq, bounds, values):
    """Solutions of one equation in one coordinate inside a zone: in closed form when the
    equation is at most quadratic, else numerically with the exercise's numbers."""
    x = lp.q[0]
    lo, hi = bounds[x]
    num, _den = sp.fraction(sp.cancel(sp.together(eq)))
    if sp.degree(num, x) <= 2:
        out = []
        for s in sp.solve(num, x):
            try:
                v = float(s.xreplace(values))
            except TypeError:
                continue
            if lo - 1e-9 <= v <= hi + 1e-9:
                out.append(s)
        return out
    return ly.solve_in_interval(eq.xreplace(values), x, lo, hi)


def _solve_all(lp: _Loop, eq: sp.Matrix):
    """Closed-form solutions of eq = 0 in the coordinates; when there is none, the coordinates that
    single equations fix ({coordinate: value})."""
    angles = [s for s in lp.q if any(s in b.joint.value.free_symbols for b in lp.robot.bodies if b.joint.type == "revolute")]
    solver = EquilibriumSolver(lp.q, angles, lambda *a: None)
    try:
        branches = solver.solve(list(enumerate(eq)), {})
    except UserError:
        part = {}
        for e in eq:
            unknown = e.free_symbols & set(lp.q)
            if len(unknown) == 1:
                s = unknown.pop()
                sol = sp.solve(e, s)
                if len(sol) == 1 and not e.has(sp.sin, sp.cos):
                    part[s] = sol[0]
        return [], part
    rows = []
    for sol in branches:
        row = []
        for s in lp.q:
            v = sol.get(s, s)
            for _ in range(lp.n):
                v = sp.expand(v.subs(sol))
            v = solver.reveal(v)
            row.append(wrap_angle(v) if s in angles else sp.simplify(v))
        if row not in rows:
            rows.append(row)
    return rows, {}


@task("lyapunov")
def lyapunov_task(ctx, spec):
    """Closed-loop Lyapunov/LaSalle analysis (see the module docstring)."""
    lp = _Loop(ctx, spec, "lyapunov")
    u, pieces = _law(lp, spec)
    joints = [b.name for b in lp.robot.bodies]
    lp.ctx.step("Control law", rf"u = {lp.L(u)}", "Generalized forces of the controller, one per coordinate "
                "(zero on the passive ones)." + (" Each artificial potential acts only in its zone." if pieces else ""), joints=joints)
    external = _force_terms(lp, spec.get("external"), "external", 1)
    if spec.get("feedforward") is not None:
        u = _feedforward(lp, spec["feedforward"], u, external)
    lp.answer("u", u)
    lp.answer("g", lp.g)
    lp.answer("U", sp.expand(sum(lp.dyn.potential.values(), sp.Integer(0)).xreplace(lp.subs)))
    F = (u + external - lp.g - lp.k - lp.friction).applyfunc(_neat)
    rest = {s: 0 for s in lp.dq}
    F_rest = F.xreplace(rest).applyfunc(_neat)
    shape_grad = sp.zeros(lp.n, 1)
    for _name, P, _z in pieces:
        shape_grad += sp.Matrix([sp.diff(P, s) for s in lp.q])
    # the position forces apart from the artificial potentials (they cancel exactly)
    base = (F_rest + shape_grad).applyfunc(lambda e: sp.expand(sp.cancel(sp.together(e)))) if pieces else F_rest
    lp.ctx.step("Closed loop", rf"M(q)\ddot q + C(q,\dot q)\dot q = F(q,\dot q) = {lp.L(F)}",
                "Every generalized force but the inertial ones: control, external forces, minus gravity, springs and friction.")
    lp.answer("F", F)
    lp.answer("F_rest", F_rest)
    domain = {symbol(c): tuple(float(lp.expr(v, f"domain.{c}").xreplace(lp.numbers())) for v in lim)
              for c, lim in (spec.get("domain") or {}).items()}
    rows, solved = _equilibria(lp, base, pieces, domain)
    cand = spec.get("candidate", "energy")
    if cand is not False:
        _candidate(lp, cand, F, F_rest, base, pieces, rows)
    if rows:
        table = sp.Matrix(rows)
        lp.ctx.step("Equilibria", rf"F(q, 0) = {lp.L(F_rest)} = 0 \Rightarrow q \in {lp.L(table)}",
                    f"{len(rows)} closed-loop equilibrium configuration(s), one per row ({', '.join(lp.coords)}).")
    elif solved:
        lp.ctx.step("Equilibria", rf"F(q, 0) = {lp.L(F_rest)} = 0 \Rightarrow " + r",\ ".join(f"{lp.L(s)} = {lp.L(v)}" for s, v in solved.items()),
                    "No closed form for all coordinates (a numeric solution is needed); the equations with one unknown fix these.")
    if rows or not solved:
        lp.answer("equilibria", sp.Matrix(rows) if rows else sp.zeros(0, lp.n))
        lp.answer("equilibria_count", len(rows))
    for s_, v in solved.items():
        lp.answer(f"solved_{s_.name}", v)
    if spec.get("at") is not None:
        _at(lp, spec["at"], F_rest)
    if spec.get("closed_loop"):
        rhs = F - lp.C * sp.Matrix(lp.dq)
        exact = ly.solve_linear_exactly(lp.M, rhs)
        ddq = tidy_quotient_matrix(exact if exact is not None else lp.M.LUsolve(rhs))
        lp.ctx.step("Closed-loop accelerations", rf"\ddot q = M^{{-1}}(F - C\dot q) = {lp.L(ddq)}", "", joints=joints)
        lp.answer("closed_loop", ddq)


def _feedforward(lp: _Loop, target, u, external):
    """u + u_ffw with the constant u_ffw that makes ``target`` an equilibrium: minus the
    closed-loop forces at rest there."""
    if not isinstance(target, dict) or set(target) != set(lp.coords):
        raise lp.fail(f"feedforward: give the target configuration ({', '.join(lp.coords)})")
    at = {symbol(c): lp.expr(v, f"feedforward.{c}") for c, v in target.items()}
    rest = {s: 0 for s in lp.dq}
    ffw = (-(u + external - lp.g - lp.k - lp.friction).xreplace(rest).xreplace(at)).applyfunc(sp.factor)
    passive = [lp.coords[i] for i, a in enumerate(lp.robot.actuated) if not a and ffw[i] != 0]
    if passive:
        raise lp.fail(f"feedforward: the target needs a force on the passive coordinate(s) {', '.join(passive)}")
    lp.ctx.step("Feedforward", rf"u_{{ffw}} = -F(q_d, 0) = {lp.L(ffw)}",
                "A constant term that cancels the closed-loop forces at rest at the target, which becomes an equilibrium.")
    lp.answer("u_ffw", ffw)
    return (u + ffw).applyfunc(_neat)


def _candidate(lp: _Loop, cand, F, F_rest, base, pieces, rows):
    if cand == "energy" or cand is True:
        at = {s: v for s, v in zip(lp.q, rows[0])} if len(rows) == 1 else None
        try:
            P = ly.potential(base, lp.q, at)
        except ly.LyapunovError as exc:
            raise lp.fail(f"candidate: {exc}") from None
        P = P + sum((Pi for _n, Pi, _z in pieces), sp.Integer(0))
        how = "T plus the potential of the position-dependent closed-loop forces" + (", zero at the equilibrium." if at else ".")
    elif isinstance(cand, dict):
        if not cand.get("kinetic", True):
            raise lp.fail("candidate: the kinetic energy must be part of V (kinetic: true)")
        P = lp.expr(cand.get("potential", 0), "candidate.potential")
        how = "The given candidate."
    else:
        raise lp.fail("candidate: energy, {kinetic: true, potential: ...} or false")
    P = _neat(P)
    T = sp.expand((sp.Matrix(lp.dq).T * lp.M * sp.Matrix(lp.dq))[0] / 2)
    grad = sp.Matrix([sp.diff(P, s) for s in lp.q])
    V_dot = sp.expand(ly.derivative_along(F, lp.dq, grad))
    D = ly.dissipation(V_dot, lp.dq)
    if D is not None:          # the exact quadratic form instead of an unsimplified sum
        V_dot = sp.expand(-(sp.Matrix(lp.dq).T * D * sp.Matrix(lp.dq))[0])
    gains = [s for s in V_dot.free_symbols if s not in lp.q and s not in lp.dq]
    kind = ly.definiteness(D, gains) if D is not None else "not a quadratic form in the velocities"
    lp.ctx.step("Lyapunov candidate", rf"V = T + P(q) = \tfrac12 \dot q^T M(q) \dot q + {lp.L(sp.factor(P))}", how,
                joints=[b.name for b in lp.robot.bodies])
    lp.ctx.step("Its derivative", rf"\dot V = \dot q^T (F + \nabla P) = {lp.L(V_dot)}"
                + (rf" = -\dot q^T D \dot q,\ D = {lp.L(D)}" if D is not None else ""),
                r"$\dot M - 2C$ is skew-symmetric, so $\dot T = \dot q^T F$. " + f"$D$ is {kind}.")
    lasalle = (r"$\dot V = 0$ only where $\dot q = 0$; staying there needs $\ddot q = 0$, i.e. $F(q, 0) = 0$: the largest "
               "invariant set is made of the closed-loop equilibria (LaSalle)." if kind == "positive definite" else
               r"$\dot V$ vanishes on more than $\dot q = 0$: the invariant set needs a closer look at the closed loop.")
    lp.ctx.step("LaSalle", rf"\dot V = 0 \Rightarrow \dot q = 0 \Rightarrow F(q, 0) = {lp.L(F_rest)} = 0"
                if kind == "positive definite" else r"\dot V \le 0", lasalle)
    lp.answer("V", T + P)
    lp.answer("P", P)
    lp.answer("V_dot", V_dot)
    if D is not None:
        lp.answer("D", D)
    lp.answer("damps_every_velocity", kind == "positive definite")


def _at(lp: _Loop, raw, F_rest):
    if not isinstance(raw, dict):
        raise lp.fail("at: expected {coordinate: value}")
    sub = {symbol(c): lp.expr(v, f"at.{c}") for c, v in raw.items()}
    Fa = F_rest.xreplace(sub).applyfunc(sp.expand)
    lp.ctx.step("Forces at rest there", rf"F = {lp.L(Fa)}", r"With $\dot q = 0$ only these forces accelerate the robot: $M \ddot q = F$.")
    lp.answer("F_at", Fa)
    values = lp.numbers()
    Mn = lp.M.xreplace(sub).xreplace(values)
    Fn = Fa.xreplace(values)
    if not (Mn.free_symbols or Fn.free_symbols):
        ddq = np.linalg.solve(np.array(Mn.evalf(), float), np.array(Fn.evalf(), float).reshape(-1))
        lp.ctx.step("Accelerations there", rf"\ddot q = M^{{-1}} F = {lp.L(sp.Matrix(np.round(ddq, 4)))}",
                    "With the exercise's numbers; M^-1 is full, so every joint accelerates.")
        lp.answer("ddq_at", ddq)


@task("steady_motion")
def steady_motion_task(ctx, spec):
    """Motion with constant, equal velocities (or rest) under constant inputs (see the module docstring)."""
    lp = _Loop(ctx, spec, "steady_motion")
    u = sp.zeros(lp.n, 1)
    for c, e in (spec.get("inputs") or {}).items():
        if c not in lp.coords:
            raise lp.fail(f"inputs: '{c}' is not a coordinate")
        u[lp.coords.index(c)] = lp.expr(e, f"inputs.{c}")
    mode = spec.get("velocity", "common")
    if mode not in ("common", "zero"):
        raise lp.fail("velocity: common or zero")
    v = symbol("v_ss")
    vel = {s: (v if mode == "common" else 0) for s in lp.dq}
    eqs = (u - lp.g - lp.k - lp.friction - lp.C * sp.Matrix(lp.dq)).xreplace(vel).applyfunc(sp.expand)
    unknowns = ([v] if mode == "common" else []) + lp.q[:-1]
    sol = sp.solve(list(eqs), unknowns, dict=True)
    if not sol:
        raise lp.fail("no steady motion of this kind exists with these inputs")
    sol = sol[0]
    lp.ctx.step("Steady-state equations", rf"q'' = 0,\ \dot q_i = {lp.L(vel[lp.dq[0]])}:\quad {lp.L(eqs)} = 0",
                "Constant equal velocities: the springs keep constant deflections, the dampers balance the input.")
    lp.answer("steady_equations", eqs)
    if mode == "common":
        vs = sp.factor(sol.get(v, v))
        lp.answer("steady_velocity", vs)
    defl = []
    for s in lp.robot.springs:
        if s.expr is None:
            continue
        val = sp.factor(sp.sympify(s.expr).xreplace(sol) - (s.rest or 0))
        defl.append(rf"\delta_{{{s.name}}} = {lp.L(val)}")
        lp.answer(f"spring_{s.name}", val)
    lp.ctx.step("Steady motion", (rf"\dot q_i = {lp.L(vs)},\quad " if mode == "common" else "") + r",\ ".join(defl),
                "Each spring transmits the force needed by the bodies after it.")


@task("gravity_gradient_symbolic")
def gravity_gradient_symbolic_task(ctx, spec):
    """A symbolic alpha >= ||dg/dq|| over the workspace (core: app.core.norm_bounds): A = dg/dq,
    A^T A, its largest eigenvalue, and alpha from upper bounds of the entries of A^T A (|sin|, |cos|
    <= 1, prismatic coordinates at the end of their ``range`` {coordinate: [lo, hi]} (expressions);
    parameters positive). Answers ``A``, ``AtA``, ``lambda_max`` (2x2), ``AtA_bounds``, ``alpha``."""
    from ..norm_bounds import BoundError, lambda_max_2x2, norm_bound
    lp = _Loop(ctx, spec, "gravity_gradient_symbolic")
    g = (lp.g + lp.k).applyfunc(sp.expand)
    A = tidy_quotient_matrix(g.jacobian(sp.Matrix(lp.q)))
    ranges = {}
    for c, lim in (spec.get("range") or {}).items():
        if c not in lp.coords or not isinstance(lim, list) or len(lim) != 2:
            raise lp.fail(f"range.{c}: expected a coordinate and [lo, hi]")
        ranges[symbol(c)] = (lp.expr(lim[0], f"range.{c}"), lp.expr(lim[1], f"range.{c}"))
    positive = [p.symbol for p in lp.robot.parameters.values()
                if p.kind in ("mass", "inertia", "stiffness", "gravity", "length", "com")]
    try:
        B, alpha = norm_bound(A, ranges, positive)
    except BoundError as exc:
        raise lp.fail(str(exc)) from None
    S = (A.T * A).applyfunc(sp.factor)
    lp.ctx.step("Gradient of gravity", rf"A(q) = \frac{{\partial g}}{{\partial q}} = {lp.L(A)}",
                r"Symmetric (the Hessian of the potential energy) and not definite in sign: its norm is $\sqrt{\lambda_{\max}(A^T A)}$.",
                joints=[b.name for b in lp.robot.bodies])
    lp.ctx.step("Its square", rf"A^T A = {lp.L(S)}", "Positive semidefinite: real nonnegative eigenvalues.")
    lp.answer("A", A)
    lp.answer("AtA", S)
    if S.shape == (2, 2):
        lam = lambda_max_2x2(S)
        lp.ctx.step("Largest eigenvalue", rf"\lambda_{{max}}(A^T A) = \frac{{a_1 + a_3 + \sqrt{{(a_1 - a_3)^2 + 4 a_2^2}}}}{{2}}",
                    r"From $\det(\lambda I - A^T A) = \lambda^2 - (a_1 + a_3) \lambda + a_1 a_3 - a_2^2$; it grows with $a_1$, $a_3$ and $|a_2|$.")
        lp.answer("lambda_max", lam)
    lp.ctx.step("A bound over the workspace", rf"A^T A \le {lp.L(B)}\ \text{{entrywise}},\quad \alpha = {lp.L(alpha)}",
                r"$|\sin|, |\cos| \le 1$ and the coordinates at the end of their range bound each entry; $\alpha \ge \|A(q)\|$ "
                r"everywhere, so $K_{P,\min} > \alpha$ makes PD with the constant compensation $g(q_d)$ globally asymptotically stable.")
    lp.answer("AtA_bounds", B)
    lp.answer("alpha", alpha)
