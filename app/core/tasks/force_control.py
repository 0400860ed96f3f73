"""Explicit force control of linear lumped models (a robot mass against a compliant environment,
a force sensor in between): closed loop, equilibrium and force error, transfer functions,
characteristic polynomial, Routh conditions on the gains, Lyapunov function, poles along a gain.
The algorithms are in ``app.core.linear_control``; the plant is the robot file's Lagrangian model
M q'' + c + g + k(q) + F_v q' = S u, which must be linear (masses on lines, springs, dampers).

``force_control`` options:
  ``measured``: ``{name, expression}``, the force the sensor reads as an expression of the
  coordinates (e.g. ``{name: F_c, expression: "k_s*(x_r - x_w)"}``); ``reference`` (default
  ``F_d``): the constant desired force; ``law``: the input on the actuated coordinate as an
  expression of the coordinates, velocities (``dx``), the measured force name, the reference and
  gains (a mapping coordinate -> expression when several coordinates are actuated);
  ``integral``: a name standing in the law for the integral of (reference - measured);
  ``position_reference``: ``{name, coordinate, estimates}``, the position where the measured force
  equals the reference (solved for ``coordinate``, with the parameters of ``estimates`` replaced by
  their estimates, e.g. ``{k_e: k_e_hat}``), usable in the law under ``name``; ``substitute``:
  parameter values for this task only (``{k_s: 0}``: no environment); ``positive``: gains assumed
  positive in the Routh analysis (masses, stiffnesses, damping, inertias and lengths always are);
  ``solve_for``: gains for which each Routh condition is solved; ``poles``: ``{gain, values}``,
  numeric poles of the closed loop at those gain values (other symbols from ``given`` or the robot
  file) and the gain intervals of stability; ``routh: false`` leaves out the symbolic Routh table
  (costly with many symbolic parameters: the numeric ``poles`` then answer the stability
  question); ``suffix`` appended to every answer name.

  Answers: ``equations`` (M q'' + n, equal to S u), ``measured`` (F_m(q)), ``law`` (u after
  substitutions), ``closed_loop`` (M q'' + n - S u, = 0), ``equilibrium`` and ``<coordinate>_e``
  (rest, with the integral state ``<integral>_e``), ``F_e`` (measured force there), ``e_F``
  (reference - F_e), ``u_e`` (input there), ``steady_velocity`` (free motion at constant speed when
  the positions of some coordinates do not appear), ``P`` (open loop, measured force over input;
  ``P_num`` its numerator over the denominator ``open_loop_poly``),
  ``H_<coordinate>`` (coordinate over input), ``W`` (closed loop, measured force over reference),
  ``W_e`` (1 - W), ``G`` (W / (1 - W): the loop transfer function of a unity feedback),
  ``open_loop_poly``, ``char_poly``, ``routh_column``, ``conditions`` (first-column entries
  reduced to what must be positive), ``<gain>_min`` / ``<gain>_max``, ``V`` and ``V_dot``
  (Lyapunov function of a loop without integral states), ``max_real_part`` (one per value of
  ``poles.values``), ``stable_at``, ``stable_intervals`` ([from, to, 1 if stable]),
  ``critical_gain`` (the first gain >= 0 where stability changes, stable to unstable or the
  reverse; none when it never changes) and ``stable_for_all_gains``.

``routh``: Routh criterion for a polynomial given by the exercise. Options ``polynomial``
  (expression in ``s``), ``positive``, ``solve_for``, ``suffix``. Answers ``routh_column``,
  ``conditions``, ``<gain>_min`` / ``<gain>_max``.

Example (2016-07-11#3, PI force control of a mass against a spring of rest position d):

    - kind: force_control
      measured: {name: F_m, expression: "k_e*(x - d)"}
      integral: int_e
      law: "k_f*(F_d - F_m) + k_i*int_e - k_d*dx"
      positive: [k_d]
      solve_for: [k_f]
"""
from __future__ import annotations

from typing import Dict, List

import numpy as np
import sympy as sp

from .. import linear_control as lc
from ..exercise import ExerciseError
from ..expressions import ExpressionError, parse_expression, symbol
from ..latex import num
from ..steps import to_latex
from . import task

_POSITIVE_KINDS = ("mass", "inertia", "stiffness", "friction", "length", "com", "gravity")


class _Spec:
    """Reading the options of one force_control / routh task."""

    def __init__(self, ctx, spec, kind):
        self.ctx, self.spec, self.kind = ctx, spec, kind
        self.suffix = str(spec.get("suffix", "") or "")

    def fail(self, option, what):
        return ExerciseError(f"{self.ctx.exercise.source or self.ctx.exercise.id}: {self.kind}.{option}: {what}")

    def expr(self, value, option, extra=None):
        try:
            return parse_expression(value, extra=extra)
        except ExpressionError as exc:
            raise self.fail(option, str(exc)) from None

    def names(self, option) -> List[sp.Symbol]:
        raw = self.spec.get(option) or []
        raw = [raw] if isinstance(raw, str) else raw
        if not isinstance(raw, list) or not all(isinstance(x, str) and x.isidentifier() for x in raw):
            raise self.fail(option, f"expected a list of names, got {raw!r}")
        return [symbol(x) for x in raw]

    def answer(self, name, value):
        self.ctx.answer(name + self.suffix, value)

    def positive(self) -> List[sp.Symbol]:
        robot = self.ctx.robot
        phys = [p.symbol for p in robot.parameters.values() if p.kind in _POSITIVE_KINDS]
        return phys + self.names("positive")


def _latex(ctx, expr) -> str:
    if isinstance(expr, sp.MatrixBase) and expr.shape == (1, 1):
        expr = expr[0]
    return to_latex(expr, ctx.robot.coordinates)


def _plant(ctx, sp_: _Spec):
    """(equations M q'' + n, substitution of the task's parameter values)."""
    dyn = ctx.dynamics()
    subs = {symbol(k): sp_.expr(v, f"substitute.{k}") for k, v in (sp_.spec.get("substitute") or {}).items()}
    lhs = (dyn.M * sp.Matrix(dyn.ddq) + dyn.c + dyn.g + dyn.spring + dyn.friction).xreplace(subs)
    return lhs.applyfunc(sp.expand), subs


def _law(ctx, sp_: _Spec, subs, measured_name, measured, reference):
    """Input vector S u from the law option, with references and the measured force substituted."""
    robot = ctx.robot
    extra = {measured_name.name: measured}
    pos = sp_.spec.get("position_reference")
    if pos:
        if not isinstance(pos, dict) or "name" not in pos or "coordinate" not in pos:
            raise sp_.fail("position_reference", "expected {name, coordinate, estimates}")
        coord = symbol(str(pos["coordinate"]))
        if coord not in robot.q:
            raise sp_.fail("position_reference.coordinate", f"'{coord}' is not a coordinate of {robot.name}")
        est = {symbol(k): sp_.expr(v, f"position_reference.estimates.{k}") for k, v in (pos.get("estimates") or {}).items()}
        poly = sp.Poly(sp.expand(measured.xreplace(est) - reference), coord)
        if poly.degree() != 1:
            raise sp_.fail("position_reference", "the measured force must be linear in the coordinate")
        a, b = poly.all_coeffs()
        xd = sp.expand(-b / a)
        extra[str(pos["name"])] = xd
        ctx.step("Position giving the desired force",
                 rf"{_latex(ctx, symbol(str(pos['name'])))} = {_latex(ctx, xd)}",
                 "Where the measured force equals the desired one" + (" (with the estimated parameters)." if est else "."))
        sp_.answer(str(pos["name"]), xd)
    raw = sp_.spec.get("law")
    if raw is None:
        raise sp_.fail("law", "give the control law (input on the actuated coordinate)")
    actuated = [c for c, a in zip(robot.coordinates, robot.actuated) if a]
    if not isinstance(raw, dict):
        if len(actuated) != 1:
            raise sp_.fail("law", f"{robot.name} has {len(actuated)} actuated coordinates: give a mapping coordinate -> law")
        raw = {actuated[0]: raw}
    unknown = set(raw) - set(actuated)
    if unknown:
        raise sp_.fail("law", f"not actuated coordinates: {', '.join(sorted(unknown))} (actuated: {', '.join(actuated)})")
    S_u = sp.zeros(robot.n, 1)
    for i, c in enumerate(robot.coordinates):
        if c in raw:
            S_u[i] = sp.expand(sp_.expr(raw[c], f"law.{c}", extra).xreplace(subs))
    return S_u


@task("force_control")
def force_control_task(ctx, spec):
    """Closed loop of a linear model under a force control law (see the module docstring)."""
    sp_ = _Spec(ctx, spec, "force_control")
    robot = ctx.robot
    lhs, subs = _plant(ctx, sp_)
    meas = spec.get("measured")
    if not isinstance(meas, dict) or "name" not in meas or "expression" not in meas:
        raise sp_.fail("measured", "expected {name, expression}: the force read by the sensor")
    measured_name = symbol(str(meas["name"]))
    measured = sp.expand(sp_.expr(meas["expression"], "measured.expression").xreplace(subs))
    reference = symbol(str(spec.get("reference", "F_d")))
    integral = [symbol(str(spec["integral"]))] if spec.get("integral") else []
    bodies = [b.name for b in robot.bodies]
    actuated = [i for i, a in enumerate(robot.actuated) if a]
    u_syms = [symbol(f"u{k + 1}") for k in range(len(actuated))]
    S_u_open = sp.zeros(robot.n, 1)
    for k, i in enumerate(actuated):
        S_u_open[i] = u_syms[k]
    shown = ctx.__dict__.setdefault("_force_control_models", set())
    if str(lhs) not in shown:
        shown.add(str(lhs))
        ctx.step("Equations of motion", rf"{_latex(ctx, lhs)} = {_latex(ctx, S_u_open)}",
                 "Lagrangian model of the masses, springs and dampers; the control input acts on the actuated coordinate.",
                 bodies=bodies)
    sp_.answer("equations", lhs)
    sp_.answer("measured", measured)
    S_u = _law(ctx, sp_, subs, measured_name, measured, reference)
    closed = (lhs - S_u).applyfunc(sp.expand)
    equations = list(closed)
    if integral:
        z = integral[0]
        equations.append(lc.derivative_symbol(z.name, 1) - (reference - measured))
    ctx.step("Control law and closed loop",
             rf"{_latex(ctx, measured_name)} = {_latex(ctx, measured)},\quad u = {_latex(ctx, S_u)},\quad {_latex(ctx, closed)} = 0"
             + (rf",\quad \dot {_latex(ctx, integral[0])} = {_latex(ctx, reference - measured_name)}" if integral else ""),
             "The measured force is substituted in the law, and the law in the model.", joints=bodies)
    sp_.answer("law", S_u[actuated[0]] if len(actuated) == 1 else S_u)
    sp_.answer("closed_loop", closed)
    try:
        loop = lc.LinearLoop(equations, robot.q, integral, [reference])
    except lc.LinearLoopError as exc:
        raise sp_.fail("law", f"{exc} (force_control needs a linear model and law)") from None
    _steady_state(ctx, sp_, loop, S_u, measured, reference, actuated)
    _transfer_functions(ctx, sp_, loop, lhs, S_u_open, u_syms, measured, reference)
    char = loop.characteristic_polynomial()
    if spec.get("routh", True):
        _routh_steps(ctx, sp_, char)
    if spec.get("poles"):
        _poles(ctx, sp_, char, subs)


def _steady_state(ctx, sp_, loop, S_u, measured, reference, actuated):
    try:
        eq = loop.equilibrium()
    except lc.LinearLoopError as exc:
        ctx.step("Equilibrium", "", f"There is no unique equilibrium: {exc}.")
        return
    if eq.velocities:
        v = sp.Matrix([eq.velocities[d] for d in loop.dq if d in eq.velocities])
        ctx.step("Steady motion", r",\ ".join(rf"{_latex(ctx, d)} = {_latex(ctx, val)}" for d, val in eq.velocities.items()),
                 "The positions do not appear in the closed loop (no contact): the mass reaches a constant velocity.")
        sp_.answer("steady_velocity", v[0] if v.rows == 1 else v)
        return
    values = {**eq.values}
    for c in loop.q + loop.z:
        sp_.answer(f"{c.name}_e", values[c])
    F_e = sp.factor(measured.xreplace(values))
    u_e = S_u.xreplace(values).xreplace({d: 0 for d in loop.dq}).applyfunc(sp.factor)
    e_F = sp.factor(reference - F_e)
    sp_.answer("equilibrium", sp.Matrix([values[c] for c in loop.q]))
    sp_.answer("F_e", F_e)
    sp_.answer("e_F", e_F)
    sp_.answer("u_e", u_e[actuated[0]] if len(actuated) == 1 else u_e)
    parts = [rf"{{{_latex(ctx, c)}}}_e = {_latex(ctx, values[c])}" for c in loop.q + loop.z]
    ctx.step("Equilibrium and force error",
             r",\quad ".join(parts + [rf"F_e = {_latex(ctx, F_e)}", rf"F_d - F_e = {_latex(ctx, e_F)}"]),
             "Velocities and accelerations set to zero" + (", and the integrated error stops changing." if loop.z else "."))
    lyap = loop.lyapunov(eq)
    if lyap:
        V, V_dot = lyap
        sp_.answer("V", V)
        sp_.answer("V_dot", V_dot)
        ctx.step("Lyapunov function", rf"V = \tfrac12 \dot q^T M \dot q + \tfrac12 (q - q_e)^T K (q - q_e),\quad \dot V = {_latex(ctx, V_dot)}",
                 "Kinetic energy plus the closed-loop elastic energy about the equilibrium; its derivative along the loop "
                 "vanishes only at zero velocity, where the dynamics push towards the equilibrium (LaSalle).")


def _transfer_functions(ctx, sp_, loop, lhs, S_u_open, u_syms, measured, reference):
    texts = []
    if len(u_syms) == 1:
        plant = lc.LinearLoop(list((lhs - S_u_open).applyfunc(sp.expand)), loop.q, [], u_syms)
        num_p, den_p = plant.transfer(measured)
        P = num_p / den_p
        sp_.answer("P", P)
        sp_.answer("P_num", num_p)
        sp_.answer("open_loop_poly", den_p)
        texts.append(rf"P(s) = \frac{{F_m(s)}}{{u(s)}} = \frac{{{_latex(ctx, num_p)}}}{{{_latex(ctx, den_p)}}}")
        for q in loop.q:
            nq, dq_ = plant.transfer(q)
            sp_.answer(f"H_{q.name}", nq / dq_)
    num_w, den_w = loop.transfer(measured)
    W = num_w / den_w
    sp_.answer("W", W)
    sp_.answer("W_e", sp.factor(sp.cancel(1 - W)))
    if num_w != 0 and sp.cancel(1 - W) != 0:
        G = sp.factor(sp.cancel(W / (1 - W)))
        sp_.answer("G", G)
        texts.append(rf"G(s) = \frac{{W}}{{1 - W}} = {_latex(ctx, G)}")
    sp_.answer("char_poly", den_w)
    texts.insert(0, rf"W(s) = \frac{{F_m(s)}}{{F_d(s)}} = \frac{{{_latex(ctx, num_w)}}}{{{_latex(ctx, den_w)}}}")
    ctx.step("Transfer functions", r",\quad ".join(texts),
             "Laplace transform of the deviations from the equilibrium; the poles are the roots of the characteristic polynomial.")


def _routh_steps(ctx, sp_, char):
    poly = sp.Poly(sp.expand(char), lc.s)
    zeros = 0
    while poly.degree() > 0 and poly.all_coeffs()[-1] == 0:
        poly, zeros = sp.Poly(sp.cancel(poly.as_expr() / lc.s), lc.s), zeros + 1
    if zeros:
        sp_.answer("poles_at_zero", zeros)
        ctx.step("Poles at the origin", rf"a(s) = s^{{{zeros}}}\left({_latex(ctx, sp.collect(poly.as_expr(), lc.s))}\right)",
                 f"{zeros} pole(s) at $s = 0$: the loop is not asymptotically stable in position; the Routh criterion "
                 "below is for the other poles.")
        char = poly.as_expr()
    positive = sp_.positive()
    column, conditions = lc.routh_conditions(poly, positive)
    sp_.answer("routh_column", sp.Matrix(column))
    sp_.answer("conditions", list(conditions))
    bounds = []
    assumed = positive + [c for c in conditions if isinstance(c, sp.Symbol)]
    for gain in sp_.names("solve_for"):
        found: Dict[str, List[sp.Expr]] = {"min": [], "max": []}
        for cond in conditions:
            gb = lc.solve_linear_condition(cond, gain, [a for a in assumed if a != gain]) if cond.has(gain) else None
            if gb is None:
                continue
            found["min" if gb.relation == ">" else "max"].append(gb.bound)
            bounds.append(rf"{_latex(ctx, gain)} {gb.relation} {_latex(ctx, gb.bound)}")
        for side, values in found.items():
            if values:
                sp_.answer(f"{gain.name}_{side}", values[0] if len(values) == 1 else sp.Matrix(values))
    small = sum(sp.count_ops(c) for c in column) < 400
    shown = (rf"\text{{first column: }} {_latex(ctx, sp.Matrix(column).T)},\quad " if small else "") + \
        r",\ ".join([rf"{_latex(ctx, c)} > 0" for c in conditions if sp.count_ops(c) < 120] + bounds)
    ctx.step("Routh criterion", rf"a(s) = {_latex(ctx, sp.collect(sp.expand(char), lc.s))},\quad " + shown,
             "All closed-loop poles have negative real part iff the first column of the Routh table keeps one sign "
             "(positive physical parameters).")


def _poles(ctx, sp_, char, subs):
    pol = sp_.spec["poles"]
    if not isinstance(pol, dict) or "gain" not in pol:
        raise sp_.fail("poles", "expected {gain, values}")
    gain = symbol(str(pol["gain"]))
    values = {}
    for name, value in ctx.robot.parameter_values().items():
        values[symbol(name)] = float(value)
    for name, value in ctx.given.items():
        if isinstance(value, (int, float, str)) and name != gain.name:
            try:
                values[symbol(name)] = float(sp_.expr(value, f"given.{name}").evalf())
            except (TypeError, ValueError):
                continue
    values.update({k: float(v) for k, v in subs.items() if v.is_number})
    try:
        intervals = lc.stability_boundaries(char, gain, values)
    except lc.LinearLoopError as exc:
        raise sp_.fail("poles", str(exc)) from None
    gains = [float(sp_.expr(v, "poles.values").evalf()) for v in (pol.get("values") or [])]
    poly = sp.Poly(sp.expand(char.xreplace(values)), lc.s)
    reals = [lc.max_real_part([float(c.subs(gain, g)) for c in poly.all_coeffs()]) for g in gains]
    sp_.answer("max_real_part", reals)
    sp_.answer("stable_at", [bool(r < 0) for r in reals])
    sp_.answer("stable_intervals", [[a, b, 1 if st else 0] for a, b, st in intervals])
    sp_.answer("stable_for_all_gains", all(st for _a, _b, st in intervals))
    if len(intervals) > 1:
        sp_.answer("critical_gain", intervals[0][1])
    rows = [rf"{_latex(ctx, gain)} = {num(g)}:\ \max \operatorname{{Re}} p = {num(r)}" for g, r in zip(gains, reals)]
    infinity = r"\infty"
    ranges = [rf"[{num(a)}, {num(b) if b < 1e8 else infinity})\ \text{{{'stable' if st else 'unstable'}}}" for a, b, st in intervals]
    ctx.step(f"Closed-loop poles as ${_latex(ctx, gain)}$ grows", r",\quad ".join(rows + ranges),
             "Numeric roots of the characteristic polynomial with the exercise's numbers; the interval ends are where a "
             "Routh entry changes sign (poles crossing the imaginary axis).")


@task("routh")
def routh_task(ctx, spec):
    """Routh criterion on a polynomial of the exercise (see the module docstring)."""
    sp_ = _Spec(ctx, spec, "routh")
    if "polynomial" not in spec:
        raise sp_.fail("polynomial", "give the polynomial in s")
    expr = sp.expand(sp_.expr(spec["polynomial"], "polynomial", extra={"s": lc.s}))
    if not expr.has(lc.s):
        raise sp_.fail("polynomial", "the polynomial must contain s")
    _routh_steps(ctx, sp_, expr)
