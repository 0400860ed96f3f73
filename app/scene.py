"""The 3D picture of a robot, like a textbook figure come alive (pure geometry: numpy).

``RobotDrawing(robot, params)`` turns a robot file into coloured meshes attached to frames:

- links as capsules (bars with rounded ends) from the joint to the next joints (or the CoM / the
  robot's named points), with their true lengths; standard-DH links as L-shapes (offset along the
  joint axis first);
- revolute joints as cylinders along their axes, prismatic joints as sleeves (fixed to the parent)
  with a rod (fixed to the child) sliding through them;
- CoMs as small black-and-white spheres, a base block, and (in the viewer) the plane of a planar
  robot or the ground, and the gravity arrow.

Every part hangs on an *attachment*: ``"base"`` (the world), ``"<body>"`` (the body frame) or
``"<body>@joint"`` (the body's joint frame before its motion, which moves with the parent).
``poses(q)`` gives the world 4x4 transform of every attachment, so moving the robot means setting a
few poses and never rebuilding meshes. The viewer (app/viewer/scene_view.py) sends the parts to
viser; nothing here imports viser.

The meshes (``Mesh``: boxes, cylinders, cones, capsules, icospheres) are made here with numpy, the
same tessellation trimesh's ``creation`` module makes: importing trimesh (and the scipy it pulls
in) cost the page's server about 0.7 s of CPU at every start (issue 16).

>>> from app.core.robot import load_robot
>>> drawing = RobotDrawing(load_robot("planar_2r"))
>>> sorted({p.role for p in drawing.parts})
['base', 'com', 'joint', 'link']
>>> round(float(drawing.poses([0.0, 0.0])["link2"][0, 3]), 3)   # joint 2 sits at x = l1
1.0
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Dict, List, Mapping, Optional, Sequence, Tuple

import numpy as np
import sympy as sp

from app.core.expressions import parse_expression
from app.core.numeric import compiled_model, numeric_function
from app.core.robot import RobotModel

#: link colours, in body order (a body's ``color`` in the robot file wins)
PALETTE = [(70, 114, 196), (230, 132, 52), (76, 160, 92), (200, 70, 80), (140, 105, 190),
           (150, 100, 70), (215, 110, 180), (120, 120, 120)]
JOINT_COLOR = (55, 62, 74)
SLEEVE_COLOR = (85, 92, 104)
BASE_COLOR = (120, 126, 136)
HIGHLIGHT_COLOR = (255, 196, 0)

# ------------------------------------------------------------------------------ meshes
class Mesh:
    """A triangle mesh: ``vertices`` (n x 3 floats), ``faces`` (m x 3 vertex indices, counter-
    clockwise seen from outside). Transforms change it in place and return it.

    >>> m = box_mesh([1.0, 2.0, 3.0])
    >>> m.bounds.tolist(), f"{m.volume:.6f}"      # bounds exact: the vertices are the half sizes
    ([[-0.5, -1.0, -1.5], [0.5, 1.0, 1.5]], '6.000000')
    """

    def __init__(self, vertices, faces):
        self.vertices = np.asarray(vertices, dtype=float).reshape(-1, 3)
        self.faces = np.asarray(faces, dtype=np.int64).reshape(-1, 3)

    def apply_transform(self, T) -> "Mesh":
        T = np.asarray(T, dtype=float)
        self.vertices = self.vertices @ T[:3, :3].T + T[:3, 3]
        return self

    def apply_translation(self, t) -> "Mesh":
        self.vertices = self.vertices + np.asarray(t, dtype=float)
        return self

    @property
    def bounds(self) -> np.ndarray:
        return np.array([self.vertices.min(axis=0), self.vertices.max(axis=0)])

    @property
    def triangles_center(self) -> np.ndarray:
        return self.vertices[self.faces].mean(axis=1)

    @property
    def volume(self) -> float:
        """Enclosed volume (positive when the faces point outwards)."""
        a, b, c = (self.vertices[self.faces[:, k]] for k in range(3))
        return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6)

    def submesh(self, face_lists, append: bool = True) -> "Mesh":
        """The mesh of the faces listed (one list, as trimesh's ``submesh(..., append=True)``)."""
        faces = self.faces[np.concatenate([np.asarray(f, dtype=np.int64) for f in face_lists])]
        used, inverse = np.unique(faces, return_inverse=True)
        return Mesh(self.vertices[used], inverse.reshape(-1, 3))


def concatenate(meshes: Sequence[Mesh]) -> Mesh:
    offsets = np.cumsum([0] + [len(m.vertices) for m in meshes[:-1]])
    return Mesh(np.vstack([m.vertices for m in meshes]),
                np.vstack([m.faces + k for m, k in zip(meshes, offsets)]))


def box_mesh(extents) -> Mesh:
    """A box centred at the origin."""
    corners = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)])
    faces = [[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
             [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]]
    return Mesh(corners * np.asarray(extents, dtype=float), faces)


def revolved_mesh(profile, sections: int) -> Mesh:
    """The surface swept by a profile of (r, z) points turned about the z axis; a point with r = 0
    is one vertex on the axis (a pole). The profile runs from the bottom to the top."""
    angles = 2 * np.pi * np.arange(sections) / sections
    ring = np.column_stack([np.cos(angles), np.sin(angles)])
    vertices, rows = [], []
    for r, z in profile:
        start = len(vertices)
        if r <= 0:
            vertices.append([0.0, 0.0, z])
            rows.append([start] * sections)
        else:
            vertices += [[r * c, r * s_, z] for c, s_ in ring]
            rows.append(list(range(start, start + sections)))
    faces = []
    for lower, upper in zip(rows, rows[1:]):
        for j in range(sections):
            k = (j + 1) % sections
            if lower[j] != lower[k]:
                faces.append([lower[j], lower[k], upper[k]])
            if upper[j] != upper[k]:
                faces.append([lower[j], upper[k], upper[j]])
    return Mesh(vertices, faces)


def cylinder_mesh(radius: float, height: float, sections: int = 32) -> Mesh:
    """A closed cylinder along z, centred at the origin."""
    h = height / 2
    return revolved_mesh([(0.0, -h), (radius, -h), (radius, h), (0.0, h)], sections)


def cone_mesh(radius: float, height: float, sections: int = 32) -> Mesh:
    """A closed cone along z: its base at z = 0, its tip at z = height."""
    return revolved_mesh([(0.0, 0.0), (radius, 0.0), (0.0, height)], sections)


def capsule_mesh(height: float, radius: float, count=(32, 32)) -> Mesh:
    """A capsule along z centred at the origin, ``height`` between its two sphere centres;
    ``count`` = (sections around, rings over both caps)."""
    around, rings = int(count[0]), max(2, int(count[1]) // 2 * 2)
    half = rings // 2
    h = height / 2
    profile = [(0.0, -h - radius)]
    profile += [(radius * math.sin(math.pi / 2 * k / half), -h - radius * math.cos(math.pi / 2 * k / half))
                for k in range(1, half + 1)]
    profile += [(radius * math.cos(math.pi / 2 * k / half), h + radius * math.sin(math.pi / 2 * k / half))
                for k in range(0, half)]
    profile.append((0.0, h + radius))
    return revolved_mesh(profile, around)


def icosphere_mesh(subdivisions: int = 2, radius: float = 1.0) -> Mesh:
    """A sphere from an icosahedron whose triangles are split in four ``subdivisions`` times."""
    t = (1 + math.sqrt(5)) / 2
    vertices = [[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t], [0, -1, -t],
                [0, 1, -t], [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]]
    vertices = [list(np.asarray(v, float) / np.linalg.norm(v)) for v in vertices]
    faces = [[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4], [11, 10, 2],
             [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5],
             [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]]
    for _ in range(subdivisions):
        middle: Dict[Tuple[int, int], int] = {}

        def mid(a, b):
            key = (min(a, b), max(a, b))
            if key not in middle:
                m = np.add(vertices[a], vertices[b])
                vertices.append(list(m / np.linalg.norm(m)))
                middle[key] = len(vertices) - 1
            return middle[key]

        split = []
        for a, b, c in faces:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            split += [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
        faces = split
    return Mesh(np.asarray(vertices) * radius, faces)


@dataclass
class Part:
    """One mesh of the drawing, in the coordinates of its attachment frame."""
    name: str                    # unique, usable as a scene-node name
    attach: str                  # "base", "<body>" or "<body>@joint"
    mesh: Mesh
    color: Tuple[int, int, int]
    role: str                    # link | joint | sleeve | rod | com | base
    body: Optional[str] = None   # the body this part shows (links, CoMs) or whose joint it is
    opacity: float = 1.0
    segment: Optional[Tuple[np.ndarray, np.ndarray]] = None   # a bar's end points (links)


@dataclass
class JointMark:
    """Where a joint sits (for labels): attachment, local position, label text."""
    body: str
    attach: str
    position: np.ndarray
    text: str


def parse_color(value) -> Optional[Tuple[int, int, int]]:
    """A colour from a robot file: ``"#4c72b0"`` or ``[r, g, b]`` (0-255).

    >>> parse_color("#ff8000"), parse_color([1, 2, 3]), parse_color(None)
    ((255, 128, 0), (1, 2, 3), None)
    """
    if value is None:
        return None
    if isinstance(value, str) and value.startswith("#") and len(value) == 7:
        return tuple(int(value[i:i + 2], 16) for i in (1, 3, 5))
    if isinstance(value, (list, tuple)) and len(value) == 3:
        return tuple(int(v) for v in value)
    return None


def _numeric(expr, subs) -> float:
    if not isinstance(expr, sp.Basic):       # a number or an expression written in the file
        expr = parse_expression(expr, [s.name for s in subs])
    return float(expr.xreplace(subs))


def _vec(matrix, subs) -> np.ndarray:
    return np.array([_numeric(e, subs) for e in matrix], dtype=float)


def _rot(matrix, subs) -> np.ndarray:
    return np.array([[_numeric(matrix[i, j], subs) for j in range(3)] for i in range(3)], dtype=float)


def _axis(axis) -> np.ndarray:
    a = np.array([float(v) for v in axis], dtype=float)
    return a / np.linalg.norm(a)


def align_z(direction) -> np.ndarray:
    """A rotation matrix taking +z to ``direction`` (unit).

    >>> bool(np.allclose(align_z([1, 0, 0]) @ [0, 0, 1], [1, 0, 0]))
    True
    """
    d = np.asarray(direction, dtype=float)
    d = d / np.linalg.norm(d)
    z = np.array([0.0, 0.0, 1.0])
    v = np.cross(z, d)
    c = float(np.dot(z, d))
    if np.linalg.norm(v) < 1e-12:
        return np.eye(3) if c > 0 else np.diag([1.0, -1.0, -1.0])
    vx = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    return np.eye(3) + vx + vx @ vx * (1 / (1 + c))


def _placed(mesh: Mesh, R=None, t=None) -> Mesh:
    T = np.eye(4)
    if R is not None:
        T[:3, :3] = R
    if t is not None:
        T[:3, 3] = t
    mesh.apply_transform(T)
    return mesh


def capsule(a, b, radius) -> Mesh:
    """A capsule (bar with round ends) from point a to point b."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    length = float(np.linalg.norm(b - a))
    mesh = capsule_mesh(height=max(length, 1e-6), radius=radius, count=[24, 12])
    return _placed(mesh, align_z(b - a) if length > 1e-9 else None, (a + b) / 2)


def cylinder(center, direction, radius, length, sections: int = 32) -> Mesh:
    mesh = cylinder_mesh(radius=radius, height=length, sections=sections)
    return _placed(mesh, align_z(direction), center)


def box(center, direction, length, width) -> Mesh:
    mesh = box_mesh(extents=[width, width, length])
    return _placed(mesh, align_z(direction), center)


def arrow(start, vector, radius) -> Mesh:
    """An arrow (shaft and cone) from ``start`` along ``vector``."""
    start, vector = np.asarray(start, float), np.asarray(vector, float)
    length = float(np.linalg.norm(vector))
    head = min(0.35 * length, 6 * radius)
    shaft = cylinder_mesh(radius=radius, height=length - head, sections=20)
    shaft.apply_translation([0, 0, (length - head) / 2])
    cone = cone_mesh(radius=2.6 * radius, height=head, sections=24)
    cone.apply_translation([0, 0, length - head])
    mesh = concatenate([shaft, cone])
    return _placed(mesh, align_z(vector), start)


def com_marker(center, radius) -> Tuple[Mesh, Mesh]:
    """The textbook centre-of-mass symbol as a sphere: (dark octants, light octants)."""
    sphere = icosphere_mesh(subdivisions=2, radius=radius)
    signs = np.prod(np.sign(sphere.triangles_center + 1e-9), axis=1)
    dark = sphere.submesh([np.nonzero(signs > 0)[0]], append=True)
    light = sphere.submesh([np.nonzero(signs <= 0)[0]], append=True)
    return dark.apply_translation(center), light.apply_translation(center)


def coordinate_ranges(robot: RobotModel, scale: float = 1.0) -> Dict[str, Tuple[float, float]]:
    """Slider range of every coordinate: its position limits, else [-pi, pi] for angles and
    [-scale, scale] for coordinates that move a prismatic joint; always containing the default.

    >>> from app.core.robot import load_robot
    >>> coordinate_ranges(load_robot("rp_2004_03_25"), 0.8)["q2"]       # exact: -scale, scale
    (-0.8, 0.8)
    """
    prismatic = set()
    for body in robot.bodies:
        if body.joint.type == "prismatic":
            prismatic |= {s.name for s in body.joint.value.free_symbols}
    out = {}
    for name in robot.coordinates:
        lim = robot.limits.get(name)
        if lim is not None and lim.position is not None:
            lo, hi = lim.position
        elif name in prismatic:
            lo, hi = -scale, scale
        else:
            lo, hi = -math.pi, math.pi
        default = robot.defaults.get(name, 0.0)
        out[name] = (min(lo, default), max(hi, default))
    return out


def default_q(robot: RobotModel) -> np.ndarray:
    """The coordinates the viewer starts with (``defaults`` of the file, clipped into the limits)."""
    q = np.array([robot.defaults.get(c, 0.0) for c in robot.coordinates], dtype=float)
    for i, name in enumerate(robot.coordinates):
        lim = robot.limits.get(name)
        if lim is not None and lim.position is not None and name not in robot.defaults:
            q[i] = min(max(q[i], lim.position[0]), lim.position[1])
    return q


@dataclass
class Framing:
    """What the camera must see: box centre and half-diagonal, up direction, plane normal (planar)."""
    center: np.ndarray
    radius: float
    up: np.ndarray
    normal: Optional[np.ndarray]


class RobotDrawing:
    """Meshes of a robot attached to its frames, for given parameter values."""

    def __init__(self, robot: RobotModel, params: Optional[Mapping[str, float]] = None):
        self.robot = robot
        self.values = robot.parameter_values(params)
        self.p = np.array([self.values[n] for n in robot.parameters], dtype=float)
        self._subs = {sp.Symbol(k, real=True): v for k, v in self.values.items()}
        self._frames_fn = compiled_model(robot).fframes       # compiled once per robot file
        draw = robot.draw or {}
        self.segments = self._link_segments()
        lengths = [float(np.linalg.norm(b - a)) for segs in self.segments.values() for a, b in segs]
        self.scale = max(sum(lengths), 0.3)
        self.radius = float(draw.get("radius", min(max(0.028 * self.scale, 0.012), 0.06)))
        self.ranges = coordinate_ranges(robot, float(draw.get("prismatic_range", 0.6 * self.scale)))
        self.up = self._up()
        self.parts: List[Part] = []
        self.joint_marks: List[JointMark] = []
        self._build()

    # ------------------------------------------------------------------ kinematics
    def poses(self, q) -> Dict[str, np.ndarray]:
        """World 4x4 transform of every attachment at coordinates q."""
        q = np.asarray(q, dtype=float).reshape(-1)
        if q.size != self.robot.n:
            raise ValueError(f"{self.robot.name} has {self.robot.n} coordinates, got {q.size}")
        mats = self._frames_fn(q, self.p)
        out = {"base": np.eye(4)}
        for i, body in enumerate(self.robot.bodies):
            out[f"{body.name}@joint"] = np.asarray(mats[2 * i], dtype=float)
            out[body.name] = np.asarray(mats[2 * i + 1], dtype=float)
        return out

    def mesh_at(self, q):
        """The whole drawing at coordinates ``q`` as one coloured ``trimesh.Trimesh`` in world
        coordinates (``export ROBOT --mesh FILE`` writes it: STL, OBJ, PLY, GLB ...).

        >>> from app.core.robot import load_robot
        >>> d = RobotDrawing(load_robot("planar_2r"))
        >>> m = d.mesh_at(default_q(d.robot))
        >>> len(m.faces) == sum(len(p.mesh.faces) for p in d.parts), m.visual.face_colors.shape[1]
        (True, 4)
        """
        import trimesh                           # here only: the page's server does not need it

        poses = self.poses(q)
        pieces = []
        for part in self.parts:
            T = poses[part.attach]
            piece = trimesh.Trimesh(part.mesh.vertices @ T[:3, :3].T + T[:3, 3], part.mesh.faces, process=False)
            piece.visual.face_colors = np.tile([*part.color, 255], (len(part.mesh.faces), 1))
            pieces.append(piece)
        return trimesh.util.concatenate(pieces)

    def _up(self) -> np.ndarray:
        g = _vec(self.robot.gravity, self._subs)
        if np.linalg.norm(g) > 1e-12:
            return -g / np.linalg.norm(g)
        return np.array([0.0, 1.0, 0.0]) if self.robot.is_planar else np.array([0.0, 0.0, 1.0])

    @property
    def gravity(self) -> np.ndarray:
        return _vec(self.robot.gravity, self._subs)

    # ------------------------------------------------------------------ geometry
    def _link_segments(self) -> Dict[str, List[Tuple[np.ndarray, np.ndarray]]]:
        """Segments (in body coordinates) drawn as bars for each body."""
        robot, subs = self.robot, self._subs
        children: Dict[str, List] = {b.name: [] for b in robot.bodies}
        for b in robot.bodies:
            if b.parent is not None:
                children[b.parent].append(b)
        extra = (robot.draw or {}).get("segments") or {}
        out: Dict[str, List[Tuple[np.ndarray, np.ndarray]]] = {}
        for body in robot.bodies:
            j = body.joint
            Rp, pp = _rot(j.post.R, subs), _vec(j.post.p, subs)
            start = -Rp.T @ pp                    # the joint's location, in body coordinates
            path = [start]
            if j.type == "revolute" and np.linalg.norm(pp) > 1e-12:
                u = _axis(j.axis)
                along = float(np.dot(pp, u)) * u
                mid = Rp.T @ (along - pp)
                if 1e-9 < np.linalg.norm(along) < np.linalg.norm(pp) - 1e-9:
                    path.append(mid)
                path.append(np.zeros(3))
            segs = [(path[k], path[k + 1]) for k in range(len(path) - 1)]
            ends = [_vec(c.joint.pre.p, subs) for c in children[body.name]]
            if not ends:
                ends = [_vec(p.position, subs) for p in robot.points.values() if p.body == body.name]
            if not ends:
                com = _vec(body.com, subs)
                if np.linalg.norm(com - path[-1]) > 1e-9 and body.joint.type != "prismatic":
                    ends = [com]
            for e in ends:
                segs.append((path[-1], e))
            for seg in extra.get(body.name, []) or []:
                segs.append((_vec(seg[0], subs), _vec(seg[1], subs)))
            out[body.name] = [(a, b) for a, b in segs if np.linalg.norm(b - a) > 1e-9]
        return out

    def _build(self) -> None:
        robot, subs, r = self.robot, self._subs, self.radius
        for idx, body in enumerate(robot.bodies):
            color = parse_color(body.color) or PALETTE[idx % len(PALETTE)]
            for k, (a, b) in enumerate(self.segments[body.name]):
                self.parts.append(Part(f"bar{k}", body.name, capsule(a, b, r), color, "link", body.name,
                                       segment=(a, b)))
            j = body.joint
            if j.type != "fixed":
                u = _axis(j.axis)
                if j.type == "revolute":
                    mesh = cylinder(np.zeros(3), u, 1.7 * r, 3.6 * r)
                    self.parts.append(Part("joint", f"{body.name}@joint", mesh, JOINT_COLOR, "joint", body.name))
                else:
                    lo, hi = self._joint_range(body)
                    sleeve = box(np.zeros(3), u, 5.0 * r, 2.7 * r)
                    self.parts.append(Part("sleeve", f"{body.name}@joint", sleeve, SLEEVE_COLOR, "joint", body.name))
                    Rp, pp = _rot(j.post.R, subs), _vec(j.post.p, subs)
                    # the rod spans every position the sleeve can take relative to the child
                    a = Rp.T @ (u * (-hi - 3 * r) - pp)
                    b = Rp.T @ (u * (-lo + 3 * r) - pp)
                    self.parts.append(Part("rod", body.name, capsule(a, b, 0.85 * r), color, "link", body.name,
                                           segment=(a, b)))
                perp = np.cross(u, [1.0, 0.0, 0.0] if abs(u[0]) < 0.9 else [0.0, 1.0, 0.0])
                perp = perp / np.linalg.norm(perp) + np.cross(u, perp / np.linalg.norm(perp))
                offset = 1.3 * r * perp + (1.8 * r * u if j.type == "revolute" else 0)
                self.joint_marks.append(JointMark(body.name, f"{body.name}@joint", offset, sp.sstr(j.value)))
            mass = _numeric(body.mass, subs)
            if mass > 0:
                dark, light = com_marker(_vec(body.com, subs), 1.45 * r)
                self.parts.append(Part("com_dark", body.name, dark, (25, 25, 25), "com", body.name))
                self.parts.append(Part("com_light", body.name, light, (245, 245, 245), "com", body.name))
        self.parts.extend(self._base_parts())
        for body in robot.bodies:       # "link 0": the fixed column up to a first joint off the origin
            offset = _vec(body.joint.pre.p, subs)
            if body.parent is None and np.linalg.norm(offset) > 1e-9:
                self.parts.append(Part(f"column_{body.name}", "base", capsule(np.zeros(3), offset, 1.3 * r),
                                       BASE_COLOR, "base"))

    def _joint_range(self, body) -> Tuple[float, float]:
        """Range of a prismatic joint's variable over the coordinates' slider ranges."""
        value = body.joint.value
        syms = sorted(value.free_symbols & set(self.robot.q), key=lambda s: s.name)
        fn = numeric_function(syms, value.xreplace(self._subs), "numpy")
        corners = np.array(np.meshgrid(*[self.ranges[s.name] for s in syms])).reshape(len(syms), -1)
        vals = np.atleast_1d(np.asarray(fn(*corners), dtype=float))
        return float(vals.min()), float(vals.max())

    def _base_parts(self) -> List[Part]:
        r, up = self.radius, self.up
        if self.robot.is_planar:
            normal = np.array([0.0, 0.0, 1.0])
            side = np.cross(up, normal)
            if np.linalg.norm(side) < 1e-9:       # horizontal plane seen from above
                side = np.array([1.0, 0.0, 0.0])
                block = box_mesh(extents=[5.5 * r, 5.5 * r, 1.2 * r])
                return [Part("base", "base", block.apply_translation([0, 0, -2.6 * r]), BASE_COLOR, "base")]
            side /= np.linalg.norm(side)
            R = np.column_stack([side, up, normal])
            block = box_mesh(extents=[6.0 * r, 2.4 * r, 2.4 * r])
            block.apply_translation([0, -1.7 * r - 1.2 * r, 0])
            return [Part("base", "base", _placed(block, R), BASE_COLOR, "base")]
        pedestal = cylinder_mesh(radius=3.0 * r, height=1.6 * r, sections=40)
        pedestal.apply_translation([0, 0, -0.8 * r - 1.9 * r])
        return [Part("base", "base", _placed(pedestal, align_z(up)), BASE_COLOR, "base")]

    # ------------------------------------------------------------------ framing
    def bounds(self, qs: Sequence[Sequence[float]]) -> Tuple[np.ndarray, np.ndarray]:
        """Axis-aligned world bounding box of the drawing over several configurations."""
        lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
        corners: Dict[str, list] = {}          # the 8 corners of each part's box, per attachment
        for part in self.parts:
            b = part.mesh.bounds
            corners.setdefault(part.attach, []).append(np.stack(np.meshgrid(*b.T, indexing="ij"), -1).reshape(-1, 3))
        stacked = {attach: np.vstack(boxes) for attach, boxes in corners.items()}
        for q in qs:
            poses = self.poses(q)
            for attach, points in stacked.items():
                T = poses[attach]
                world = points @ T[:3, :3].T + T[:3, 3]
                lo, hi = np.minimum(lo, world.min(0)), np.maximum(hi, world.max(0))
        return lo, hi

    def framing(self, q=None, samples: int = 48, seed: int = 0) -> Framing:
        """The region to frame: the robot at q (default: its default configuration) with a margin,
        and at least 60 % of the region it sweeps over the slider ranges, so that it stays mostly
        in view while the sliders move."""
        rng = np.random.default_rng(seed)
        names = self.robot.coordinates
        q = default_q(self.robot) if q is None else np.asarray(q, float)
        swept = [q] + [np.array([rng.uniform(*self.ranges[n]) for n in names]) for _ in range(samples)]
        lo, hi = self.bounds([q])
        slo, shi = self.bounds(swept)
        planar = self.robot.is_planar
        dims = slice(0, 2) if planar else slice(0, 3)

        def half(a, b):
            return float(np.max(b[dims] - a[dims])) / 2 if planar else float(np.linalg.norm(b - a)) / 2

        center = (lo + hi) / 2
        radius = max(1.3 * half(lo, hi), 0.6 * half(slo, shi), 3 * self.radius)
        normal = np.array([0.0, 0.0, 1.0]) if planar else None
        if planar:                     # keep the view square-on: centre in the plane
            center[2] = 0.0
        return Framing(center, radius, self.up, normal)


def camera_pose(framing: Framing, fov: float = math.radians(50), aspect: float = 16 / 9,
                fill: float = 0.88, occluded_right: float = 0.0) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(position, look_at, up) of a camera that sees the framed region, square-on to the plane of
    a planar robot, from an oblique viewpoint for a spatial one. ``occluded_right`` is the fraction
    of the canvas width hidden by the side panel: the region is centred in the visible part.

    >>> f = Framing(np.zeros(3), 1.0, np.array([0, 1.0, 0]), np.array([0, 0, 1.0]))
    >>> pos, look, up = camera_pose(f)
    >>> bool(pos[0] == 0 and pos[1] == 0 and pos[2] > 2)
    True
    """
    half = fov / 2
    visible_aspect = aspect * (1.0 - occluded_right)
    vertical = framing.radius / math.tan(half)
    horizontal = framing.radius / (math.tan(half) * visible_aspect)
    distance = max(vertical, horizontal) / fill
    up = framing.up / np.linalg.norm(framing.up)
    if framing.normal is not None:
        direction = framing.normal / np.linalg.norm(framing.normal)
        if abs(float(np.dot(direction, up))) > 0.99:     # horizontal plane seen from above
            up = np.array([0.0, 1.0, 0.0])
    else:
        side = np.cross(up, [1.0, 0.0, 0.0]) if abs(up[0]) < 0.9 else np.cross(up, [0.0, 1.0, 0.0])
        side /= np.linalg.norm(side)
        front = np.cross(side, up)
        direction = 0.78 * front - 0.45 * side + 0.45 * up
        direction /= np.linalg.norm(direction)
    right = np.cross(-direction, up)
    right /= np.linalg.norm(right)
    shift = occluded_right * distance * math.tan(half) * aspect * right
    look_at = framing.center + shift
    return look_at + distance * direction, look_at, up


def quaternion_wxyz(R: np.ndarray) -> np.ndarray:
    """Unit quaternion (w, x, y, z) of a rotation matrix.

    >>> (np.round(quaternion_wxyz(np.eye(3)), 12) + 0.0).tolist()
    [1.0, 0.0, 0.0, 0.0]
    """
    m = R
    tr = m[0, 0] + m[1, 1] + m[2, 2]
    if tr > 0:
        s = math.sqrt(tr + 1.0) * 2
        q = [0.25 * s, (m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s]
    elif m[0, 0] > m[1, 1] and m[0, 0] > m[2, 2]:
        s = math.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2]) * 2
        q = [(m[2, 1] - m[1, 2]) / s, 0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s]
    elif m[1, 1] > m[2, 2]:
        s = math.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2]) * 2
        q = [(m[0, 2] - m[2, 0]) / s, (m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s]
    else:
        s = math.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1]) * 2
        q = [(m[1, 0] - m[0, 1]) / s, (m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s]
    q = np.array(q, dtype=float)
    return q / np.linalg.norm(q)
