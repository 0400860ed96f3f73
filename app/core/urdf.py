"""URDF in and out: a robot file written as URDF, and a URDF file read as a robot file.

Out (``to_urdf``): the robot at given parameter values (URDF holds numbers only). Every moving
body becomes a link with a revolute (``continuous`` when the file gives no position limits) or
prismatic joint named after its coordinate, fixed bodies and named points become links on fixed
joints, viscous and Coulomb friction become ``<dynamics damping friction>``. URDF has no gravity:
when the robot's gravity is not along -z, a root link ``world`` holds the robot's base rotated so
that gravity points along world -z, and a comment states its magnitude (set ``model.gravity`` in
pinocchio when it is not 9.81). What URDF cannot express is refused with the reason
(``urdf_refusal``): a joint moved by a map of several coordinates or a multiple of one, a
coordinate that moves two joints, springs, elastic joints (motor coordinates).

In (``robot_data_from_urdf``): revolute, continuous, prismatic and fixed joints (``mimic`` too)
with their inertials, as the mapping of a robot file (docs/robot-format.md), so that a URDF file
loads wherever a robot file does. Coordinates are q1, q2, ... in depth-first order from the root
link; every number becomes a parameter named after its link (``m_L``, ``c_L_x``, ``I_L_xx``,
``l_L_x`` for the joint origin of link L, ``fv_L``, ``fc_L``), holding the magnitude, the sign
in the expression; massless links on fixed joints are merged into their parent (a leaf one
becomes a named point). The XML is parsed without a DOCTYPE (no entities at all) and with bounded
size.

>>> from app.core.robot import load_robot
>>> text = to_urdf(load_robot("planar_2r"))
>>> data = robot_data_from_urdf(text, "planar_2r.urdf")
>>> data["coordinates"], sorted(data["parameters"])[:4]
(['q1', 'q2'], ['I_link1_xx', 'I_link1_yy', 'I_link1_zz', 'I_link2_xx'])
"""
from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET
from typing import TYPE_CHECKING, Dict, List, Mapping, Optional, Tuple

import numpy as np
import sympy as sp

from .errors import UserError
from .robot_model import refuse_negative

if TYPE_CHECKING:       # robot.py reads URDF files through this module
    from .robot import RobotModel

#: largest URDF text read [characters] and most links and joints
MAX_URDF_CHARS = 2_000_000
MAX_URDF_LINKS = 200


class UrdfError(UserError):
    """A robot that URDF cannot express, or a URDF file that cannot be read as a robot."""


# ====================================================================== out
def urdf_refusal(robot: RobotModel) -> Optional[str]:
    """Why the robot cannot be written as URDF (one sentence), or None when it can.

    >>> from app.core.robot import load_robot
    >>> urdf_refusal(load_robot("planar_2r")) is None
    True
    >>> urdf_refusal(load_robot("kin_planar_3r_absolute"))
    'link2 moves by -q1 + q2, a map of several coordinates (a URDF joint moves by one coordinate plus a constant)'
    """
    if robot.motor_inertias:
        return (f"elastic joints: the motor coordinate(s) {', '.join(robot.motor_inertias)} move no link "
                "(URDF has no rotor coordinates)")
    for spring in robot.springs:
        what = "between two points" if spring.points else f"on {spring.expr}"
        return f"the spring '{spring.name}' {what} (URDF has no springs)"
    try:
        _masters(robot)
    except ValueError as exc:
        return str(exc)
    return None


def _masters(robot: RobotModel) -> Dict[sp.Symbol, str]:
    """Per coordinate, the body whose URDF joint it is (moved by +-q plus a constant); the other
    joints it moves become mimic joints. ValueError with the reason when URDF cannot say it."""
    movers: Dict[sp.Symbol, List[Tuple[str, int]]] = {}
    for body in robot.bodies:
        if body.joint.type == "fixed":
            continue
        try:
            q, slope, _offset = _one_coordinate(robot, body.joint.value)
        except ValueError as exc:
            raise ValueError(f"{body.name} moves by {body.joint.value}, {exc} "
                             "(a URDF joint moves by one coordinate plus a constant)") from None
        movers.setdefault(q, []).append((body.name, slope))
    masters = {}
    for q, bodies in movers.items():
        unit = [name for name, slope in bodies if slope in (1, -1)]
        if not unit:
            raise ValueError(f"{q} moves {', '.join(name for name, _ in bodies)} by a multiple of {q} "
                             "(a URDF joint moves by one coordinate plus a constant)")
        masters[q] = unit[0]
    return masters


def _one_coordinate(robot: RobotModel, value: sp.Expr) -> Tuple[sp.Symbol, sp.Expr, sp.Expr]:
    """(q, s, c) with value = s q + c, s a nonzero number and c free of coordinates; ValueError otherwise."""
    coordinates = [q for q in robot.q if value.has(q)]
    if len(coordinates) != 1:
        raise ValueError("a map of several coordinates")
    q = coordinates[0]
    slope = sp.diff(value, q)
    if slope.free_symbols & set(robot.q) or not slope.is_number or slope == 0:
        raise ValueError(f"a nonlinear function of {q}")
    return q, slope, sp.expand(value - slope * q)


def urdf_gravity(robot: RobotModel, values: Optional[Mapping[str, float]] = None) -> np.ndarray:
    """Gravity of the written URDF's root frame [m/s^2]: (0, 0, -|g|), or zero.

    >>> from app.core.robot import load_robot
    >>> [float(x) + 0.0 for x in urdf_gravity(load_robot("planar_2r"))]   # exact: the file's g0 = 9.81
    [0.0, 0.0, -9.81]
    """
    g = _gravity(robot, values)
    return np.array([0.0, 0.0, -float(np.linalg.norm(g))])


def _gravity(robot, values) -> np.ndarray:
    subs = _subs(robot, values)
    return np.array([float(e.xreplace(subs)) for e in robot.gravity], dtype=float)


def _subs(robot: RobotModel, values: Optional[Mapping[str, float]]):
    from .expressions import symbol
    return {symbol(k): sp.Float(v) for k, v in robot.parameter_values(values).items()}


def to_urdf(robot: RobotModel, values: Optional[Mapping[str, float]] = None) -> str:
    """The robot as URDF text at the given parameter values (default: the file's).

    Raises UrdfError with the reason when URDF cannot express the robot (``urdf_refusal``).

    >>> from app.core.robot import load_robot
    >>> text = to_urdf(load_robot("planar_2r"), {"m2": 3.0})
    >>> '<joint name="q2" type="continuous">' in text, '<mass value="3" />' in text
    (True, True)
    """
    reason = urdf_refusal(robot)
    if reason:
        raise UrdfError(f"{robot.name} cannot be written as URDF: {reason}")
    subs = _subs(robot, values)

    def number(expr) -> float:
        return float(sp.sympify(expr).xreplace(subs))

    def frame(tf) -> np.ndarray:
        T = np.eye(4)
        T[:3, :3] = np.array(tf.R.xreplace(subs), dtype=float)
        T[:3, 3] = [number(e) for e in tf.p]
        return T

    root = ET.Element("robot", name=robot.name)
    root.append(ET.Comment(f" {robot.title}: written by Robotics II Lab from {robot.source or robot.name} "))
    g = _gravity(robot, values)
    g_norm = float(np.linalg.norm(g))
    root.append(ET.Comment(f" gravity: {_num(g_norm)} m/s^2 along -z of the root link "
                           "(URDF has no gravity: pinocchio assumes 9.81) "))
    names = _unique_names([b.name for b in robot.bodies] + list(robot.points) + ["world", "base"])
    base_link = names["base"]
    if g_norm > 0 and not np.allclose(g / g_norm, [0, 0, -1], atol=1e-12):
        world = names["world"]
        ET.SubElement(root, "link", name=world)
        T = np.eye(4)
        T[:3, :3] = _rotation_to_minus_z(g / g_norm)
        _joint(root, f"{base_link}_in_{world}", "fixed", world, base_link, T)
    ET.SubElement(root, "link", name=base_link)
    masters = _masters(robot)
    after = {None: np.eye(4)}         # per body: its URDF link frame -> its body frame (the post transform)
    link_of = {None: base_link}
    for body in robot.bodies:
        joint = body.joint
        origin = after[body.parent] @ frame(joint.pre)
        link = ET.SubElement(root, "link", name=names[body.name])
        link_of[body.name] = names[body.name]
        post = frame(joint.post)
        after[body.name] = post
        _inertial(link, number(body.mass), post, [number(e) for e in body.com],
                  np.array(body.inertia.xreplace(subs), dtype=float))
        if joint.type == "fixed":
            _joint(root, f"fixed_{names[body.name]}", "fixed", link_of[body.parent], names[body.name], origin)
            continue
        q, slope, offset = _one_coordinate(robot, joint.value)
        axis = np.array([float(a) for a in joint.axis], dtype=float)
        shift = np.eye(4)
        if joint.type == "revolute":
            shift[:3, :3] = _axis_rotation(axis, number(offset))
        else:
            shift[:3, 3] = axis * number(offset)
        name = str(q)
        limits = robot.limits.get(name)
        position = limits.position if limits else None
        kind = joint.type if position is not None or joint.type == "prismatic" else "continuous"
        if masters[q] == body.name:        # the joint angle is q: the sign goes into the axis
            element = _joint(root, name, kind, link_of[body.parent], names[body.name], origin @ shift, float(slope) * axis)
            _limit(element, robot, joint.type, position, limits)
            damping, friction = robot.viscous.get(name), robot.coulomb.get(name)
            if damping is not None or friction is not None:
                ET.SubElement(element, "dynamics", damping=_num(number(damping or 0)),
                              friction=_num(number(friction or 0)))
            if not robot.actuated[robot.coordinates.index(name)]:
                element.append(ET.Comment(f" {name} is not actuated in the robot file "))
        else:                              # another joint moved by q: a mimic joint, angle slope * q
            element = _joint(root, f"{name}_{names[body.name]}", kind, link_of[body.parent], names[body.name],
                             origin @ shift, axis)
            scaled = None if position is None else tuple(sorted(float(slope) * np.array(position)))
            _limit(element, robot, joint.type, scaled, limits)
            ET.SubElement(element, "mimic", joint=name, multiplier=_num(float(slope)), offset="0")
    for point in robot.points.values():
        T = np.eye(4)
        T[:3, 3] = (after[point.body] @ np.r_[[number(e) for e in point.position], 1.0])[:3]
        ET.SubElement(root, "link", name=names[point.name])
        _joint(root, f"fixed_{names[point.name]}", "fixed", link_of[point.body], names[point.name], T)
    ET.indent(root)
    return '<?xml version="1.0"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


def _unique_names(wanted: List[str]) -> Dict[str, str]:
    """A distinct link name for each wanted name (later duplicates get a suffix)."""
    out: Dict[str, str] = {}
    used = set()
    for name in wanted:
        candidate, k = name, 2
        while candidate in used:
            candidate, k = f"{name}_{k}", k + 1
        out.setdefault(name, candidate)
        used.add(candidate)
    return out


def _num(x: float) -> str:
    """A float as the shortest text that reads back to the same value (round-off below 1e-15: 0)."""
    x = float(x)
    if abs(x) < 1e-15:
        return "0"
    return str(int(x)) if x.is_integer() and abs(x) < 1e15 else repr(x)


def _rpy(R: np.ndarray) -> Tuple[float, float, float]:
    """Roll, pitch, yaw of R = Rz(yaw) Ry(pitch) Rx(roll) (URDF's convention and the robot files').

    >>> R = _axis_rotation(np.array([0.0, 0.0, 1.0]), 0.5) @ _axis_rotation(np.array([1.0, 0.0, 0.0]), 0.25)
    >>> [round(a, 6) + 0.0 for a in _rpy(R)]
    [0.25, 0.0, 0.5]
    """
    cos_pitch = math.hypot(R[0, 0], R[1, 0])
    pitch = math.atan2(-R[2, 0], cos_pitch)
    if cos_pitch < 1e-12:    # gimbal lock: roll merged into yaw
        return 0.0, pitch, math.atan2(-R[0, 1], R[1, 1])
    return math.atan2(R[2, 1], R[2, 2]), pitch, math.atan2(R[1, 0], R[0, 0])


def _axis_rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rotation by ``angle`` [rad] about the unit ``axis`` (Rodrigues)."""
    ux = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + math.sin(angle) * ux + (1 - math.cos(angle)) * ux @ ux


def _rotation_to_minus_z(direction: np.ndarray) -> np.ndarray:
    """A rotation R with R direction = (0, 0, -1) (the world frame in which gravity points down)."""
    target = np.array([0.0, 0.0, -1.0])
    axis = np.cross(direction, target)
    s, c = float(np.linalg.norm(axis)), float(direction @ target)
    if s < 1e-12:
        return np.eye(3) if c > 0 else np.diag([1.0, -1.0, -1.0])
    return _axis_rotation(axis / s, math.atan2(s, c))


def _origin(parent: ET.Element, T: np.ndarray) -> None:
    xyz = " ".join(_num(v) for v in T[:3, 3])
    rpy = " ".join(_num(v) for v in _rpy(T[:3, :3]))
    ET.SubElement(parent, "origin", xyz=xyz, rpy=rpy)


def _joint(root, name, kind, parent, child, T, axis=None) -> ET.Element:
    element = ET.SubElement(root, "joint", name=name, type=kind)
    ET.SubElement(element, "parent", link=parent)
    ET.SubElement(element, "child", link=child)
    _origin(element, T)
    if axis is not None:
        ET.SubElement(element, "axis", xyz=" ".join(_num(v) for v in axis))
    return element


def _inertial(link, mass: float, post: np.ndarray, com, inertia: np.ndarray) -> None:
    """The body's mass, CoM and inertia about the CoM, expressed in the URDF link frame."""
    if mass == 0 and not np.any(inertia):
        return
    element = ET.SubElement(link, "inertial")
    T = np.eye(4)
    T[:3, 3] = (post @ np.r_[com, 1.0])[:3]
    _origin(element, T)
    ET.SubElement(element, "mass", value=_num(mass))
    R = post[:3, :3]
    I = R @ inertia @ R.T
    ET.SubElement(element, "inertia", **{f"i{a}{b}": _num(I[i, j]) for (a, i), (b, j) in
                                         ((("x", 0), ("x", 0)), (("x", 0), ("y", 1)), (("x", 0), ("z", 2)),
                                          (("y", 1), ("y", 1)), (("y", 1), ("z", 2)), (("z", 2), ("z", 2)))})


#: written for a joint without that limit in the robot file (URDF requires effort and velocity)
UNLIMITED = 1e6


def _limit(element, robot, jtype, position, limits) -> None:
    attrs = {}
    if position is None and jtype == "prismatic":
        reach = float(robot.draw.get("prismatic_range", 0.5))
        position = (-reach, reach)
        element.append(ET.Comment(f" no position limits in the robot file: the page's slider range +-{_num(reach)} m "))
    if position is not None:
        attrs.update(lower=_num(position[0]), upper=_num(position[1]))
    effort = limits.torque if limits and limits.torque else None
    velocity = limits.velocity if limits and limits.velocity else None
    missing = [what for what, value in (("torque", effort), ("velocity", velocity)) if value is None]
    if missing:
        element.append(ET.Comment(f" no {' or '.join(missing)} limit in the robot file: {_num(UNLIMITED)} written "))
    attrs.update(effort=_num(effort or UNLIMITED), velocity=_num(velocity or UNLIMITED))
    ET.SubElement(element, "limit", **attrs)


# ====================================================================== in
_NUMBER_OF_PI = 12     # angles within 1e-9 of a multiple of pi/12 are written exactly


def is_urdf(text: str, source: str = "") -> bool:
    """Whether a robot file's text is URDF (by its name, else by its first character).

    >>> is_urdf("<robot name='x'/>"), is_urdf("name: x"), is_urdf("", "arm.urdf")
    (True, False, True)
    """
    return source.lower().endswith(".urdf") or text.lstrip().startswith("<")


def parse_urdf(text: str, source: str = "<urdf>") -> ET.Element:
    """The ``<robot>`` element of a URDF text, parsed safely: bounded size, no DOCTYPE (so no
    entity can be declared or expanded).

    >>> parse_urdf('<!DOCTYPE r [<!ENTITY a "aa">]><robot name="x"/>', "bomb.urdf")
    Traceback (most recent call last):
    ...
    app.core.urdf.UrdfError: bomb.urdf: a URDF file must not declare a DOCTYPE or entities (refused for safety)
    """
    if len(text) > MAX_URDF_CHARS:
        raise UrdfError(f"{source}: {len(text)} characters, more than the {MAX_URDF_CHARS} a URDF file may have")
    if re.search(r"<!\s*(DOCTYPE|ENTITY)", text, re.IGNORECASE):
        raise UrdfError(f"{source}: a URDF file must not declare a DOCTYPE or entities (refused for safety)")
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise UrdfError(f"{source}: not valid XML: {exc}") from None
    if root.tag != "robot":
        raise UrdfError(f"{source}: the root element is <{root.tag}>, not <robot>")
    if len(root) > 2 * MAX_URDF_LINKS + 10:
        raise UrdfError(f"{source}: more than {MAX_URDF_LINKS} links (too large for the symbolic engine)")
    return root


class _Reader:
    """Turns the parsed URDF into a robot file's mapping (see ``robot_data_from_urdf``)."""

    def __init__(self, root: ET.Element, source: str):
        self.source = source
        self.links = {}
        for element in root.findall("link"):
            name = element.get("name")
            if not name:
                raise self.fail("a <link> without a name")
            if name in self.links:
                raise self.fail(f"two links named '{name}'")
            self.links[name] = element
        self.joints = root.findall("joint")
        self.children: Dict[str, List[ET.Element]] = {name: [] for name in self.links}
        parent_of: Dict[str, str] = {}
        for joint in self.joints:
            jname = joint.get("name", "?")
            parent, child = (self.attr(joint, tag, "link", f"joint '{jname}'") for tag in ("parent", "child"))
            for link in (parent, child):
                if link not in self.links:
                    raise self.fail(f"joint '{jname}' names the unknown link '{link}'")
            if child in parent_of:
                raise self.fail(f"link '{child}' is the child of two joints")
            parent_of[child] = parent
            self.children[parent].append(joint)
        roots = [name for name in self.links if name not in parent_of]
        if len(roots) != 1:
            raise self.fail(f"expected one root link (a tree), found {len(roots)}: {roots[:5]}")
        self.root = roots[0]
        self.identifiers = _identifiers(list(self.links))
        self.data = {"parameters": {}, "bodies": [], "points": {}, "limits": {},
                     "friction": {"viscous": {}, "coulomb": {}}}
        self.coordinate_of: Dict[str, str] = {}       # URDF joint name -> coordinate
        self.notes: List[str] = []

    def fail(self, what: str) -> UrdfError:
        return UrdfError(f"{self.source}: {what}")

    def attr(self, element, tag, key, where) -> str:
        sub = element.find(tag)
        if sub is None or not sub.get(key):
            raise self.fail(f"{where}: missing <{tag} {key}=...>")
        return sub.get(key)

    def numbers(self, text: Optional[str], count: int, where: str) -> np.ndarray:
        if text is None:
            return np.zeros(count)
        try:
            values = np.array([float(v) for v in text.split()], dtype=float)
        except ValueError:
            raise self.fail(f"{where}: expected {count} numbers, got {text[:60]!r}") from None
        if values.size != count or not np.all(np.isfinite(values)):
            raise self.fail(f"{where}: expected {count} finite numbers, got {text[:60]!r}")
        return values

    def origin(self, element, where) -> np.ndarray:
        """The 4x4 transform of an element's <origin xyz rpy> (identity when absent)."""
        T = np.eye(4)
        origin = element.find("origin")
        if origin is not None:
            r, p, y = self.numbers(origin.get("rpy"), 3, f"{where} origin rpy")
            T[:3, :3] = (_axis_rotation(np.array([0.0, 0, 1]), y) @ _axis_rotation(np.array([0.0, 1, 0]), p)
                         @ _axis_rotation(np.array([1.0, 0, 0]), r))
            T[:3, 3] = self.numbers(origin.get("xyz"), 3, f"{where} origin xyz")
        return T

    def parameter(self, name: str, value: float, kind: str, unit: str) -> str:
        """An expression naming a new parameter with |value|, the sign in front; '0' for zero."""
        if abs(value) < 1e-12:
            return "0"
        self.data["parameters"][name] = {"value": abs(float(value)), "kind": kind, "unit": unit}
        return name if value > 0 else f"-{name}"

    # ------------------------------------------------------------------ the tree
    def read(self) -> dict:
        self.walk(self.root, None, np.eye(4))
        coordinates = sorted(set(self.coordinate_of.values()), key=lambda c: int(c[1:]))
        if not coordinates:
            raise self.fail("no revolute, continuous or prismatic joint: nothing moves")
        self.data["coordinates"] = coordinates
        return self.data

    def walk(self, link: str, body: Optional[str], offset: np.ndarray) -> None:
        """Add the joints below ``link``, whose frame is ``offset`` in the frame of ``body`` (the
        robot-file body it belongs to; None: the base)."""
        for joint in self.children[link]:
            jname = joint.get("name", "?")
            kind = joint.get("type", "")
            child = self.attr(joint, "child", "link", f"joint '{jname}'")
            where = f"joint '{jname}'"
            if kind in ("floating", "planar"):
                raise self.fail(f"{where}: a {kind} joint cannot be read (only revolute, continuous, prismatic, fixed)")
            if kind not in ("revolute", "continuous", "prismatic", "fixed"):
                raise self.fail(f"{where}: unknown joint type {kind!r}")
            T = offset @ self.origin(joint, where)
            mass, com, inertia = self.inertial(child)
            if kind == "fixed" and mass == 0 and not np.any(inertia):
                if self.children[child]:
                    self.walk(child, body, T)          # a massless frame: merged into its parent
                else:
                    self.point(child, body, T)
                continue
            self.body(joint, kind, child, body, T, mass, com, inertia)
            self.walk(child, self.body_name(child), np.eye(4))

    def body_name(self, link: str) -> str:
        """The robot-file body of a link: its identifier (``upper-arm`` -> ``upper_arm``), ``base_``
        for a link named base (the robot file's name of the fixed frame)."""
        ident = self.identifiers[link]
        return ident if ident != "base" else "base_"

    def point(self, link: str, body: Optional[str], T: np.ndarray) -> None:
        ident = self.identifiers[link]
        xyz = [self.parameter(f"l_{ident}_{a}", v, "length", "m") for a, v in zip("xyz", T[:3, 3])]
        self.data["points"][ident] = {"body": body or "base", "at": xyz}

    def inertial(self, link: str):
        element = self.links[link].find("inertial")
        if element is None:
            return 0.0, np.zeros(3), np.zeros((3, 3))
        where = f"link '{link}' inertial"
        mass_el = element.find("mass")
        mass = 0.0 if mass_el is None else float(self.numbers(mass_el.get("value"), 1, f"{where} mass")[0])
        refusal = refuse_negative("a mass", mass)
        if refusal:
            raise self.fail(f"{where}: {refusal}")
        T = self.origin(element, where)
        tensor = element.find("inertia")
        entries = {}
        for key in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz"):
            entries[key] = float(self.numbers(tensor.get(key, "0") if tensor is not None else "0", 1,
                                              f"{where} inertia {key}")[0])
        I = np.array([[entries["ixx"], entries["ixy"], entries["ixz"]],
                      [entries["ixy"], entries["iyy"], entries["iyz"]],
                      [entries["ixz"], entries["iyz"], entries["izz"]]])
        if np.min(np.linalg.eigvalsh(I)) < -1e-12 * max(1.0, float(np.max(np.abs(I)))):
            raise self.fail(f"{where}: the inertia tensor is not positive semidefinite")
        R = T[:3, :3]
        return mass, T[:3, 3], R @ I @ R.T

    def body(self, joint, kind, child, parent_body, T, mass, com, inertia) -> None:
        ident = self.identifiers[child]
        jname = joint.get("name", "?")
        where = f"joint '{jname}'"
        spec = {"name": self.body_name(child), "parent": parent_body or "base"}
        origin = {"xyz": [self.parameter(f"l_{ident}_{a}", v, "length", "m") for a, v in zip("xyz", T[:3, 3])],
                  "rpy": [_angle_text(a) for a in _rpy(T[:3, :3])]}
        if kind == "fixed":
            spec["joint"] = {"type": "fixed", "origin": origin}
        else:
            axis = self.numbers(joint.find("axis").get("xyz") if joint.find("axis") is not None else "1 0 0",
                                3, f"{where} axis")
            norm = float(np.linalg.norm(axis))
            if norm < 1e-12:
                raise self.fail(f"{where}: the axis must not be zero")
            spec["joint"] = {"type": "prismatic" if kind == "prismatic" else "revolute",
                             "axis": _axis_text(axis / norm), "q": self.variable(joint, kind, where),
                             "origin": origin}
        spec["mass"] = self.parameter(f"m_{ident}", mass, "mass", "kg")
        spec["com"] = [self.parameter(f"c_{ident}_{a}", v, "com", "m") for a, v in zip("xyz", com)]
        spec["inertia"] = {ab: self.parameter(f"I_{ident}_{ab}", inertia[i, j], "inertia", "kg m^2")
                           for ab, (i, j) in (("xx", (0, 0)), ("yy", (1, 1)), ("zz", (2, 2)), ("xy", (0, 1)),
                                              ("xz", (0, 2)), ("yz", (1, 2)))}
        spec["doc"] = f"URDF link '{child}' on the {kind} joint '{jname}'"
        self.data["bodies"].append(spec)

    def variable(self, joint, kind, where) -> str:
        """The joint variable: a new coordinate, or a mimic joint's multiple of another one."""
        jname = joint.get("name", "?")
        mimic = joint.find("mimic")
        if mimic is not None:
            source = mimic.get("joint")
            if source not in self.coordinate_of:
                raise self.fail(f"{where}: mimics '{source}', which is not a moving joint read before it")
            factor = float(self.numbers(mimic.get("multiplier", "1"), 1, f"{where} mimic multiplier")[0])
            shift = float(self.numbers(mimic.get("offset", "0"), 1, f"{where} mimic offset")[0])
            if abs(factor) < 1e-12:
                raise self.fail(f"{where}: a mimic multiplier of zero moves nothing")
            q = self.coordinate_of[source]
            text = q if factor == 1 else f"{_num(factor)}*{q}"
            return text if shift == 0 else f"{text} + {_num(shift)}"
        q = f"q{len(self.coordinate_of) + 1}"
        self.coordinate_of[jname] = q
        self.notes.append(f"{q}: the {kind} joint '{jname}'")
        limit = joint.find("limit")
        entry = {}
        if limit is not None:
            lower, upper = (float(self.numbers(limit.get(k, "0"), 1, f"{where} limit {k}")[0]) for k in ("lower", "upper"))
            if kind != "continuous" and lower < upper:
                entry["position"] = [lower, upper]
            for key, name in (("velocity", "velocity"), ("effort", "torque")):
                value = float(self.numbers(limit.get(key, "0"), 1, f"{where} limit {key}")[0])
                if 0 < value < UNLIMITED:
                    entry[name] = value
        if entry:
            self.data["limits"][q] = entry
        dynamics = joint.find("dynamics")
        if dynamics is not None:
            ident = self.identifiers[self.attr(joint, "child", "link", where)]
            for key, kind_name, prefix in (("damping", "viscous", "fv"), ("friction", "coulomb", "fc")):
                value = float(self.numbers(dynamics.get(key, "0"), 1, f"{where} dynamics {key}")[0])
                refusal = refuse_negative(f"dynamics {key}", value, shown=f"got {value:g}")
                if refusal:
                    raise self.fail(f"{where}: {refusal}")
                if value > 0:
                    self.data["friction"][kind_name][q] = self.parameter(f"{prefix}_{ident}", value, "friction", "")
        return q


def _identifiers(names: List[str]) -> Dict[str, str]:
    """A distinct identifier for each link name, used in parameter names (``upper-arm`` -> ``upper_arm``)."""
    out, used = {}, set()
    for name in names:
        ident = re.sub(r"\W", "_", name, flags=re.ASCII) or "link"
        if not ident[0].isalpha():
            ident = "L" + ident
        candidate, k = ident, 2
        while candidate in used:
            candidate, k = f"{ident}{k}", k + 1
        used.add(candidate)
        out[name] = candidate
    return out


def _angle_text(angle: float) -> str:
    """An angle [rad] as text: exact multiples of pi/12 as such (``pi/2``), else the float.

    >>> _angle_text(math.pi / 2), _angle_text(-math.pi), _angle_text(0.3)
    ('pi/2', '-pi', '0.3')
    """
    k = angle / (math.pi / _NUMBER_OF_PI)
    if abs(k - round(k)) < 1e-9:
        return str(sp.Rational(round(k), _NUMBER_OF_PI) * sp.pi) if round(k) else "0"
    return _num(angle)


def _axis_text(axis: np.ndarray):
    for name, vector in (("x", (1, 0, 0)), ("y", (0, 1, 0)), ("z", (0, 0, 1))):
        for sign in (1, -1):
            if np.allclose(axis, sign * np.array(vector), atol=1e-12):
                return name if sign > 0 else "-" + name
    return [_num(v) for v in axis]


def robot_data_from_urdf(text: str, source: str = "<urdf>") -> dict:
    """The mapping of a robot file (docs/robot-format.md) that describes the URDF text's robot:
    q1, q2, ... for the moving joints in depth-first order, parameters named after the links,
    gravity (0, 0, -g0) with g0 = 9.81 m/s^2 in the root link's frame."""
    root = parse_urdf(text, source)
    reader = _Reader(root, source)
    data = reader.read()
    data["parameters"]["g0"] = {"value": 9.81, "kind": "gravity", "unit": "m/s^2"}
    name = re.sub(r"[^\w-]", "_", root.get("name") or "urdf_robot", flags=re.ASCII)
    base = source.replace("\\", "/").rsplit("/", 1)[-1]
    data.update(name=name, title=f"{root.get('name') or name} (URDF)",
                description=f"Read from the URDF file {base}: coordinates q1..q{len(data['coordinates'])} "
                            f"are its moving joints, parameters are named after its links.",
                gravity=[0, 0, "-g0"], notes=reader.notes)
    for key in ("points", "limits"):
        if not data[key]:
            del data[key]
    data["friction"] = {k: v for k, v in data["friction"].items() if v}
    if not data["friction"]:
        del data["friction"]
    return data
