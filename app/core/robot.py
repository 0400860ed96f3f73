"""Robot files: loading and validating robot files (YAML) into an immutable ``RobotModel``.

A robot file describes a tree of rigid bodies connected by revolute, prismatic or fixed joints,
the generalized coordinates and how joint variables depend on them, symbolic parameters with
default values, gravity, springs, dampers, motors of elastic joints, friction, actuation, limits
and how to draw the robot. The format is documented in docs/robot-format.md. The data model and
the rule for parameter values live in app.core.robot_model and are re-exported here.

>>> robot = load_robot("rp_2004_03_25")
>>> robot.coordinates
('q1', 'q2')
>>> robot.check_parameter_value("m1", -1)
Traceback (most recent call last):
...
app.core.robot_model.ParameterError: m1: a mass must not be negative (got -1)
"""
from __future__ import annotations

import hashlib
import json
import math
from pathlib import Path
from typing import Dict, List, Mapping, Optional, Sequence, Tuple

import numpy as np
import sympy as sp

from .catalog import ROBOT_SUFFIXES, ROBOTS_DIR, list_robot_names, named_file, shipped_robot
from .errors import UserError
from .expressions import ExpressionError, excerpt, parse_expression, parse_number, symbol
from .files import load_yaml, read_user_file
from .mass_check import singular_directions
from .robot_model import (  # noqa: F401  (re-exported: the robot module is the entry point)
    DELTA, GROUPS, KNOWN_KINDS, NON_NEGATIVE_KINDS, PARAMETER_KINDS, RESERVED_NAMES, Body, Damper,
    Joint, Limits, Parameter, ParameterError, Point, RobotModel, Spring, Transform, check_parameter,
    elementary_rotation, refuse_negative)
from .urdf import is_urdf, robot_data_from_urdf

class RobotFileError(UserError):
    """A robot file is malformed; the message names the file, the field and the problem."""


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
    if in_theta or in_d:
        _check_joint_variable(ctx, "revolute" if in_theta else "prismatic", theta if in_theta else d,
                              coordinate_syms, f"{where}.{'theta' if in_theta else 'd'}")
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
             "bodies", "springs", "dampers", "motors", "friction", "actuated", "limits", "points", "plane",
             "draw", "defaults", "notes", "format"}


def _is_name(value) -> bool:
    """An ASCII identifier (a full-width or other look-alike letter is refused, not read as ASCII)."""
    return isinstance(value, str) and value.isascii() and value.isidentifier()


def _text(ctx: _Ctx, value, where: str, limit: int = 20000) -> str:
    """A free text field (title, description, doc, unit, notes): a string or a number."""
    if isinstance(value, bool) or not isinstance(value, (str, int, float)):
        raise ctx.fail(where, f"expected a text, got {excerpt(value)}")
    text = str(value)
    if len(text) > limit:
        raise ctx.fail(where, f"text longer than {limit} characters")
    return text


def _parse_header(ctx: _Ctx, data) -> Tuple[str, str]:
    if not isinstance(data, dict):
        raise ctx.fail("top level", "expected a mapping (key: value lines)")
    _check_keys(ctx, data, _TOP_KEYS, "top level")
    for key in ("name", "coordinates", "bodies"):
        if key not in data:
            raise ctx.fail(key, "required field is missing")
    name = data["name"]
    if not isinstance(name, str) or not name.isascii() or not name.replace("_", "").replace("-", "").isalnum():
        raise ctx.fail("name", f"expected an identifier (letters, digits, _ and -), got {excerpt(name)}")
    group = data.get("group", "other")
    if group not in GROUPS:
        raise ctx.fail("group", f"expected one of {GROUPS}, got {excerpt(group)}")
    return name, group


def _parse_coordinates(ctx: _Ctx, coords) -> List[str]:
    if not isinstance(coords, list) or not coords or not all(_is_name(c) for c in coords):
        raise ctx.fail("coordinates", f"expected a non-empty list of ASCII identifiers, got {excerpt(coords)}")
    if len(set(coords)) != len(coords):
        raise ctx.fail("coordinates", "duplicate coordinate names")
    for c in coords:
        if c in RESERVED_NAMES or c == DELTA:
            raise ctx.fail("coordinates", f"'{c}' is a sympy/Python name and would not read back as a symbol; "
                           f"choose another name (e.g. {c}_)")
    return coords


def _parse_parameters(ctx: _Ctx, raw, coords: Sequence[str]) -> Dict[str, Parameter]:
    params: Dict[str, Parameter] = {}
    raw = raw or {}
    if not isinstance(raw, dict):
        raise ctx.fail("parameters", "expected a mapping name: value or name: {value, kind, unit, doc}")
    reserved = set(coords) | {"d" + c for c in coords} | {"dd" + c for c in coords} | {"pi", "E", DELTA}
    for pname, spec in raw.items():
        where = f"parameters.{pname}"
        if not _is_name(pname):
            raise ctx.fail(f"parameters.{excerpt(pname, 30)}", "a parameter name must be an ASCII identifier")
        if pname in reserved:
            raise ctx.fail(where, "name clashes with a coordinate, its derivatives, a constant or delta")
        if pname in RESERVED_NAMES:
            raise ctx.fail(where, f"'{pname}' is a sympy/Python name (sympify would not read it back as a "
                           f"symbol); choose another name, e.g. {pname}_ or {pname}0")
        if not isinstance(spec, dict):
            spec = {"value": spec}
        _check_keys(ctx, spec, {"value", "kind", "unit", "doc"}, where)
        kind = spec.get("kind", "other")
        if kind not in PARAMETER_KINDS:
            raise ctx.fail(f"{where}.kind", f"expected one of {PARAMETER_KINDS}, got {excerpt(kind)}")
        try:
            value = check_parameter(pname, kind, parse_number(spec.get("value")))
        except ExpressionError as exc:
            raise ctx.fail(f"{where}.value", f"expected a number: {exc}") from None
        except ParameterError as exc:
            raise ctx.fail(f"{where}.value", str(exc)) from None
        params[pname] = Parameter(pname, value, kind, _text(ctx, spec.get("unit", ""), f"{where}.unit"),
                                  _text(ctx, spec.get("doc", ""), f"{where}.doc"))
    return params


def _check_joint_variable(ctx: _Ctx, jtype: str, value: sp.Expr, coord_syms, where: str) -> None:
    """A revolute joint turns by an integer combination of the coordinates plus a constant (so that
    its sines and cosines stay trigonometric polynomials); a prismatic one slides by a polynomial."""
    if not value.free_symbols & coord_syms:
        raise ctx.fail(where, "the joint variable does not depend on any coordinate")
    if jtype == "revolute":
        for term in sp.Add.make_args(sp.expand(value)):
            coeff, rest = term.as_coeff_Mul()
            if term.free_symbols & coord_syms and not (rest in coord_syms and coeff.is_Integer):
                raise ctx.fail(where, "a revolute joint variable must be a sum of integer multiples of the "
                               f"coordinates plus a constant (q2, q2 - q1, q3 + pi/2), got {excerpt(value)}")
    elif not value.is_polynomial(*coord_syms):
        raise ctx.fail(where, f"a prismatic joint variable must be a polynomial in the coordinates, got {excerpt(value)}")


def _parse_joint(ctx: _Ctx, const: _Ctx, spec, where: str, coord_syms) -> Joint:
    if not isinstance(spec, dict):
        raise ctx.fail(where, "expected a mapping")
    _check_keys(ctx, spec, {"type", "axis", "q", "origin", "post"}, where)
    jtype = spec.get("type", "revolute")
    if jtype not in ("revolute", "prismatic", "fixed"):
        raise ctx.fail(f"{where}.type", f"expected revolute, prismatic or fixed, got {excerpt(jtype)}")
    axis = _parse_axis(ctx, spec.get("axis", "z"), f"{where}.axis")
    if jtype == "fixed":
        value = sp.Integer(0)
    else:
        if "q" not in spec:
            raise ctx.fail(f"{where}.q", "missing the joint variable (an expression of the coordinates)")
        value = ctx.expr(spec["q"], f"{where}.q")
        _check_joint_variable(ctx, jtype, value, coord_syms, f"{where}.q")
    pre = _parse_transform(const, spec.get("origin"), f"{where}.origin")
    post = _parse_transform(const, spec.get("post"), f"{where}.post")
    return Joint(jtype, axis, value, pre, post)


_BODY_KEYS = {"name", "parent", "joint", "dh", "mdh", "mass", "com", "inertia", "color", "doc"}


def _parse_bodies(ctx: _Ctx, const: _Ctx, raw, coord_syms) -> List[Body]:
    if not isinstance(raw, list) or not raw:
        raise ctx.fail("bodies", "expected a non-empty list of bodies")
    bodies: List[Body] = []
    names: List[str] = []
    for i, spec in enumerate(raw):
        where = f"bodies[{i}]"
        if not isinstance(spec, dict):
            raise ctx.fail(where, "expected a mapping")
        _check_keys(ctx, spec, _BODY_KEYS, where)
        bname = spec.get("name", f"link{i + 1}")
        if not _is_name(bname):
            raise ctx.fail(f"{where}.name", f"expected an ASCII identifier, got {excerpt(bname)}")
        where = f"bodies[{i}] ({bname})"
        if bname in names or bname == "base":
            raise ctx.fail(where, f"duplicate body name '{bname}'")
        parent = spec.get("parent", names[-1] if names else "base")
        if parent != "base" and parent not in names:
            raise ctx.fail(f"{where}.parent", f"unknown parent {excerpt(parent)} (bodies must be listed after their parent)")
        kinds = [k for k in ("joint", "dh", "mdh") if k in spec]
        if len(kinds) != 1:
            raise ctx.fail(where, "give exactly one of joint, dh, mdh")
        if kinds[0] == "joint":
            joint = _parse_joint(ctx, const, spec["joint"], f"{where}.joint", coord_syms)
        else:
            joint = _parse_dh(ctx, spec[kinds[0]], f"{where}.{kinds[0]}", coord_syms, kinds[0] == "mdh")
        mass = const.expr(spec.get("mass", 0), f"{where}.mass")
        com = const.vector(spec.get("com", [0, 0, 0]), f"{where}.com")
        inertia, planar_inertia = _parse_inertia(const, spec.get("inertia"), f"{where}.inertia")
        bodies.append(Body(bname, None if parent == "base" else parent, joint, mass, com, inertia,
                           planar_inertia, spec.get("color"), _text(ctx, spec.get("doc", ""), f"{where}.doc")))
        names.append(bname)
    return bodies


def _parse_motors(ctx: _Ctx, const: _Ctx, raw, coords) -> Dict[str, sp.Expr]:
    """Rotor inertias of elastic joints or actuators modelled as extra coordinates."""
    raw = raw or {}
    if not isinstance(raw, dict):
        raise ctx.fail("motors", "expected a mapping coordinate: inertia")
    motors: Dict[str, sp.Expr] = {}
    for cname, value in raw.items():
        if cname not in coords:
            raise ctx.fail(f"motors.{excerpt(cname, 30)}", "not a coordinate")
        motors[cname] = const.expr(value, f"motors.{cname}")
    return motors


def _parse_spring(ctx: _Ctx, const: _Ctx, spec, where: str, bodies: Sequence[str], coord_syms) -> Spring:
    if not isinstance(spec, dict):
        raise ctx.fail(where, "expected a mapping")
    _check_keys(ctx, spec, {"name", "stiffness", "force", "expr", "rest", "between"}, where)
    sname = str(spec.get("name", where.replace("springs[", "spring").rstrip("]")))
    if ("expr" in spec) == ("between" in spec):
        raise ctx.fail(where, "give exactly one of expr (a function of the coordinates) or between (two points)")
    if "force" in spec:
        if "stiffness" in spec or "between" in spec:
            raise ctx.fail(where, "a nonlinear spring gives force (a polynomial in delta) and expr, not stiffness or between")
        force = _Ctx(ctx.source, list(const.names) + [DELTA]).expr(spec["force"], f"{where}.force")
        stretch = symbol(DELTA)
        if not force.is_polynomial(stretch) or force.free_symbols & coord_syms:
            raise ctx.fail(f"{where}.force", f"expected a polynomial in delta with constant coefficients, got {excerpt(force)}")
        if sp.expand(force.xreplace({stretch: 0})) != 0:
            raise ctx.fail(f"{where}.force", "the force must vanish at delta = 0 (give rest for a preloaded spring)")
        return Spring(sname, None, _stretch_expr(ctx, spec["expr"], f"{where}.expr", coord_syms),
                      const.expr(spec.get("rest", 0), f"{where}.rest"), force=force)
    k = const.expr(spec.get("stiffness"), f"{where}.stiffness")
    if "expr" in spec:
        return Spring(sname, k, _stretch_expr(ctx, spec["expr"], f"{where}.expr", coord_syms),
                      const.expr(spec.get("rest", 0), f"{where}.rest"))
    pts = spec["between"]
    if not isinstance(pts, list) or len(pts) != 2:
        raise ctx.fail(f"{where}.between", "expected two points [body, [x, y, z]]")
    parsed = []
    for j, pt in enumerate(pts):
        if not isinstance(pt, list) or len(pt) != 2:
            raise ctx.fail(f"{where}.between[{j}]", "expected [body, [x, y, z]] (body may be base)")
        bn = pt[0]
        if bn != "base" and bn not in bodies:
            raise ctx.fail(f"{where}.between[{j}]", f"unknown body {excerpt(bn, 30)}")
        parsed.append((None if bn == "base" else bn, const.vector(pt[1], f"{where}.between[{j}][1]")))
    if "rest" in spec and spec["rest"] not in (0, "0"):
        raise ctx.fail(f"{where}.rest", "springs between points have zero rest length")
    return Spring(sname, k, None, sp.Integer(0), tuple(parsed))


def _stretch_expr(ctx: _Ctx, value, where: str, coord_syms) -> sp.Expr:
    expr = ctx.expr(value, where)
    if not expr.free_symbols & coord_syms:
        raise ctx.fail(where, "must depend on the coordinates")
    return expr


def _parse_springs(ctx: _Ctx, const: _Ctx, raw, bodies: Sequence[str], coord_syms) -> List[Spring]:
    raw = raw or []
    if not isinstance(raw, list):
        raise ctx.fail("springs", "expected a list")
    return [_parse_spring(ctx, const, spec, f"springs[{i}]", bodies, coord_syms) for i, spec in enumerate(raw)]


def _parse_dampers(ctx: _Ctx, const: _Ctx, raw, coord_syms) -> List[Damper]:
    raw = raw or []
    if not isinstance(raw, list):
        raise ctx.fail("dampers", "expected a list of {name, coefficient, expr}")
    dampers = []
    for i, spec in enumerate(raw):
        where = f"dampers[{i}]"
        if not isinstance(spec, dict):
            raise ctx.fail(where, "expected a mapping {name, coefficient, expr}")
        _check_keys(ctx, spec, {"name", "coefficient", "expr"}, where)
        expr = _stretch_expr(ctx, spec.get("expr"), f"{where}.expr", coord_syms)
        if any(sp.diff(expr, c).free_symbols & coord_syms for c in coord_syms):
            raise ctx.fail(f"{where}.expr", f"a damper acts on an affine function of the coordinates "
                           f"(e.g. theta - q), got {excerpt(expr)}")
        dampers.append(Damper(str(spec.get("name", f"damper{i + 1}")),
                              const.expr(spec.get("coefficient"), f"{where}.coefficient"), expr))
    return dampers


def _parse_friction(ctx: _Ctx, const: _Ctx, raw, coords) -> Tuple[Dict[str, sp.Expr], Dict[str, sp.Expr]]:
    viscous: Dict[str, sp.Expr] = {}
    coulomb: Dict[str, sp.Expr] = {}
    raw = raw or {}
    if not isinstance(raw, dict):
        raise ctx.fail("friction", "expected a mapping with viscous and/or coulomb")
    _check_keys(ctx, raw, {"viscous", "coulomb"}, "friction")
    for kind_name, target in (("viscous", viscous), ("coulomb", coulomb)):
        entries = raw.get(kind_name) or {}
        if not isinstance(entries, dict):
            raise ctx.fail(f"friction.{kind_name}", "expected a mapping coordinate: coefficient")
        for cname, value in entries.items():
            if cname not in coords:
                raise ctx.fail(f"friction.{kind_name}.{excerpt(cname, 30)}", "not a coordinate")
            target[cname] = const.expr(value, f"friction.{kind_name}.{cname}")
    return viscous, coulomb


def _number(ctx: _Ctx, value, where: str) -> float:
    try:
        return parse_number(value)
    except ExpressionError as exc:
        raise ctx.fail(where, str(exc)) from None


def _parse_limits(ctx: _Ctx, raw, coords) -> Dict[str, Limits]:
    limits: Dict[str, Limits] = {}
    raw = raw or {}
    if not isinstance(raw, dict):
        raise ctx.fail("limits", "expected a mapping coordinate: {position, velocity, torque}")
    for cname, spec in raw.items():
        where = f"limits.{excerpt(cname, 30) if cname not in coords else cname}"
        if cname not in coords:
            raise ctx.fail(where, "not a coordinate")
        if not isinstance(spec, dict):
            raise ctx.fail(where, "expected a mapping with position, velocity, torque")
        _check_keys(ctx, spec, {"position", "velocity", "torque"}, where)
        pos = spec.get("position")
        if pos is not None:
            if not isinstance(pos, list) or len(pos) != 2:
                raise ctx.fail(f"{where}.position", "expected [lower, upper]")
            lo, hi = (_number(ctx, v, f"{where}.position") for v in pos)
            if not lo < hi:
                raise ctx.fail(f"{where}.position", f"lower limit {lo} must be below upper {hi}")
            pos = (lo, hi)
        vel, tor = (None if spec.get(k) is None else _number(ctx, spec[k], f"{where}.{k}") for k in ("velocity", "torque"))
        for label, v in (("velocity", vel), ("torque", tor)):
            if v is not None and not v > 0:
                raise ctx.fail(f"{where}.{label}", "must be positive")
        limits[cname] = Limits(pos, vel, tor)
    return limits


def _parse_points(ctx: _Ctx, const: _Ctx, raw, bodies: Sequence[str]) -> Dict[str, Point]:
    points: Dict[str, Point] = {}
    raw = raw or {}
    if not isinstance(raw, dict):
        raise ctx.fail("points", "expected a mapping name: {body, at}")
    for pname, spec in raw.items():
        where = f"points.{excerpt(pname, 30) if not _is_name(pname) else pname}"
        if not _is_name(pname):
            raise ctx.fail(where, "a point name must be an ASCII identifier")
        if not isinstance(spec, dict) or "body" not in spec:
            raise ctx.fail(where, "expected {body: NAME, at: [x, y, z]}")
        _check_keys(ctx, spec, {"body", "at"}, where)
        bn = spec["body"]
        if bn != "base" and bn not in bodies:
            raise ctx.fail(f"{where}.body", f"unknown body {excerpt(bn, 30)}")
        points[pname] = Point(pname, None if bn == "base" else bn, const.vector(spec.get("at", [0, 0, 0]), f"{where}.at"))
    return points


def _parse_plane(ctx: _Ctx, plane, bodies: Sequence[Body]) -> Optional[str]:
    if plane not in (None, "vertical", "horizontal"):
        raise ctx.fail("plane", f"expected vertical, horizontal or nothing (spatial), got {excerpt(plane)}")
    if plane is not None:
        for b in bodies:
            if b.joint.type == "revolute" and b.joint.axis not in ((0, 0, 1), (0, 0, -1)):
                raise ctx.fail(f"bodies ({b.name})", "a planar robot (plane: ...) needs revolute axes along z")
    return plane


def _check_coordinates_used(ctx: _Ctx, coords, bodies: Sequence[Body], motors) -> None:
    used = set(symbol(c) for c in motors)
    for b in bodies:
        used |= b.joint.value.free_symbols
    unused = [c for c in coords if symbol(c) not in used]
    if unused:
        raise ctx.fail("coordinates", f"coordinate(s) {unused} move no joint and no motor")


def _value_at(ctx: _Ctx, expr: sp.Expr, values: Mapping[sp.Symbol, float], where: str) -> float:
    try:
        value = float(expr.xreplace(values))
    except (TypeError, ValueError, OverflowError):
        raise ctx.fail(where, f"not a real number at the default parameter values ({excerpt(expr)})") from None
    if not math.isfinite(value):
        raise ctx.fail(where, f"not finite at the default parameter values ({excerpt(expr)})")
    return value


def _check_physics(ctx: _Ctx, robot: "RobotModel") -> None:
    """At the default parameter values: masses, rotor inertias, stiffnesses, damper and friction
    coefficients not negative, inertia tensors positive semi-definite (the triangle inequality of
    principal moments is not imposed: exam models often give only the moment about the joint axis),
    and the inertia matrix M(q) positive definite (app.core.mass_check: not singular at q = 0 and at
    three seeded random configurations)."""
    values = {p.symbol: p.value for p in robot.parameters.values()}

    def non_negative(expr, where, what):
        value = _value_at(ctx, expr, values, where)
        shown = "" if expr.is_number else f"{sp.sstr(expr)[:40]} = {value:g} at the default parameter values"
        refusal = refuse_negative(f"a {what}", value, shown)
        if refusal:
            raise ctx.fail(where, refusal)

    for i, body in enumerate(robot.bodies):
        where = f"bodies[{i}] ({body.name})"
        non_negative(body.mass, f"{where}.mass", "mass")
        tensor = np.array([[_value_at(ctx, body.inertia[r, c], values, f"{where}.inertia")
                            for c in range(3)] for r in range(3)])
        eigenvalues = np.linalg.eigvalsh(tensor)
        if eigenvalues.min() < -1e-12 * max(1.0, float(np.abs(eigenvalues).max())):
            raise ctx.fail(f"{where}.inertia", "the inertia tensor must be positive semi-definite (principal "
                           f"moments {', '.join(f'{e:.4g}' for e in eigenvalues)} at the default parameter values)")
    for cname, inertia in robot.motor_inertias.items():
        non_negative(inertia, f"motors.{cname}", "rotor inertia")
    for i, spring in enumerate(robot.springs):
        if spring.force is None:
            non_negative(spring.stiffness, f"springs[{i}].stiffness", "stiffness")
        else:
            linear = sp.diff(spring.force, symbol(DELTA)).xreplace({symbol(DELTA): 0})
            non_negative(linear, f"springs[{i}].force", "linear stiffness (the force's slope at delta = 0)")
    for i, damper in enumerate(robot.dampers):
        non_negative(damper.coefficient, f"dampers[{i}].coefficient", "damping coefficient")
    for kind_name, coefficients in (("viscous", robot.viscous), ("coulomb", robot.coulomb)):
        for cname, coeff in coefficients.items():
            non_negative(coeff, f"friction.{kind_name}.{cname}", "friction coefficient")
    singular = singular_directions(robot, values)
    if singular:
        raise ctx.fail("bodies", singular)


def parse_robot(data, source: str = "<robot>", content_hash: str = "") -> RobotModel:
    """Build a RobotModel from the parsed YAML mapping ``data``; raise RobotFileError on problems."""
    ctx = _Ctx(source, [])
    name, group = _parse_header(ctx, data)
    coords = _parse_coordinates(ctx, data["coordinates"])
    params = _parse_parameters(ctx, data.get("parameters"), coords)
    ctx.names = set(coords) | set(params)
    coord_syms = {symbol(c) for c in coords}
    const = _Ctx(source, list(params))          # for expressions that must not depend on q
    gravity = const.vector(data.get("gravity", [0, 0, 0]), "gravity")
    bodies = _parse_bodies(ctx, const, data["bodies"], coord_syms)
    body_names = [b.name for b in bodies]
    motors = _parse_motors(ctx, const, data.get("motors"), coords)
    springs = _parse_springs(ctx, const, data.get("springs"), body_names, coord_syms)
    dampers = _parse_dampers(ctx, const, data.get("dampers"), coord_syms)
    _check_coordinates_used(ctx, coords, bodies, motors)
    viscous, coulomb = _parse_friction(ctx, const, data.get("friction"), coords)
    act_spec = data.get("actuated", list(coords))
    if not isinstance(act_spec, list) or any(a not in coords for a in act_spec):
        raise ctx.fail("actuated", f"expected a list of coordinate names, got {excerpt(act_spec)}")
    defaults_raw = data.get("defaults") or {}
    if not isinstance(defaults_raw, dict) or any(k not in coords for k in defaults_raw):
        raise ctx.fail("defaults", "expected a mapping coordinate: value")
    draw = data.get("draw") or {}
    if not isinstance(draw, dict):
        raise ctx.fail("draw", "expected a mapping")
    notes = data.get("notes") or []
    notes = [notes] if isinstance(notes, str) else notes
    if not isinstance(notes, list):
        raise ctx.fail("notes", "expected a text or a list of texts")
    notes = [_text(ctx, n, f"notes[{i}]") for i, n in enumerate(notes)]
    robot = RobotModel(
        name=name, title=_text(ctx, data.get("title", name), "title"),
        description=_text(ctx, data.get("description", ""), "description"),
        group=group, coordinates=tuple(coords), parameters=params, gravity=gravity,
        bodies=tuple(bodies), springs=tuple(springs), dampers=tuple(dampers), motor_inertias=motors,
        viscous=viscous, coulomb=coulomb, actuated=tuple(c in act_spec for c in coords),
        limits=_parse_limits(ctx, data.get("limits"), coords),
        points=_parse_points(ctx, const, data.get("points"), body_names),
        plane=_parse_plane(ctx, data.get("plane"), bodies), draw=draw,
        defaults={k: _number(ctx, v, f"defaults.{k}") for k, v in defaults_raw.items()},
        source=source, content_hash=content_hash, notes=tuple(notes))
    _check_physics(ctx, robot)
    return robot


def robot_path(name_or_path: str | Path) -> Path:
    """Resolve a shipped robot's name or a path to a robot file."""
    if not str(name_or_path).strip():
        raise RobotFileError("empty robot name (give a shipped robot's name or a path to a robot file)")
    path = named_file(name_or_path, shipped_robot(name_or_path), ROBOT_SUFFIXES, RobotFileError)
    if path is not None:
        return path
    known = ", ".join(list_robot_names()[:8])
    raise RobotFileError(f"unknown robot {excerpt(name_or_path)} (not a file, not a shipped robot; e.g. {known} ...; "
                         f"`python -m app robots` lists them)")


def load_robot(name_or_path: str | Path) -> RobotModel:
    """Load a shipped robot by name or a robot file by path (a regular text file of at most 1 MB)."""
    path = robot_path(name_or_path)
    shipped = Path(path).resolve().parent == ROBOTS_DIR.resolve()
    return load_robot_text(read_user_file(path, RobotFileError), str(path), shipped)


def load_robot_text(text: str, source: str = "<robot>", shipped: bool = False) -> RobotModel:
    """A robot from the text of a robot file (YAML) or of a URDF file (app/core/urdf.py);
    ``shipped``: the text of a file in app/robots (read with libyaml's loader)."""
    if is_urdf(text, source):
        data = robot_data_from_urdf(text, source)
        digest = hashlib.sha256(json.dumps(data, sort_keys=True).encode("utf-8")).hexdigest()
        return parse_robot(data, source, digest)
    data = load_yaml(text, source, RobotFileError, shipped)
    digest = hashlib.sha256(text.encode("utf-8")).hexdigest()
    return parse_robot(data, source, digest)
