"""What one task sees of its exercise: ``TaskView``, the one adapter every task module builds on the
``TaskContext`` it is given (``TaskView(ctx)``, or ``TaskView(ctx, spec, kind)`` for messages that
name the task's options and for a task's ``suffix`` and ``substitute``), and the two ways the tasks
write a symbolic result compactly.

A view gives
- the robot's symbolic model, derived on first use: ``dyn``, ``M``, ``C``, ``c``, ``g``, ``k``
  (springs), ``n`` = c + g + k + friction, ``q``, ``dq``, ``ddq``, the natural angles, the printer
  ``L`` and the simplifiers ``tidy`` / ``tidy_cancelled``;
- the exercise's numbers as the numeric tasks read them: a value in a task spec is a number, a list,
  an expression string ("pi/6", "l1/2"), the name of an entry of ``given`` or the name of an earlier
  answer; expressions may combine vectors element by element ("Pd - J_position", "0.5*grad"). A
  configuration ``q`` is a list, a given name (``qa: [0, pi/2, pi/2, 0]``) or, by default, the
  coordinates found in ``given`` (q1, q2, ...) completed by the exercise's ``configuration``.
  Robot parameters take the robot file's values, overridden by ``given``;
- ``objects``: what earlier tasks of the exercise left for later ones (e.g. a named Jacobian).

>>> from app.core.expressions import symbol
>>> q, m = symbol("q"), symbol("m")
>>> tidy_quotient((sp.cos(q)**2 + sp.sin(q)**2) / m), tidy_cancelled((sp.sin(q)**2 + sp.cos(q)**2) * m / 2)
(1/m, m/2)
"""
from __future__ import annotations

from functools import cached_property
from typing import Any, Dict, List, Optional, Sequence, Tuple

import numpy as np
import sympy as sp

from .. import jacobians as jac
from ..dynamics import natural_angles, pretty
from ..errors import UserError
from ..exercise import ExerciseError
from ..expressions import ExpressionError, parse_expression, parse_number, symbol
from ..kinematics import Kinematics
from ..numeric import numeric_function
from ..robot import RESERVED_NAMES
from ..steps import to_latex
from ..trig import TrigPoly


# ====================================================================== compact forms
def tidy_quotient(expr, angles: Sequence = ()) -> sp.Expr:
    """Compact form of a rational trigonometric expression, the way results are written by hand:
    numerator and denominator through the exact canonical form, their common factor cancelled; a
    denominator free of trigonometric terms d gives polynomial part + remainder / d."""
    expr = sp.sympify(expr)
    if expr.is_number or not expr.free_symbols:
        return expr
    num, den = sp.fraction(sp.together(expr))
    num_tp = TrigPoly.from_expr(sp.expand(num)).expand()
    den_tp = TrigPoly.from_expr(sp.expand(den)).expand()
    common = sp.gcd_list(list(num_tp.terms.values()) + list(den_tp.terms.values()))
    if common != 0 and common != 1:
        num_tp = TrigPoly({k: sp.cancel(c / common) for k, c in num_tp.terms.items()})
        den_tp = TrigPoly({k: sp.cancel(c / common) for k, c in den_tp.terms.items()})
    if all(not freq for (freq, _kind) in den_tp.terms):
        d = den_tp.to_expr()
        if d == 0:
            raise ZeroDivisionError("denominator is zero")
        if d.is_number:
            return pretty(TrigPoly({k: c / d for k, c in num_tp.terms.items()}), angles)
        # polynomial part + remainder / d, the way the results are written by hand
        gens = sorted(d.free_symbols, key=lambda x: x.name)
        quot, rem = {}, {}
        for k, c in num_tp.terms.items():
            qk, rk = sp.div(sp.expand(c), d, *gens)
            quot[k], rem[k] = qk, rk
        rem_tp = TrigPoly(rem)
        whole = pretty(TrigPoly(quot), angles)
        return whole + (pretty(rem_tp, angles) / d if rem_tp.terms else 0)
    return pretty(num_tp, angles) / pretty(den_tp, angles)


def tidy_quotient_matrix(mat, angles: Sequence = ()) -> sp.Matrix:
    return sp.Matrix(mat).applyfunc(lambda e: tidy_quotient(e, angles))


def tidy_cancelled(expr, angles: Sequence = ()) -> sp.Expr:
    """Compact form of a (possibly rational) trigonometric expression: cancelled first, then the
    exact canonical form of its numerator and denominator (a float constant becomes exact).

    >>> q = symbol("q")
    >>> tidy_cancelled((sp.sin(q)**2 + sp.cos(q)**2) * symbol("m") / 2)
    m/2
    """
    expr = sp.sympify(expr)
    if not expr.free_symbols:
        return sp.nsimplify(expr) if expr.is_Float else expr
    num, den = sp.fraction(sp.cancel(sp.together(expr)))
    num_tp = TrigPoly.from_expr(sp.expand(num)).expand()
    den_tp = TrigPoly.from_expr(sp.expand(den)).expand()
    if all(not freq for (freq, _kind) in den_tp.terms):
        d = den_tp.to_expr()
        num_tp = TrigPoly({k: sp.factor(sp.cancel(c / d)) for k, c in num_tp.terms.items()})
        return pretty(num_tp, angles)
    return pretty(num_tp, angles) / pretty(den_tp, angles)


# ====================================================================== small rules
def is_zero(expr) -> bool:
    """Whether a (possibly rational) trigonometric expression is identically zero."""
    expr = sp.sympify(expr)
    num, _den = sp.fraction(sp.cancel(sp.together(expr)))
    return TrigPoly.from_expr(sp.expand(num)).is_zero()


def wrap_angle(value):
    """A rational multiple of pi brought into (-pi, pi]; other values unchanged.

    >>> wrap_angle(3*sp.pi/2), wrap_angle(-sp.pi), wrap_angle(sp.Symbol("x"))
    (-pi/2, pi, x)
    """
    r = sp.nsimplify(value / sp.pi) if value.is_number else None
    if r is None or not r.is_Rational:
        return value
    r = r - 2 * sp.floor((r + 1) / 2)        # into [-1, 1)
    if r == -1:
        r = sp.Integer(1)
    return r * sp.pi


# ====================================================================== the view
def _applied(term: str) -> cached_property:
    """A TaskView property: the dynamic model's ``term`` with the task's values applied, computed once."""
    prop = cached_property(lambda view: view.apply(getattr(view.dyn, term)))
    prop.__doc__ = f"The model's {term} with the task's values applied."
    return prop


class TaskView:
    """One task's view of its exercise (see the module docstring)."""

    def __init__(self, ctx, spec: Optional[dict] = None, kind: str = ""):
        self.ctx, self.kind = ctx, kind
        self.spec = spec if spec is not None else {}
        self.robot = ctx.robot
        self.coords = list(self.robot.coordinates)
        self.q = sp.Matrix(self.robot.q)
        self.dq = sp.Matrix(self.robot.dq)
        self.ddq = sp.Matrix(self.robot.ddq)
        self.suffix = str(self.spec.get("suffix", ""))
        self.subs: Dict[sp.Symbol, sp.Expr] = {}
        if spec is not None:        # a task with options: its model read first, then its substitutions
            _ = self.dyn
            self.subs = self.substitution(self.spec.get("substitute") or {}, "substitute")

    @property
    def objects(self) -> Dict[str, Any]:
        """What earlier tasks of the exercise left for later ones (``TaskContext.objects``)."""
        return self.ctx.objects

    # ---------------------------------------------------------------- symbolic model
    @cached_property
    def dyn(self):
        return self.ctx.dynamics()

    @cached_property
    def kin(self) -> Kinematics:
        return Kinematics(self.robot)

    @cached_property
    def angles(self) -> list:
        return natural_angles(self.kin)

    #: the model's terms with the task's values applied: M(q), C(q, q'), c, g(q) and the springs k(q)
    M = _applied("M")
    C = _applied("C")
    c = _applied("c")
    g = _applied("g")
    k = _applied("spring")

    @cached_property
    def n(self) -> sp.Matrix:
        """n(q, q') = c + g + k + friction (M q'' + n = S u)."""
        return self.dyn.c + self.dyn.g + self.dyn.spring + self.dyn.friction

    def apply(self, obj):
        """The task's ``substitute`` applied to an expression or a matrix."""
        if not self.subs:
            return obj
        return obj.subs(self.subs) if isinstance(obj, sp.MatrixBase) else sp.sympify(obj).subs(self.subs)

    def L(self, expr) -> str:
        return to_latex(expr, self.coords)

    def tidy(self, expr):
        return tidy_quotient(expr, self.angles)

    def tidy_matrix(self, mat):
        return tidy_quotient_matrix(mat, self.angles)

    def tidy_cancelled(self, expr) -> sp.Expr:
        return tidy_cancelled(expr, self.angles)

    def tidy_cancelled_matrix(self, mat) -> sp.Matrix:
        return sp.Matrix(mat).applyfunc(self.tidy_cancelled)

    def answer(self, name: str, value) -> None:
        """An answer, named with the task's ``suffix``."""
        self.ctx.answer(name + self.suffix, value)

    def angle_coordinates(self) -> List[sp.Symbol]:
        """Coordinates that enter a revolute joint (they are angles)."""
        out = set()
        for body in self.robot.bodies:
            if body.joint.type == "revolute":
                out |= body.joint.value.free_symbols & set(self.q)
        return [s for s in self.q if s in out]

    def bodies_moved_by(self, coordinate: sp.Symbol) -> List[str]:
        names = []
        for body in self.robot.bodies:
            chain = self.robot.chain(body.name)
            if any(coordinate in b.joint.value.free_symbols for b in chain):
                names.append(body.name)
        return names

    def bodies_of(self, idx: Sequence[int]) -> List[str]:
        """Bodies whose joint is moved by the given coordinates (for highlighting)."""
        syms = {self.q[i] for i in idx}
        return [b.name for b in self.robot.bodies if b.joint.value.free_symbols & syms]

    def selection(self, actuated: Sequence[bool]) -> sp.Matrix:
        cols = [i for i, a in enumerate(actuated) if a]
        S = sp.zeros(len(actuated), len(cols))
        for k, i in enumerate(cols):
            S[i, k] = 1
        return S

    # ---------------------------------------------------------------- symbolic input
    def where(self, option: str) -> str:
        return f"{self.ctx.exercise.source or self.ctx.exercise.id}: {self.kind}.{option}"

    def fail(self, option: str, what: str) -> ExerciseError:
        """A refusal that names the task's option."""
        return ExerciseError(f"{self.where(option)}: {what}")

    def _fail(self, what: str) -> ExerciseError:
        """A refusal that names the exercise."""
        return ExerciseError(f"{self.ctx.exercise.source or self.ctx.exercise.id}: {what}")

    def expr(self, value, option: str) -> sp.Expr:
        """An expression of an option that must read back as symbols in the JSON answers."""
        out = self.ctx.expr(value, f"{self.kind}.{option}")
        clash = sorted(s.name for s in out.free_symbols if s.name in RESERVED_NAMES)
        if clash:
            raise self.fail(option, f"{', '.join(clash)}: a sympy/Python name that would not read back as a "
                            f"symbol in the JSON answers; use e.g. {clash[0]}_")
        return out

    def constant(self, value, option: str) -> float:
        """A number of an option (an expression of constants)."""
        try:
            return parse_number(value, self.where(option))
        except ExpressionError as exc:
            raise ExerciseError(str(exc)) from None

    def substitution(self, raw, option: str) -> Dict[sp.Symbol, sp.Expr]:
        """An option {name: expression} as a substitution."""
        if not isinstance(raw, dict):
            raise self.fail(option, f"expected a mapping name: expression, got {raw!r}")
        return {symbol(str(k)): self.expr(v, f"{option}.{k}") for k, v in raw.items()}

    def coordinate_values(self, option: str, prefix: str = "") -> Dict[sp.Symbol, float]:
        """An option {coordinate: number} as {symbol prefix + coordinate: value}."""
        raw = self.spec.get(option) or {}
        if not isinstance(raw, dict):
            raise self.fail(option, "expected a mapping coordinate: value")
        out = {}
        for name, value in raw.items():
            name = str(name)
            if name not in self.coords:
                raise self.fail(f"{option}.{name}", f"not a coordinate of {self.robot.name} "
                                f"(coordinates: {', '.join(self.coords)})")
            out[symbol(prefix + name)] = self.constant(value, f"{option}.{name}")
        return out

    def parameter_values(self) -> Dict[sp.Symbol, float]:
        """Numbers of the robot's parameters (the exercise's ``given`` first, then the file's
        defaults) and of the other numeric data the exercise gives (e.g. a gain gamma)."""
        values = {}
        for name, value in self.ctx.given.items():
            if isinstance(value, (int, float, str)) and str(name).isidentifier():
                values[symbol(str(name))] = self.constant(value, f"given.{name}")
        for name, p in self.robot.parameters.items():
            values.setdefault(p.symbol, p.value)
        return values

    def point(self, option: str = "point") -> Tuple[Optional[str], sp.Matrix, str]:
        """(body, position in the body, label) of a named point or of {body, at}."""
        raw = self.spec.get(option)
        if raw is None:
            raise self.fail(option, "required: a point name or {body, at}")
        if isinstance(raw, str):
            if raw not in self.robot.points:
                raise self.fail(option, f"unknown point '{raw}' (points of {self.robot.name}: "
                                f"{', '.join(self.robot.points) or 'none'})")
            pt = self.robot.points[raw]
            return pt.body, pt.position, raw
        if not isinstance(raw, dict) or "body" not in raw:
            raise self.fail(option, "expected a point name or {body: NAME, at: [x, y, z]}")
        body = raw["body"]
        if body != "base" and body not in [b.name for b in self.robot.bodies]:
            raise self.fail(f"{option}.body", f"unknown body '{body}'")
        at = raw.get("at", [0, 0, 0])
        if not isinstance(at, list) or len(at) != 3:
            raise self.fail(f"{option}.at", "expected [x, y, z]")
        local = sp.Matrix([self.expr(v, f"{option}.at") for v in at])
        return (None if body == "base" else body), local, str(raw.get("name", "point"))

    def components(self) -> List[int]:
        comp = self.spec.get("components", [0, 1])
        if not isinstance(comp, list) or not comp or any(c not in (0, 1, 2) for c in comp):
            raise self.fail("components", "expected a list of 0 (x), 1 (y), 2 (z)")
        return comp

    def indices(self, names, where: str) -> List[int]:
        """Coordinate names (one or a list) as their indices."""
        if isinstance(names, str):
            names = [names]
        if not isinstance(names, (list, tuple)):
            raise ExerciseError(f"{where}: expected a list of coordinate names, got {names!r}")
        out = []
        for name in names:
            if name not in self.coords:
                raise ExerciseError(f"{where}: '{name}' is not a coordinate of {self.robot.name} "
                                    f"({', '.join(self.coords)})")
            out.append(self.coords.index(name))
        return out

    def new_symbols(self, names, where: str) -> List[sp.Symbol]:
        taken = set(self.robot.parameters) | set(self.coords)
        taken |= {"d" + c for c in self.coords} | {"dd" + c for c in self.coords}
        out = []
        for name in names:
            if not isinstance(name, str) or not name.isidentifier():
                raise ExerciseError(f"{where}: '{name}' is not a valid name")
            if name in taken:
                raise ExerciseError(f"{where}: name '{name}' is already used by the robot {self.robot.name}")
            out.append(symbol(name))
        return out

    def mapping(self, spec, where: str, keys="coordinates") -> Dict[sp.Symbol, sp.Expr]:
        """{name: expression} -> {symbol: sympy expression}; names must be coordinates (or their
        velocities when keys == 'state')."""
        if spec is None:
            return {}
        if not isinstance(spec, dict):
            raise ExerciseError(f"{where}: expected a mapping name: value")
        allowed = set(self.coords)
        if keys == "state":
            allowed |= {"d" + c for c in self.coords}
        out = {}
        for name, value in spec.items():
            if name not in allowed:
                raise ExerciseError(f"{where}: '{name}' is not a coordinate{' or velocity' if keys == 'state' else ''} "
                                    f"of {self.robot.name}")
            out[symbol(name)] = self.ctx.expr(value, f"{where}.{name}")
        return out

    def mapping_of_parameters(self, spec, where: str) -> Dict[sp.Symbol, sp.Expr]:
        """{robot parameter: expression} (e.g. ``{g0: 0}``) as a substitution."""
        if not spec:
            return {}
        if not isinstance(spec, dict) or not set(map(str, spec)) <= set(self.robot.parameters):
            raise ExerciseError(f"{where}: expected a mapping robot parameter -> value "
                                f"(parameters: {', '.join(self.robot.parameters)})")
        return {symbol(str(k)): self.ctx.expr(v, f"{where}.{k}") for k, v in spec.items()}

    # ---------------------------------------------------------------- numbers
    @property
    def params(self) -> Dict[str, float]:
        values = dict(self.robot.parameter_values())
        for k in values:
            if k in self.ctx.given:
                values[k] = self.number(self.ctx.given[k], k)
        return values

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
        if isinstance(ref, str) and ref in self.objects:
            return self.objects[ref]["num"]
        J = self.array(ref, where)
        return np.atleast_2d(J)

    def drift(self, ref: str, dq, where: str = "joint_velocity") -> np.ndarray:
        """J'(q, q') q' for a symbolic Jacobian of an earlier task, at that task's configuration."""
        obj = self.objects.get(ref) if isinstance(ref, str) else None
        if obj is None or obj["sym"] is None or obj["q"] is None:
            raise self._fail(f"{where}: J' q' needs the Jacobian of an earlier jacobian task defined on the robot")
        dq = self.array(dq, where).reshape(-1)
        J = obj["sym"]
        Jdot = sp.zeros(*J.shape)
        for qk, vk in zip(self.robot.q, dq):
            if vk:
                Jdot += J.diff(qk) * float(vk)
        return np.atleast_2d(jac.evaluate(self.robot, Jdot, obj["q"], self.params)) @ dq
