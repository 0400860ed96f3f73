"""The data model of a robot (an immutable ``RobotModel`` of bodies, joints, springs, dampers,
motors, friction, limits and points) and the rule for parameter values (``check_parameter``:
finite, and not negative for masses, inertias, stiffnesses and friction), which every input path
calls. Robot files are read into it by app.core.robot.

>>> check_parameter("m1", "mass", 2)      # exact: the value as given, as a float
2.0
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Dict, List, Mapping, Optional, Sequence, Tuple

import numpy as np
import sympy as sp

from .errors import UserError
from .expressions import excerpt, parse_expression, symbol

PARAMETER_KINDS = ("mass", "length", "com", "inertia", "gravity", "friction", "stiffness",
                   "angle", "other")
#: parameter kinds that are treated as known (kinematic) data by default in a linear parametrization
KNOWN_KINDS = ("length", "gravity", "angle")
GROUPS = ("exam", "throwing", "catching", "other")
#: parameter kinds whose values must not be negative
NON_NEGATIVE_KINDS = ("mass", "length", "inertia", "stiffness", "friction")
#: the stretch variable of a nonlinear spring's force law (``force: k*delta + k3*delta**3``)
DELTA = "delta"


def _reserved_names() -> frozenset:
    """Names that ``sympy.sympify`` would not read back as plain symbols (functions and constants of
    sympy such as gamma, beta, E, I, S, N, and Python's builtins such as max)."""
    import builtins
    return frozenset(sp.__all__) | frozenset(dir(builtins))


RESERVED_NAMES = _reserved_names()


class ParameterError(UserError):
    """A parameter value is not acceptable (negative mass, not a number, ...)."""


def refuse_negative(what: str, value: float, shown: str = "") -> str:
    """The one rule for physical amounts that cannot be negative (masses, inertias, stiffnesses,
    damping and friction coefficients): '' when ``value`` is fine, else the refusal, e.g. "a mass
    must not be negative (got -1)" (``what`` with its article; ``shown``: how the value is shown,
    default "got <value>"). Used for parameter values typed or given (``check_parameter``), for
    the amounts of a robot file at its default values (app.core.robot) and for the throwing arm's
    wrist spring.

    >>> refuse_negative("a mass", 2.0), refuse_negative("a mass", -1)
    ('', 'a mass must not be negative (got -1)')
    """
    if value >= 0:
        return ""
    return f"{what} must not be negative ({shown or f'got {value:g}'})"


def check_parameter(name: str, kind: str, value) -> float:
    """The one rule for a parameter's value: a finite real number, not negative for the kinds in
    NON_NEGATIVE_KINDS (masses, lengths, inertias, stiffnesses, friction). Returns it as a float.

    >>> check_parameter("k", "stiffness", 2)     # exact: the value as given, as a float
    2.0
    >>> check_parameter("k", "stiffness", -2)
    Traceback (most recent call last):
    ...
    app.core.robot_model.ParameterError: k: a stiffness must not be negative (got -2)
    """
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ParameterError(f"{name}: expected a number, got {excerpt(value, 30)}")
    if not math.isfinite(value):
        raise ParameterError(f"{name}: expected a finite number, got {value!r}")
    article = "an" if kind[0] in "aeiou" else "a"
    refusal = refuse_negative(f"{article} {kind}", value) if kind in NON_NEGATIVE_KINDS else ""
    if refusal:
        raise ParameterError(f"{name}: {refusal}")
    return float(value)


@dataclass(frozen=True)
class Parameter:
    """A named symbolic parameter with its default numeric value.

    ``kind`` is one of PARAMETER_KINDS; masses, inertias and stiffnesses must be >= 0."""
    name: str
    value: float
    kind: str = "other"
    unit: str = ""
    doc: str = ""

    @property
    def symbol(self) -> sp.Symbol:
        return symbol(self.name)


@dataclass(frozen=True)
class Transform:
    """A constant rigid transform: rotation matrix R (3x3 sympy) and translation p (3 sympy).

    ``rotations`` keeps the elementary rotations (axis, angle) it was built from, when it is one,
    so that chains of rotations about the same axis can be merged into one angle."""
    R: sp.Matrix
    p: sp.Matrix
    rotations: Tuple[Tuple[Tuple[int, int, int], sp.Expr], ...] | None = ()

    @staticmethod
    def identity() -> "Transform":
        return Transform(sp.eye(3), sp.zeros(3, 1), ())


@dataclass(frozen=True)
class Joint:
    """Joint of a body: parent frame -> ``pre`` -> motion about/along ``axis`` by ``value`` -> ``post``."""
    type: str                    # "revolute", "prismatic" or "fixed"
    axis: Tuple[int, int, int] | sp.Matrix
    value: sp.Expr               # joint variable as a function of the coordinates
    pre: Transform
    post: Transform


@dataclass(frozen=True)
class Body:
    name: str
    parent: Optional[str]        # None = the fixed base
    joint: Joint
    mass: sp.Expr
    com: sp.Matrix               # CoM in the body frame
    inertia: sp.Matrix           # inertia tensor about the CoM, body axes
    planar_inertia: bool = False  # inertia was given as one scalar (about the plane normal)
    color: Optional[str] = None
    doc: str = ""


@dataclass(frozen=True)
class Spring:
    """An elastic element. On a stretch delta = expr - rest (a function of the coordinates): the
    potential 1/2 k delta^2 (``stiffness`` k), or, for a nonlinear spring, the integral from 0 to
    delta of its elastic force ``force`` (a polynomial in the symbol ``delta``, e.g.
    k delta + k3 delta^3 gives k delta^2/2 + k3 delta^4/4). Between two points (body, position):
    the zero-rest-length spring 1/2 k |p_a - p_b|^2."""
    name: str
    stiffness: Optional[sp.Expr]
    expr: Optional[sp.Expr] = None
    rest: sp.Expr = sp.Integer(0)
    points: Optional[Tuple[Tuple[Optional[str], sp.Matrix], Tuple[Optional[str], sp.Matrix]]] = None
    force: Optional[sp.Expr] = None

    @property
    def is_linear(self) -> bool:
        """True for 1/2 k (expr - rest)^2 and point springs; False for a nonlinear force law."""
        return self.force is None

    def potential_of_stretch(self, delta) -> sp.Expr:
        """Elastic energy as a function of the stretch (springs given by ``expr``).

        >>> s = Spring("j", None, symbol("q"), force=parse_expression("k*delta + k3*delta**3"))
        >>> s.potential_of_stretch(symbol("x"))
        k*x**2/2 + k3*x**4/4
        """
        if self.force is None:
            return self.stiffness * delta ** 2 / 2
        stretch = symbol(DELTA)
        return sp.Poly(self.force, stretch).integrate().as_expr().xreplace({stretch: delta})

    def potential(self) -> sp.Expr:
        """Elastic energy as an expression of the coordinates (springs given by ``expr``)."""
        return self.potential_of_stretch(self.expr - self.rest)

    def describe(self) -> str:
        """One line for people: ``U = 1/2 K (theta - q)^2``."""
        if self.expr is None:
            return f"zero-length spring of stiffness {sp.sstr(self.stiffness)}"
        stretch = sp.sstr(self.expr - self.rest)
        if self.force is None:
            return f"U = 1/2 {sp.sstr(self.stiffness)} ({stretch})^2"
        return f"elastic force {sp.sstr(self.force)} with delta = {stretch}"


@dataclass(frozen=True)
class Damper:
    """A viscous damper on the stretch delta = expr, an affine function of the coordinates (e.g.
    theta - q for a damped transmission): it resists the rate delta' = a^T q' (a = d delta/dq) with
    the force d delta', i.e. generalized forces a d a^T q' on the left-hand side of the equations
    of motion, and dissipates the power d delta'^2."""
    name: str
    coefficient: sp.Expr
    expr: sp.Expr

    def forces(self, q: Sequence[sp.Symbol], dq: Sequence[sp.Symbol]) -> List[sp.Expr]:
        """The damper's generalized forces, one per coordinate.

        >>> th, q = symbol("theta"), symbol("q")
        >>> Damper("t", symbol("D"), th - q).forces([q, th], [symbol("dq"), symbol("dtheta")])
        [-D*(-dq + dtheta), D*(-dq + dtheta)]
        """
        gradient = [sp.diff(self.expr, qk) for qk in q]
        rate = sp.Add(*[a * v for a, v in zip(gradient, dq)])
        return [self.coefficient * a * rate if a != 0 else sp.Integer(0) for a in gradient]

    def describe(self) -> str:
        return f"damper {sp.sstr(self.coefficient)} on the rate of {sp.sstr(self.expr)}"


@dataclass(frozen=True)
class Point:
    """A named point fixed in a body (or in the base when body is None)."""
    name: str
    body: Optional[str]
    position: sp.Matrix


@dataclass(frozen=True)
class Limits:
    position: Optional[Tuple[float, float]] = None
    velocity: Optional[float] = None
    torque: Optional[float] = None


@dataclass(frozen=True)
class RobotModel:
    """Everything a robot file says, parsed and checked. Immutable."""
    name: str
    title: str
    description: str
    group: str
    coordinates: Tuple[str, ...]
    parameters: Dict[str, Parameter]
    gravity: sp.Matrix
    bodies: Tuple[Body, ...]
    springs: Tuple[Spring, ...] = ()
    dampers: Tuple[Damper, ...] = ()
    motor_inertias: Dict[str, sp.Expr] = field(default_factory=dict)   # coordinate -> inertia
    viscous: Dict[str, sp.Expr] = field(default_factory=dict)          # coordinate -> coefficient
    coulomb: Dict[str, sp.Expr] = field(default_factory=dict)
    actuated: Tuple[bool, ...] = ()
    limits: Dict[str, Limits] = field(default_factory=dict)
    points: Dict[str, Point] = field(default_factory=dict)
    plane: Optional[str] = None          # "vertical", "horizontal" or None (spatial)
    draw: dict = field(default_factory=dict)
    defaults: Dict[str, float] = field(default_factory=dict)   # default coordinate values
    source: str = ""                     # path of the file
    content_hash: str = ""
    notes: Tuple[str, ...] = ()

    # -------------------------------------------------------------- symbols
    @property
    def n(self) -> int:
        return len(self.coordinates)

    @property
    def q(self) -> List[sp.Symbol]:
        return [symbol(c) for c in self.coordinates]

    @property
    def dq(self) -> List[sp.Symbol]:
        return [symbol("d" + c) for c in self.coordinates]

    @property
    def ddq(self) -> List[sp.Symbol]:
        return [symbol("dd" + c) for c in self.coordinates]

    def reference_symbols(self) -> Tuple[List[sp.Symbol], List[sp.Symbol]]:
        """Symbols of the reference velocity and acceleration used in adaptive regressors."""
        return ([symbol("d" + c + "_r") for c in self.coordinates],
                [symbol("dd" + c + "_r") for c in self.coordinates])

    @property
    def parameter_symbols(self) -> List[sp.Symbol]:
        return [p.symbol for p in self.parameters.values()]

    def parameter_values(self, overrides: Mapping[str, float] | None = None) -> Dict[str, float]:
        values = {name: p.value for name, p in self.parameters.items()}
        if overrides:
            for key, value in overrides.items():
                if key not in values:
                    raise KeyError(f"robot {self.name} has no parameter '{key}'")
                values[key] = float(value)
        return values

    def random_configuration(self, rng: np.random.Generator) -> np.ndarray:
        """q drawn uniformly within each coordinate's position limits, else in [-pi, pi] (one draw
        per coordinate, in order).

        >>> from app.core.robot import load_robot
        >>> q = load_robot("planar_2r").random_configuration(np.random.default_rng(0))
        >>> q.shape, bool(np.all(np.abs(q) <= np.pi))
        ((2,), True)
        """
        q = np.empty(self.n)
        for i, name in enumerate(self.coordinates):
            lim = self.limits.get(name)
            lo, hi = lim.position if lim is not None and lim.position is not None else (-np.pi, np.pi)
            q[i] = rng.uniform(lo, hi)
        return q

    def check_parameter_value(self, name: str, value) -> float:
        """A new value of one of the robot's parameters, checked by ``check_parameter``."""
        param = self.parameters.get(name)
        if param is None:
            raise ParameterError(f"unknown parameter '{name}' (the robot has {', '.join(self.parameters) or 'none'})")
        return check_parameter(name, param.kind, value)

    def viscous_forces(self) -> List[sp.Expr]:
        """Generalized forces of viscous friction and dampers (linear in q'), one per coordinate.

        >>> from app.core.robot import load_robot
        >>> load_robot("pprr_2018_04_26").viscous_forces()[0]
        dq1*f_v1
        """
        forces = [sp.Integer(0)] * self.n
        for cname, coeff in self.viscous.items():
            k = self.coordinates.index(cname)
            forces[k] += coeff * self.dq[k]
        for damper in self.dampers:
            forces = [f + d for f, d in zip(forces, damper.forces(self.q, self.dq))]
        return forces

    @property
    def has_friction(self) -> bool:
        """True when the model has dissipative terms (viscous or Coulomb friction, dampers)."""
        return bool(self.viscous or self.coulomb or self.dampers)

    def body(self, name: str) -> Body:
        for b in self.bodies:
            if b.name == name:
                return b
        raise KeyError(f"robot {self.name} has no body '{name}'")

    def chain(self, body_name: Optional[str]) -> List[Body]:
        """Bodies from the base to ``body_name`` (inclusive)."""
        out: List[Body] = []
        while body_name is not None:
            b = self.body(body_name)
            out.append(b)
            body_name = b.parent
        return out[::-1]

    @property
    def is_planar(self) -> bool:
        return self.plane is not None


def elementary_rotation(axis: Tuple[int, int, int], angle) -> sp.Matrix:
    """Rotation matrix about a unit axis (Rodrigues), exact for numeric or symbolic angles.

    >>> elementary_rotation((0, 0, 1), sp.pi/2)
    Matrix([
    [0, -1, 0],
    [1,  0, 0],
    [0,  0, 1]])
    """
    u = sp.Matrix(axis)
    ux = sp.Matrix([[0, -u[2], u[1]], [u[2], 0, -u[0]], [-u[1], u[0], 0]])
    c, s = sp.cos(angle), sp.sin(angle)
    return sp.eye(3) + s * ux + (1 - c) * ux * ux
