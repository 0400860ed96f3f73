"""Robot descriptions: loading and validating robot files (YAML) into an immutable ``RobotModel``.

A robot file describes a tree of rigid bodies connected by revolute, prismatic or fixed joints,
the generalized coordinates and how joint variables depend on them, symbolic parameters with
default values, gravity, springs, motors of elastic joints, friction, actuation, limits and how to
draw the robot. The format is documented in docs/robot-format.md.

>>> robot = load_robot("rp_2004_03_25")
>>> robot.coordinates
('q1', 'q2')
"""
from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Dict, List, Mapping, Optional, Sequence, Tuple

import sympy as sp
import yaml

from .errors import UserError
from .expressions import ExpressionError, parse_expression, symbol

ROBOTS_DIR = Path(__file__).resolve().parent.parent / "robots"

PARAMETER_KINDS = ("mass", "length", "com", "inertia", "gravity", "friction", "stiffness",
                   "angle", "other")
#: parameter kinds that are treated as known (kinematic) data by default in a linear parametrization
KNOWN_KINDS = ("length", "gravity", "angle")
GROUPS = ("exam", "throwing", "catching", "other")


def _reserved_names() -> frozenset:
    """Names that ``sympy.sympify`` would not read back as plain symbols (functions and constants of
    sympy such as gamma, beta, E, I, S, N, and Python's builtins such as max)."""
    import builtins
    return frozenset(sp.__all__) | frozenset(dir(builtins))


RESERVED_NAMES = _reserved_names()


class RobotFileError(UserError):
    """A robot file is malformed; the message names the file, the field and the problem."""


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
    """Potential energy 1/2 k (expr - rest)^2 with expr a function of the coordinates, or the
    zero-rest-length spring 1/2 k |p_a - p_b|^2 between two points (body, position)."""
    name: str
    stiffness: sp.Expr
    expr: Optional[sp.Expr] = None
    rest: sp.Expr = sp.Integer(0)
    points: Optional[Tuple[Tuple[Optional[str], sp.Matrix], Tuple[Optional[str], sp.Matrix]]] = None


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


# ====================================================================== parsing helpers
class _Ctx:
    """Parsing context: file name, allowed names, error helper."""

    def __init__(self, source: str, names: Sequence[str]):
        self.source = source
        self.names = set(names)

    def fail(self, where: str, what: str) -> RobotFileError:
        return RobotFileError(f"{self.source}: {where}: {what}")

    def expr(self, value, where: str) -> sp.Expr:
        if value is None:
            raise self.fail(where, "missing value")
        try:
            return parse_expression(value, self.names)
        except ExpressionError as exc:
            raise self.fail(where, str(exc)) from None

    def vector(self, value, where: str, length: int = 3) -> sp.Matrix:
        if not isinstance(value, (list, tuple)) or len(value) != length:
            raise self.fail(where, f"expected a list of {length} numbers or expressions, got {value!r}")
        return sp.Matrix([self.expr(v, f"{where}[{i}]") for i, v in enumerate(value)])


_AXES = {"x": (1, 0, 0), "y": (0, 1, 0), "z": (0, 0, 1),
         "-x": (-1, 0, 0), "-y": (0, -1, 0), "-z": (0, 0, -1)}


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


def _parse_axis(ctx: _Ctx, value, where: str):
    if isinstance(value, str):
        key = value.strip().lower()
        if key in _AXES:
            return _AXES[key]
        raise ctx.fail(where, f"unknown axis {value!r} (use x, y, z, -x, -y, -z or a list of 3 numbers)")
    vec = ctx.vector(value, where)
    if any(not e.is_number for e in vec):
        raise ctx.fail(where, "an axis must be numeric")
    norm = sp.sqrt(sum(e ** 2 for e in vec))
    if norm == 0:
        raise ctx.fail(where, "an axis must not be zero")
    unit = tuple(sp.nsimplify(e / norm) for e in vec)
    if all(e in (0, 1, -1) for e in unit):
        return tuple(int(e) for e in unit)
    return sp.Matrix(unit)


def _parse_transform(ctx: _Ctx, spec, where: str) -> Transform:
    """A transform from {xyz: [...], rpy: [...]} / {rotation: [[...]]} / {rotations: [[axis, angle]...]}."""
    if spec is None:
        return Transform.identity()
    if isinstance(spec, list):
        spec = {"xyz": spec}
    if not isinstance(spec, dict):
        raise ctx.fail(where, f"expected a mapping with xyz/rpy/rotation, got {spec!r}")
    unknown = set(spec) - {"xyz", "rpy", "rotation", "rotations"}
    if unknown:
        raise ctx.fail(where, f"unknown field(s) {sorted(unknown)} (allowed: xyz, rpy, rotation, rotations)")
    p = ctx.vector(spec["xyz"], f"{where}.xyz") if "xyz" in spec else sp.zeros(3, 1)
    rots: list = []
    R = sp.eye(3)
    given = [k for k in ("rpy", "rotation", "rotations") if k in spec]
    if len(given) > 1:
        raise ctx.fail(where, "give only one of rpy, rotation, rotations")
    if "rpy" in spec:   # fixed-axis roll-pitch-yaw: R = Rz(yaw) Ry(pitch) Rx(roll)
        r, pch, y = list(ctx.vector(spec["rpy"], f"{where}.rpy"))
        for axis, angle in (((0, 0, 1), y), ((0, 1, 0), pch), ((1, 0, 0), r)):
            if angle != 0:
                rots.append((axis, angle))
    elif "rotations" in spec:
        seq = spec["rotations"]
        if not isinstance(seq, list):
            raise ctx.fail(f"{where}.rotations", "expected a list of [axis, angle] pairs")
        for i, item in enumerate(seq):
            if not isinstance(item, (list, tuple)) or len(item) != 2:
                raise ctx.fail(f"{where}.rotations[{i}]", "expected [axis, angle]")
            axis = _parse_axis(ctx, item[0], f"{where}.rotations[{i}][0]")
            if not isinstance(axis, tuple):
                raise ctx.fail(f"{where}.rotations[{i}][0]", "use x, y or z axes in a rotation sequence")
            rots.append((axis, ctx.expr(item[1], f"{where}.rotations[{i}][1]")))
    elif "rotation" in spec:
        rows = spec["rotation"]
        if not isinstance(rows, list) or len(rows) != 3:
            raise ctx.fail(f"{where}.rotation", "expected a 3x3 matrix (list of 3 rows)")
        R = sp.Matrix([list(ctx.vector(row, f"{where}.rotation[{i}]")) for i, row in enumerate(rows)])
        if any(e.free_symbols for e in R):
            raise ctx.fail(f"{where}.rotation", "a rotation matrix must be numeric")
        err = (R.T * R - sp.eye(3)).applyfunc(lambda e: abs(float(e)))
        if max(err) > 1e-9 or abs(float(R.det()) - 1) > 1e-9:
            raise ctx.fail(f"{where}.rotation", "not a rotation matrix (R^T R != I or det != 1)")
        return Transform(R, p, None)
    for axis, angle in rots:
        R = R * elementary_rotation(axis, angle)
    return Transform(R, p, tuple(rots))


def _compose(a: Transform, b: Transform) -> Transform:
    rots = None if a.rotations is None or b.rotations is None else a.rotations + b.rotations
    return Transform(a.R * b.R, a.p + a.R * b.p, rots)


def _rot_only(axis, angle) -> Transform:
    return Transform(elementary_rotation(axis, angle), sp.zeros(3, 1), ((axis, angle),))


def _trans_only(x=0, y=0, z=0) -> Transform:
    return Transform(sp.eye(3), sp.Matrix([x, y, z]), ())


def _parse_dh(ctx: _Ctx, spec, where: str, coordinate_syms, modified: bool) -> Joint:
    if not isinstance(spec, dict):
        raise ctx.fail(where, "expected a mapping with alpha, a, d, theta")
    unknown = set(spec) - {"alpha", "a", "d", "theta"}
    if unknown:
        raise ctx.fail(where, f"unknown field(s) {sorted(unknown)} (allowed: alpha, a, d, theta)")
    alpha, a, d, theta = (ctx.expr(spec.get(k, 0), f"{where}.{k}") for k in ("alpha", "a", "d", "theta"))
    in_theta = bool(theta.free_symbols & coordinate_syms)
    in_d = bool(d.free_symbols & coordinate_syms)
    if in_theta and in_d:
        raise ctx.fail(where, "only one of theta and d may depend on the coordinates")
    for name, val in (("alpha", alpha), ("a", a)):
        if val.free_symbols & coordinate_syms:
            raise ctx.fail(f"{where}.{name}", "must not depend on the coordinates")
    z = (0, 0, 1)
    if in_theta:
        jtype, value = "revolute", theta
        fixed_before, fixed_after = Transform.identity(), _trans_only(z=d)
    elif in_d:
        jtype, value = "prismatic", d
        fixed_before, fixed_after = _rot_only(z, theta) if theta != 0 else Transform.identity(), Transform.identity()
    else:
        jtype, value = "fixed", sp.Integer(0)
        fixed_before = _compose(_rot_only(z, theta) if theta != 0 else Transform.identity(), _trans_only(z=d))
        fixed_after = Transform.identity()
    link = _compose(_trans_only(x=a), _rot_only((1, 0, 0), alpha) if alpha != 0 else Transform.identity())
    if modified:   # Craig: Rx(alpha) Tx(a) Rz(theta) Tz(d)
        pre = _compose(_compose(_rot_only((1, 0, 0), alpha) if alpha != 0 else Transform.identity(),
                                _trans_only(x=a)), fixed_before)
        post = fixed_after
    else:          # standard: Rz(theta) Tz(d) Tx(a) Rx(alpha)
        pre = fixed_before
        post = _compose(fixed_after, link)
    return Joint(jtype, z, value, pre, post)


def _parse_inertia(ctx: _Ctx, value, where: str) -> Tuple[sp.Matrix, bool]:
    if value is None:
        return sp.zeros(3, 3), False
    if isinstance(value, (int, float, str)):
        I = ctx.expr(value, where)
        return sp.eye(3) * I, True
    if isinstance(value, dict):
        allowed = {"xx", "yy", "zz", "xy", "xz", "yz"}
        unknown = set(value) - allowed
        if unknown:
            raise ctx.fail(where, f"unknown field(s) {sorted(unknown)} (allowed: {sorted(allowed)})")
        g = {k: ctx.expr(value.get(k, 0), f"{where}.{k}") for k in allowed}
        M = sp.Matrix([[g["xx"], g["xy"], g["xz"]], [g["xy"], g["yy"], g["yz"]], [g["xz"], g["yz"], g["zz"]]])
        return M, False
    if isinstance(value, list) and len(value) == 3 and not isinstance(value[0], list):
        return sp.diag(*ctx.vector(value, where)), False
    if isinstance(value, list) and len(value) == 3:
        M = sp.Matrix([list(ctx.vector(row, f"{where}[{i}]")) for i, row in enumerate(value)])
        if M != M.T:
            raise ctx.fail(where, "the inertia tensor must be symmetric")
        return M, False
    raise ctx.fail(where, f"expected a scalar, a list of 3 (diagonal), a 3x3 matrix or a mapping xx..yz, got {value!r}")


def _check_keys(ctx: _Ctx, spec: dict, allowed: set, where: str) -> None:
    unknown = set(spec) - allowed
    if unknown:
        raise ctx.fail(where, f"unknown field(s) {sorted(unknown)} (allowed: {sorted(allowed)})")


_TOP_KEYS = {"name", "title", "description", "group", "coordinates", "parameters", "gravity",
             "bodies", "springs", "motors", "friction", "actuated", "limits", "points", "plane",
             "draw", "defaults", "notes", "format"}


def parse_robot(data, source: str = "<robot>", content_hash: str = "") -> RobotModel:
    """Build a RobotModel from the parsed YAML mapping ``data``; raise RobotFileError on problems."""
    ctx = _Ctx(source, [])
    if not isinstance(data, dict):
        raise ctx.fail("top level", "expected a mapping (key: value lines)")
    _check_keys(ctx, data, _TOP_KEYS, "top level")
    for key in ("name", "coordinates", "bodies"):
        if key not in data:
            raise ctx.fail(key, "required field is missing")
    name = data["name"]
    if not isinstance(name, str) or not name.replace("_", "").replace("-", "").isalnum():
        raise ctx.fail("name", f"expected an identifier (letters, digits, _ and -), got {name!r}")
    group = data.get("group", "other")
    if group not in GROUPS:
        raise ctx.fail("group", f"expected one of {GROUPS}, got {group!r}")

    coords = data["coordinates"]
    if not isinstance(coords, list) or not coords or not all(isinstance(c, str) and c.isidentifier() for c in coords):
        raise ctx.fail("coordinates", f"expected a non-empty list of identifiers, got {coords!r}")
    if len(set(coords)) != len(coords):
        raise ctx.fail("coordinates", "duplicate coordinate names")
    for c in coords:
        if c in RESERVED_NAMES:
            raise ctx.fail("coordinates", f"'{c}' is a sympy/Python name and would not read back as a symbol; "
                           f"choose another name (e.g. {c}_)")

    # ---- parameters
    params: Dict[str, Parameter] = {}
    raw_params = data.get("parameters") or {}
    if not isinstance(raw_params, dict):
        raise ctx.fail("parameters", "expected a mapping name: value or name: {value, kind, unit, doc}")
    reserved = set(coords) | {"d" + c for c in coords} | {"dd" + c for c in coords} | {"pi", "E"}
    for pname, spec in raw_params.items():
        where = f"parameters.{pname}"
        if not isinstance(pname, str) or not pname.isidentifier():
            raise ctx.fail(where, "a parameter name must be an identifier")
        if pname in reserved:
            raise ctx.fail(where, "name clashes with a coordinate, its derivatives or a constant")
        if pname in RESERVED_NAMES:
            raise ctx.fail(where, f"'{pname}' is a sympy/Python name (sympify would not read it back as a "
                           f"symbol); choose another name, e.g. {pname}_ or {pname}0")
        if not isinstance(spec, dict):
            spec = {"value": spec}
        _check_keys(ctx, spec, {"value", "kind", "unit", "doc"}, where)
        kind = spec.get("kind", "other")
        if kind not in PARAMETER_KINDS:
            raise ctx.fail(f"{where}.kind", f"expected one of {PARAMETER_KINDS}, got {kind!r}")
        try:
            value = float(parse_expression(spec.get("value"), allowed_names=()))
        except (ExpressionError, TypeError) as exc:
            raise ctx.fail(f"{where}.value", f"expected a number: {exc}") from None
        if not math.isfinite(value):
            raise ctx.fail(f"{where}.value", "must be finite")
        if kind in ("mass", "inertia", "stiffness", "friction") and value < 0:
            raise ctx.fail(f"{where}.value", f"a {kind} must not be negative (got {value})")
        params[pname] = Parameter(pname, value, kind, str(spec.get("unit", "")), str(spec.get("doc", "")))

    ctx.names = set(coords) | set(params)
    coord_syms = {symbol(c) for c in coords}
    param_ctx = _Ctx(source, list(params))          # for expressions that must not depend on q

    def const_expr(value, where):
        return param_ctx.expr(value, where)

    def const_vector(value, where):
        return param_ctx.vector(value, where)

    gravity = const_vector(data.get("gravity", [0, 0, 0]), "gravity")

    # ---- bodies
    raw_bodies = data["bodies"]
    if not isinstance(raw_bodies, list) or not raw_bodies:
        raise ctx.fail("bodies", "expected a non-empty list of bodies")
    bodies: List[Body] = []
    names: List[str] = []
    for i, spec in enumerate(raw_bodies):
        where = f"bodies[{i}]"
        if not isinstance(spec, dict):
            raise ctx.fail(where, "expected a mapping")
        _check_keys(ctx, spec, {"name", "parent", "joint", "dh", "mdh", "mass", "com", "inertia",
                                "color", "doc"}, where)
        bname = spec.get("name", f"link{i + 1}")
        where = f"bodies[{i}] ({bname})"
        if bname in names or bname == "base":
            raise ctx.fail(where, f"duplicate body name '{bname}'")
        parent = spec.get("parent", names[-1] if names else "base")
        if parent != "base" and parent not in names:
            raise ctx.fail(f"{where}.parent", f"unknown parent '{parent}' (bodies must be listed after their parent)")
        kinds = [k for k in ("joint", "dh", "mdh") if k in spec]
        if len(kinds) != 1:
            raise ctx.fail(where, "give exactly one of joint, dh, mdh")
        if kinds[0] == "joint":
            jspec = spec["joint"]
            if not isinstance(jspec, dict):
                raise ctx.fail(f"{where}.joint", "expected a mapping")
            _check_keys(ctx, jspec, {"type", "axis", "q", "origin", "post"}, f"{where}.joint")
            jtype = jspec.get("type", "revolute")
            if jtype not in ("revolute", "prismatic", "fixed"):
                raise ctx.fail(f"{where}.joint.type", f"expected revolute, prismatic or fixed, got {jtype!r}")
            axis = _parse_axis(ctx, jspec.get("axis", "z"), f"{where}.joint.axis")
            if jtype == "fixed":
                value = sp.Integer(0)
            else:
                if "q" not in jspec:
                    raise ctx.fail(f"{where}.joint.q", "missing the joint variable (an expression of the coordinates)")
                value = ctx.expr(jspec["q"], f"{where}.joint.q")
                if not value.free_symbols & coord_syms:
                    raise ctx.fail(f"{where}.joint.q", "the joint variable does not depend on any coordinate")
            pre = _parse_transform(param_ctx, jspec.get("origin"), f"{where}.joint.origin")
            post = _parse_transform(param_ctx, jspec.get("post"), f"{where}.joint.post")
            joint = Joint(jtype, axis, value, pre, post)
        else:
            joint = _parse_dh(ctx, spec[kinds[0]], f"{where}.{kinds[0]}", coord_syms, kinds[0] == "mdh")
        mass = const_expr(spec.get("mass", 0), f"{where}.mass")
        com = const_vector(spec.get("com", [0, 0, 0]), f"{where}.com")
        inertia, planar_inertia = _parse_inertia(param_ctx, spec.get("inertia"), f"{where}.inertia")
        bodies.append(Body(bname, None if parent == "base" else parent, joint, mass, com, inertia,
                           planar_inertia, spec.get("color"), str(spec.get("doc", ""))))
        names.append(bname)

    used = set()
    for b in bodies:
        used |= b.joint.value.free_symbols & coord_syms

    # ---- motors (rotor inertias of elastic joints or actuators modelled as extra coordinates)
    motors: Dict[str, sp.Expr] = {}
    raw_motors = data.get("motors") or {}
    if not isinstance(raw_motors, dict):
        raise ctx.fail("motors", "expected a mapping coordinate: inertia")
    for cname, value in raw_motors.items():
        if cname not in coords:
            raise ctx.fail(f"motors.{cname}", "not a coordinate")
        motors[cname] = const_expr(value, f"motors.{cname}")
        used.add(symbol(cname))

    # ---- springs
    springs: List[Spring] = []
    raw_springs = data.get("springs") or []
    if not isinstance(raw_springs, list):
        raise ctx.fail("springs", "expected a list")
    for i, spec in enumerate(raw_springs):
        where = f"springs[{i}]"
        if not isinstance(spec, dict):
            raise ctx.fail(where, "expected a mapping")
        _check_keys(ctx, spec, {"name", "stiffness", "expr", "rest", "between"}, where)
        k = const_expr(spec.get("stiffness"), f"{where}.stiffness")
        sname = str(spec.get("name", f"spring{i + 1}"))
        if ("expr" in spec) == ("between" in spec):
            raise ctx.fail(where, "give exactly one of expr (a function of the coordinates) or between (two points)")
        if "expr" in spec:
            springs.append(Spring(sname, k, ctx.expr(spec["expr"], f"{where}.expr"),
                                  const_expr(spec.get("rest", 0), f"{where}.rest")))
        else:
            pts = spec["between"]
            if not isinstance(pts, list) or len(pts) != 2:
                raise ctx.fail(f"{where}.between", "expected two points [body, [x, y, z]]")
            parsed = []
            for j, pt in enumerate(pts):
                if not isinstance(pt, list) or len(pt) != 2:
                    raise ctx.fail(f"{where}.between[{j}]", "expected [body, [x, y, z]] (body may be base)")
                bn = pt[0]
                if bn != "base" and bn not in names:
                    raise ctx.fail(f"{where}.between[{j}]", f"unknown body '{bn}'")
                parsed.append((None if bn == "base" else bn, const_vector(pt[1], f"{where}.between[{j}][1]")))
            if "rest" in spec and spec["rest"] not in (0, "0"):
                raise ctx.fail(f"{where}.rest", "springs between points have zero rest length")
            springs.append(Spring(sname, k, None, sp.Integer(0), tuple(parsed)))

    unused = [c for c in coords if symbol(c) not in used]
    if unused:
        raise ctx.fail("coordinates", f"coordinate(s) {unused} move no joint and no motor")

    # ---- friction
    viscous: Dict[str, sp.Expr] = {}
    coulomb: Dict[str, sp.Expr] = {}
    raw_fr = data.get("friction") or {}
    if not isinstance(raw_fr, dict):
        raise ctx.fail("friction", "expected a mapping with viscous and/or coulomb")
    _check_keys(ctx, raw_fr, {"viscous", "coulomb"}, "friction")
    for kind_name, target in (("viscous", viscous), ("coulomb", coulomb)):
        entries = raw_fr.get(kind_name) or {}
        if not isinstance(entries, dict):
            raise ctx.fail(f"friction.{kind_name}", "expected a mapping coordinate: coefficient")
        for cname, value in entries.items():
            if cname not in coords:
                raise ctx.fail(f"friction.{kind_name}.{cname}", "not a coordinate")
            target[cname] = const_expr(value, f"friction.{kind_name}.{cname}")

    # ---- actuation
    act_spec = data.get("actuated", list(coords))
    if not isinstance(act_spec, list) or any(a not in coords for a in act_spec):
        raise ctx.fail("actuated", f"expected a list of coordinate names, got {act_spec!r}")
    actuated = tuple(c in act_spec for c in coords)

    # ---- limits
    limits: Dict[str, Limits] = {}
    raw_limits = data.get("limits") or {}
    if not isinstance(raw_limits, dict):
        raise ctx.fail("limits", "expected a mapping coordinate: {position, velocity, torque}")
    for cname, spec in raw_limits.items():
        where = f"limits.{cname}"
        if cname not in coords:
            raise ctx.fail(where, "not a coordinate")
        if not isinstance(spec, dict):
            raise ctx.fail(where, "expected a mapping with position, velocity, torque")
        _check_keys(ctx, spec, {"position", "velocity", "torque"}, where)
        pos = spec.get("position")
        if pos is not None:
            if not isinstance(pos, list) or len(pos) != 2:
                raise ctx.fail(f"{where}.position", "expected [lower, upper]")
            lo, hi = (float(parse_expression(v, allowed_names=())) for v in pos)
            if not lo < hi:
                raise ctx.fail(f"{where}.position", f"lower limit {lo} must be below upper {hi}")
            pos = (lo, hi)
        vel = spec.get("velocity")
        tor = spec.get("torque")
        vel = None if vel is None else float(parse_expression(vel, allowed_names=()))
        tor = None if tor is None else float(parse_expression(tor, allowed_names=()))
        for label, v in (("velocity", vel), ("torque", tor)):
            if v is not None and not v > 0:
                raise ctx.fail(f"{where}.{label}", "must be positive")
        limits[cname] = Limits(pos, vel, tor)

    # ---- points
    points: Dict[str, Point] = {}
    raw_points = data.get("points") or {}
    if not isinstance(raw_points, dict):
        raise ctx.fail("points", "expected a mapping name: {body, at}")
    for pname, spec in raw_points.items():
        where = f"points.{pname}"
        if not isinstance(spec, dict) or "body" not in spec:
            raise ctx.fail(where, "expected {body: NAME, at: [x, y, z]}")
        _check_keys(ctx, spec, {"body", "at"}, where)
        bn = spec["body"]
        if bn != "base" and bn not in names:
            raise ctx.fail(f"{where}.body", f"unknown body '{bn}'")
        points[pname] = Point(pname, None if bn == "base" else bn, const_vector(spec.get("at", [0, 0, 0]), f"{where}.at"))

    plane = data.get("plane")
    if plane not in (None, "vertical", "horizontal"):
        raise ctx.fail("plane", f"expected vertical, horizontal or nothing (spatial), got {plane!r}")
    if plane is not None:
        for b in bodies:
            ax = b.joint.axis
            if b.joint.type == "revolute" and ax not in ((0, 0, 1), (0, 0, -1)):
                raise ctx.fail(f"bodies ({b.name})", "a planar robot (plane: ...) needs revolute axes along z")

    defaults_raw = data.get("defaults") or {}
    if not isinstance(defaults_raw, dict) or any(k not in coords for k in defaults_raw):
        raise ctx.fail("defaults", "expected a mapping coordinate: value")
    defaults = {k: float(parse_expression(v, allowed_names=())) for k, v in defaults_raw.items()}

    draw = data.get("draw") or {}
    if not isinstance(draw, dict):
        raise ctx.fail("draw", "expected a mapping")
    notes = data.get("notes") or []
    if isinstance(notes, str):
        notes = [notes]

    return RobotModel(
        name=name, title=str(data.get("title", name)), description=str(data.get("description", "")),
        group=group, coordinates=tuple(coords), parameters=params, gravity=gravity,
        bodies=tuple(bodies), springs=tuple(springs), motor_inertias=motors, viscous=viscous,
        coulomb=coulomb, actuated=actuated, limits=limits, points=points, plane=plane, draw=draw,
        defaults=defaults, source=source, content_hash=content_hash, notes=tuple(str(n) for n in notes))


def robot_path(name_or_path: str | Path) -> Path:
    """Resolve a shipped robot's name or a path to a robot file."""
    candidate = Path(name_or_path)
    if candidate.suffix in (".yaml", ".yml", ".json") or candidate.exists():
        if not candidate.exists():
            raise RobotFileError(f"{candidate}: no such file")
        return candidate
    shipped = ROBOTS_DIR / f"{name_or_path}.yaml"
    if shipped.exists():
        return shipped
    known = ", ".join(list_robot_names()[:8])
    raise RobotFileError(f"unknown robot '{name_or_path}' (not a file, not a shipped robot; e.g. {known} ...; "
                         f"`python -m app robots` lists them)")


def load_robot(name_or_path: str | Path) -> RobotModel:
    """Load a shipped robot by name or a robot file by path."""
    path = robot_path(name_or_path)
    text = path.read_text(encoding="utf-8")
    return load_robot_text(text, str(path))


def load_robot_text(text: str, source: str = "<robot>") -> RobotModel:
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise RobotFileError(f"{source}: not valid YAML: {exc}") from None
    digest = hashlib.sha256(text.encode("utf-8")).hexdigest()
    return parse_robot(data, source, digest)


def list_robot_names() -> List[str]:
    return sorted(p.stem for p in ROBOTS_DIR.glob("*.yaml"))
