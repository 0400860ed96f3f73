"""Kinematic tasks: Jacobians (symbolic and at a configuration), singularity analysis, positions.

Data conventions shared by the tasks of this module and of ``redundancy``, ``planning`` and
``contact`` (see ``TaskData``): a value in a task spec is a number, a list, an expression string
("pi/6", "l1/2"), the name of an entry of ``given`` or the name of an earlier answer; expressions
may combine vectors element by element ("Pd - J_position", "0.5*grad"). A
configuration ``q`` is a list, a given name (``qa: [0, pi/2, pi/2, 0]``) or, by default, the
coordinates found in ``given`` (q1, q2, ...) completed by the exercise's ``configuration``.
Robot parameters take the robot file's values, overridden by ``given``.

Task kinds
----------
``jacobian``: ``name`` (default J) and one of
  - ``point`` (a named point or ``{body, at}``) with ``components`` (x, y, z, angle, wx, wy, wz;
    default [x, y]) and optional ``frame`` (a body: rows expressed in that link's frame),
  - ``body`` with ``components`` [angle] (planar orientation of a link),
  - ``expression``: a list of expressions of the coordinates r(q) (analytic Jacobian dr/dq),
  - ``matrix``: a numeric matrix given by the exercise,
  - ``stack``: names of earlier Jacobians to stack (extended / augmented Jacobian).
  Options: ``q``, ``parameters`` (values for this task only, e.g. lengths in other units),
  ``derivative: true`` (J'(q, dq) dq, answer ``<name>_dot_dq``), ``singularities: true`` (symbolic det J or det(J J^T) and the numeric
  rank, null space and left null space), ``minors: true`` (det J_{-i}), ``pinv: true``,
  ``position: true`` (the task value r(q)).
  Answers: ``<name>`` (symbolic), ``<name>_num``, ``<name>_rank``, ``<name>_null``,
  ``<name>_left_null``, ``<name>_det``, ``<name>_minors`` (list, in order of the deleted columns),
  ``<name>_pinv``, ``<name>_position``, ``<name>_manipulability``.
``forward_kinematics``: ``points`` (mapping label -> point) at ``q``: answers ``p_<label>``
  (numeric) and ``p_<label>_expr`` (symbolic).

Highlight keys emitted in steps (for the 3D walkthrough): ``configuration`` (coordinate values),
``points`` ([{label, position}]), ``vectors`` ([{label, origin, vector, role}], role in desired,
achieved, error, force, gradient), ``joint_values`` ([{label, values, lower?, upper?, saturated?,
violating?}]: one value per joint, e.g. velocities with their bounds), ``scale`` (task scaling),
``profile`` (timing law), ``path`` ([[x, y, z], ...]).
"""
from __future__ import annotations

from typing import Any, Dict, List, Optional

import numpy as np
import sympy as sp

from .. import jacobians as jac
from ..errors import UserError
from ..exercise import ExerciseError
from ..expressions import ExpressionError, parse_expression
from ..latex import mat, num, vec
from ..numeric import numeric_function
from ..steps import symbol_latex, to_latex
from . import task


class TaskData:
    """Numbers of an exercise as the numeric tasks see them (see the module docstring)."""

    def __init__(self, ctx):
        self.ctx = ctx
        self.robot = ctx.robot
        self.store: Dict[str, Any] = ctx.__dict__.setdefault("_numeric_objects", {})

    # ---------------------------------------------------------------- values
    @property
    def params(self) -> Dict[str, float]:
        values = dict(self.robot.parameter_values())
        for k in values:
            if k in self.ctx.given:
                values[k] = self.number(self.ctx.given[k], k)
        return values

    def _fail(self, what: str) -> ExerciseError:
        return ExerciseError(f"{self.ctx.exercise.source or self.ctx.exercise.id}: {what}")

    def number(self, value, where: str = "value", _depth: int = 0, q=None) -> float:
        arr = self.array(value, where, _depth, q)
        if arr.size != 1:
            raise self._fail(f"{where}: expected a number, got {value!r}")
        return float(arr.reshape(-1)[0])

    def array(self, value, where: str = "value", _depth: int = 0, q=None) -> np.ndarray:
        """A number, list, expression, given name or answer name -> numpy array (expressions may
        use the coordinates when a configuration ``q`` is passed)."""
        if _depth > 20:
            raise self._fail(f"{where}: circular definition")
        if isinstance(value, bool):
            raise self._fail(f"{where}: expected a number, got {value!r}")
        if isinstance(value, (int, float)):
            return np.array(float(value))
        if isinstance(value, np.ndarray):
            return value.astype(float)
        if isinstance(value, sp.MatrixBase):
            return np.array(value.evalf(), dtype=float)
        if isinstance(value, (list, tuple)):
            items = [self.array(v, where, _depth + 1, q) for v in value]
            try:
                return np.array(items, dtype=float)
            except ValueError:
                raise self._fail(f"{where}: rows of different lengths in {value!r}") from None
        if isinstance(value, str):
            key = value.strip()
            if key in self.ctx.answers:
                return self.array(self.ctx.answers[key], where, _depth + 1, q)
            if key in self.ctx.given:
                return self.array(self.ctx.given[key], key, _depth + 1, q)
            return self._vector_expression(key, where, q, _depth + 1)
        if isinstance(value, sp.Basic):
            return np.array(float(value))
        raise self._fail(f"{where}: cannot read {value!r} as a number")

    def _vector_expression(self, text: str, where: str, q, _depth: int) -> np.ndarray:
        """An expression whose names may be vectors or matrices (given entries, answers): evaluated
        element by element, e.g. ``Pd - J_position`` or ``0.5*grad``."""
        expr = self.expression(text, where)
        names = [s.name for s in expr.free_symbols]
        if not any(n in self.ctx.answers or (n in self.ctx.given and isinstance(self.ctx.given[n], list)) for n in names):
            return np.array(self.evaluate(text, where, q, _depth))
        syms = sorted(expr.free_symbols, key=lambda s: s.name)
        values = []
        coords = dict(zip(self.robot.coordinates, q)) if q is not None else {}
        params = self.robot.parameter_values()
        for s in syms:
            if s.name in coords:
                values.append(float(coords[s.name]))
            elif s.name in self.ctx.answers or s.name in self.ctx.given:
                values.append(self.array(s.name, where, _depth + 1, q))
            elif s.name in params:
                values.append(float(params[s.name]))
            else:
                raise self._fail(f"{where}: no value for {s.name} in {text!r}")
        try:
            return np.asarray(numeric_function(syms, expr, "numpy")(*values), dtype=float)
        except (ValueError, TypeError) as exc:
            raise self._fail(f"{where}: cannot combine the values of {text!r} ({exc})") from None

    def scalars(self) -> Dict[str, float]:
        """Every given scalar and robot parameter, as numbers (for expressions)."""
        out = dict(self.params)
        for k, v in self.ctx.given.items():
            if k in out or isinstance(v, (list, dict)):
                continue
            try:
                out[k] = self.number(v, k)
            except UserError:
                continue
        return out

    def evaluate(self, text: str, where: str = "expression", q=None, _depth: int = 0) -> float:
        """Numeric value of an expression; its names are given entries, answers, robot parameters
        or (with ``q``) coordinates."""
        expr = self.expression(text, where)
        subs = {}
        params = None
        coords = dict(zip(self.robot.coordinates, q)) if q is not None else {}
        for sym in expr.free_symbols:
            name = sym.name
            if name in coords:
                subs[sym] = float(coords[name])
            elif name in self.ctx.answers or name in self.ctx.given:
                subs[sym] = self.number(name, where, _depth + 1)
            else:
                params = params if params is not None else self.robot.parameter_values()
                if name not in params:
                    raise self._fail(f"{where}: no value for {name} in {text!r}")
                subs[sym] = float(params[name])
        return float(expr.xreplace(subs).evalf())

    def expression(self, text, where: str = "expression") -> sp.Expr:
        try:
            return parse_expression(text)
        except ExpressionError as exc:
            raise self._fail(f"{where}: {exc}") from None

    def substitute(self, expr):
        """Replace the names of an expression that are neither coordinates nor robot parameters by
        their values from the exercise (e.g. a contact distance l_c2 used in a point)."""
        names = set(self.robot.coordinates) | set(self.robot.parameters)
        extra = {s: self.number(s.name, s.name) for s in sp.sympify(expr).free_symbols if s.name not in names}
        return expr.xreplace(extra) if extra else expr

    def configuration(self, spec=None) -> np.ndarray:
        n = self.robot.n
        if spec is not None:
            q = self.array(spec, "q").reshape(-1)
        else:
            conf = dict(self.ctx.exercise.configuration)
            for c in self.robot.coordinates:
                if c in self.ctx.given:
                    conf[c] = self.ctx.given[c]
            missing = [c for c in self.robot.coordinates if c not in conf]
            if missing:
                raise self._fail(f"no value for {', '.join(missing)}: give q in the task, or the coordinates in given")
            q = np.array([self.number(conf[c], c) for c in self.robot.coordinates])
        if q.size != n:
            raise self._fail(f"q: expected {n} values, got {q.size}")
        return q

    def bounds(self, spec, n: int, where: str = "bounds"):
        """{lower, upper} or {max} (symmetric) -> (lower, upper) arrays."""
        if not isinstance(spec, dict):
            raise self._fail(f"{where}: expected {{max: [...]}} or {{lower: [...], upper: [...]}}")
        if "max" in spec:
            hi = self.array(spec["max"], where) * np.ones(n)
            return -hi, hi
        return self.array(spec["lower"], where) * np.ones(n), self.array(spec["upper"], where) * np.ones(n)

    # ---------------------------------------------------------------- Jacobians
    def jacobian(self, ref, where: str = "jacobian") -> np.ndarray:
        """A numeric Jacobian: the name of an earlier ``jacobian`` task or a matrix."""
        if isinstance(ref, str) and ref in self.store:
            return self.store[ref]["num"]
        J = self.array(ref, where)
        return np.atleast_2d(J)

    def drift(self, ref: str, dq, where: str = "joint_velocity") -> np.ndarray:
        """J'(q, q') q' for a symbolic Jacobian of an earlier task, at that task's configuration."""
        obj = self.store.get(ref) if isinstance(ref, str) else None
        if obj is None or obj["sym"] is None or obj["q"] is None:
            raise self._fail(f"{where}: J' q' needs the Jacobian of an earlier jacobian task defined on the robot")
        dq = self.array(dq, where).reshape(-1)
        J = obj["sym"]
        Jdot = sp.zeros(*J.shape)
        for qk, vk in zip(self.robot.q, dq):
            if vk:
                Jdot += J.diff(qk) * float(vk)
        return np.atleast_2d(jac.evaluate(self.robot, Jdot, obj["q"], self.params)) @ dq


def data(ctx) -> TaskData:
    return TaskData(ctx)


def _components(spec) -> List[str]:
    comps = spec.get("components", ["x", "y"])
    if isinstance(comps, str):
        comps = [comps]
    return list(comps)


@task("jacobian")
def jacobian_task(ctx, spec):
    """A task Jacobian, symbolic and at a configuration, with optional singularity analysis."""
    d = data(ctx)
    robot = d.robot
    name = spec.get("name", "J")
    L = lambda e: to_latex(e, robot.coordinates)
    J_sym, r_sym, J_num, what = None, None, None, ""
    if "matrix" in spec:
        J_num = np.atleast_2d(d.array(spec["matrix"], f"{name}.matrix"))
        what = "given by the exercise"
    elif "stack" in spec:
        parts = [d.store[p] if p in d.store else None for p in spec["stack"]]
        missing = [p for p, obj in zip(spec["stack"], parts) if obj is None]
        if missing:
            raise d._fail(f"{name}.stack: unknown Jacobian(s) {missing} (define them in earlier jacobian tasks)")
        J_num = np.vstack([p["num"] for p in parts])
        if all(p["sym"] is not None for p in parts):
            J_sym = sp.Matrix.vstack(*[p["sym"] for p in parts])
        what = "stacked " + ", ".join(f"${_tex(p)}$" for p in spec["stack"])
    elif "expression" in spec:
        exprs = spec["expression"] if isinstance(spec["expression"], list) else [spec["expression"]]
        r_sym = sp.Matrix([d.expression(e, f"{name}.expression") for e in exprs])
        J_sym = r_sym.jacobian(sp.Matrix(robot.q)).applyfunc(sp.expand)
        what = "analytic Jacobian of the task function"
    else:
        comps = _components(spec)
        try:
            J_sym = jac.jacobian(robot, spec.get("point"), comps, spec.get("body"), spec.get("frame"))
            r_sym = jac.task_function(robot, spec.get("point"), comps, spec.get("body")) if "frame" not in spec else None
        except UserError as exc:
            raise d._fail(f"{name}: {exc}") from None
        what = (f"rows {', '.join(f'${_tex(c)}$' for c in comps)} of {_point_text(spec.get('point') or spec.get('body'), robot)}"
                + (f" in the frame of {spec['frame']}" if spec.get("frame") else ""))
    q = None
    params = d.params
    for k, v in (spec.get("parameters") or {}).items():
        if k not in params:
            raise d._fail(f"{name}.parameters: {robot.name} has no parameter '{k}'")
        params[k] = d.number(v, f"{name}.parameters.{k}")
    if J_num is None:
        q = d.configuration(spec.get("q"))
        J_num = np.atleast_2d(jac.evaluate(robot, d.substitute(J_sym), q, params))
    d.store[name] = {"sym": J_sym, "num": J_num, "r": r_sym, "q": q}
    if J_sym is not None:
        ctx.step(f"Jacobian ${_tex(name)}$", f"{_tex(name)}(q) = " + L(J_sym), f"{what[:1].upper() + what[1:]}.")
        ctx.answer(name, J_sym)
    conf = {c: float(v) for c, v in zip(robot.coordinates, q)} if q is not None else {}
    ctx.step(f"${_tex(name)}$ at the configuration", f"{_tex(name)} = " + mat(J_num),
             ("At $" + ", ".join(f"{to_latex(robot.q[k], robot.coordinates)} = {num(v)}" for k, v in enumerate(conf.values()))
              + "$.") if conf else "Numeric matrix.",
             configuration=conf)
    ctx.answer(f"{name}_num", J_num)
    if spec.get("position") and r_sym is not None and q is not None:
        r_num = np.asarray(jac.evaluate(robot, d.substitute(r_sym), q, params), float).reshape(-1)
        ctx.step(f"Task value", f"r(q) = " + L(r_sym) + " = " + vec(r_num), "")
        ctx.answer(f"{name}_position", r_num)
    if spec.get("derivative") and J_sym is not None:
        Jdot = sum((J_sym.diff(qk) * dqk for qk, dqk in zip(robot.q, robot.dq)), sp.zeros(*J_sym.shape))
        Jdot_dq = (Jdot * sp.Matrix(robot.dq)).applyfunc(sp.expand)
        ctx.step("Velocity-dependent term", rf"\dot {_tex(name)}(q, \dot q)\,\dot q = " + L(Jdot_dq),
                 r"Second-order kinematics: $\ddot p = J \ddot q + \dot J \dot q$.")
        ctx.answer(f"{name}_dot_dq", Jdot_dq)
    a = jac.analyze(J_num, float(spec.get("threshold", jac.DEFAULT_THRESHOLD)))
    ctx.answer(f"{name}_rank", a.rank)
    if spec.get("singularities"):
        if J_sym is not None:
            D = jac.determinant_condition(J_sym)
            T = _tex(name)
            label = rf"\det {T}" if J_sym.rows == J_sym.cols else rf"\det({T} {T}^T)"
            ctx.step("Singularity condition", label + " = " + L(D), "The configurations where it vanishes are singular.")
            ctx.answer(f"{name}_det", D)
        text = (f"Rank {a.rank} of {J_num.shape[0]}: singular values {', '.join(num(s) for s in a.singular_values)}. ")
        if a.null_space.shape[1]:
            text += "Null-space columns are joint motions that leave the task still (self motions). "
        if a.left_null_space.shape[1]:
            text += "Left null-space columns are task directions no joint velocity can produce; forces along them are balanced by the structure with zero joint torques ($J^T F = 0$)."
        ctx.step("Rank and null spaces",
                 rf"\mathrm{{rank}}\,{_tex(name)} = {a.rank},\quad \mathcal{{N}}({_tex(name)}) = \mathrm{{span}}\," + mat(a.null_space if a.null_space.size else np.zeros((J_num.shape[1], 1)))
                 + (rf",\quad \mathcal{{N}}({_tex(name)}^T) = \mathrm{{span}}\," + mat(a.left_null_space) if a.left_null_space.shape[1] else ""),
                 text.strip())
        ctx.answer(f"{name}_null", a.null_space)
        ctx.answer(f"{name}_left_null", a.left_null_space)
        ctx.answer(f"{name}_manipulability", a.manipulability)
    if spec.get("minors"):
        minors = jac.column_minors(J_num)
        ctx.step("Square minors", r",\ ".join(rf"\det {_tex(name)}_{{-{','.join(map(str, k))}}} = {num(v)}" for k, v in minors.items()),
                 "Determinants of the square submatrices obtained by deleting columns.")
        ctx.answer(f"{name}_minors", list(minors.values()))
    if spec.get("pinv"):
        from ..redundancy import pinv
        P = pinv(J_num, float(spec.get("threshold", jac.DEFAULT_THRESHOLD)))
        ctx.step("Pseudoinverse", f"{_tex(name)}^\\# = " + mat(P), "From the SVD with an absolute threshold.")
        ctx.answer(f"{name}_pinv", P)


def _tex(name: str) -> str:
    """LaTeX of a Jacobian's or component's name (``J_cm`` -> ``J_{cm}``, ``j1`` -> ``j_{1}``)."""
    return symbol_latex(str(name))


def _point_text(point, robot) -> str:
    """A point of a task for a sentence: its name, or "the point at (x, y, z) of link2"."""
    if isinstance(point, dict):
        at = point.get("at")
        where = f" at ${to_latex(sp.Matrix([parse_expression(str(v)) for v in at]).T, robot.coordinates)}$" if at else ""
        return f"the point{where} of {point.get('body', 'the last link')}"
    return str(point).replace("_", " ")


@task("forward_kinematics")
def forward_kinematics_task(ctx, spec):
    """Positions of points at a configuration: ``points: {label: point}``."""
    d = data(ctx)
    q = d.configuration(spec.get("q"))
    pts = spec.get("points") or {"ee": "ee"}
    shown = []
    for label, point in pts.items():
        try:
            body, local = jac.point_location(d.robot, point)
        except UserError as exc:
            raise d._fail(f"forward_kinematics.{label}: {exc}") from None
        p_sym = jac._kinematics(d.robot).point_position(body, local)
        p = np.asarray(jac.evaluate(d.robot, p_sym, q, d.params), float).reshape(-1)
        if d.robot.is_planar:
            p_sym, p = p_sym[:2, :], p[:2]
        ctx.answer(f"p_{label}_expr", p_sym)
        ctx.answer(f"p_{label}", p)
        shown.append({"label": label, "position": (list(p) + [0.0])[:3]})
        ctx.step(f"Position of {label}", f"p_{{{label}}} = " + to_latex(p_sym, d.robot.coordinates) + " = " + vec(p), "",
                 points=[shown[-1]], configuration={c: float(v) for c, v in zip(d.robot.coordinates, q)})
