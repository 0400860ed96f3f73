"""The 3D side of an exercise step: what its highlight hints ask to show, drawn with the
session's scene overlays (docs/panels.md).

Hints a step may carry (app/core/tasks/kinematic.py lists them): ``bodies`` and ``joints`` (lit
up), ``configuration`` (the robot is moved there), ``vectors`` (arrows: ``origin`` and
``vector`` in world coordinates, planar ones with z = 0; without ``origin`` at the end effector;
``joint_space`` ones at the joints), ``joint_values`` (one value per joint, e.g. velocities with
their bounds: an arc around each revolute joint, a bar along each prismatic one, the bounds in
grey), ``points`` (markers), ``path`` (a polyline). ``scale`` and ``profile`` are shown in the
panel. Arrows of one step share one length scale so that they can be compared.

>>> (arc_points([0, 0, 0], [0, 0, 1], [1, 0, 0], 1.0, 0.0, np.pi / 2, segments=2).round(3) + 0.0).tolist()
[[1.0, 0.0, 0.0], [0.707, 0.707, 0.0], [0.0, 1.0, 0.0]]
"""
from __future__ import annotations

from typing import Any, Dict, List, Optional

import numpy as np
import sympy as sp

from app.panels.exercise_view import ROLE_COLORS

PREFIX = "exercise_"
MAX_ARC = np.radians(150.0)      # the largest |value| of a joint row is drawn as this angle


def arc_points(center, axis, start_dir, radius: float, a0: float, a1: float, segments: int = 24) -> np.ndarray:
    """Points of a circular arc about ``axis`` through ``center`` from angle a0 to a1 (radians,
    counter-clockwise about the axis), angle 0 along ``start_dir``."""
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    u = np.asarray(start_dir, float) - np.dot(start_dir, axis) * axis
    u /= np.linalg.norm(u)
    w = np.cross(axis, u)
    angles = np.linspace(a0, a1, max(2, segments + 1))
    return np.asarray(center, float) + radius * (np.outer(np.cos(angles), u) + np.outer(np.sin(angles), w))


def _perpendicular(axis, hint) -> np.ndarray:
    axis = np.asarray(axis, float)
    for cand in (hint, [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]):
        c = np.asarray(cand, float)
        c = c - np.dot(c, axis) * axis
        if np.linalg.norm(c) > 1e-6:
            return c / np.linalg.norm(c)
    return np.array([1.0, 0.0, 0.0])


def joint_geometry(drawing, q) -> List[Dict[str, Any]]:
    """World position, axis, type and reference direction (along the moved link) of every joint."""
    poses = drawing.poses(q)
    out = []
    for body in drawing.robot.bodies:
        T = poses[f"{body.name}@joint"]
        axis = np.array([float(v) for v in body.joint.axis], float)
        axis = T[:3, :3] @ (axis / np.linalg.norm(axis))
        segs = drawing.segments.get(body.name) or []
        Tb = poses[body.name]
        if segs:
            a, b = segs[-1]
            along = Tb[:3, :3] @ (np.asarray(b) - np.asarray(a))
        else:
            along = Tb[:3, 0]
        out.append({"body": body.name, "type": body.joint.type, "position": T[:3, 3].copy(), "axis": axis,
                    "reference": _perpendicular(axis, along)})
    return out


def tip_position(drawing, q) -> np.ndarray:
    """The end effector: the robot's point ``ee`` (or its last point), else the far end of the
    last link as drawn."""
    robot = drawing.robot
    poses = drawing.poses(q)
    subs = {sp.Symbol(k, real=True): v for k, v in drawing.values.items()}
    points = list(robot.points.values())
    pt = robot.points.get("ee") or (points[-1] if points else None)
    if pt is not None:
        local = np.array([float(sp.sympify(e).xreplace(subs)) for e in pt.position], float)
        T = poses[pt.body] if pt.body else np.eye(4)
        return T[:3, :3] @ local + T[:3, 3]
    last = robot.bodies[-1].name
    T = poses[last]
    segs = drawing.segments.get(last) or []
    local = np.asarray(segs[-1][1], float) if segs else np.zeros(3)
    return T[:3, :3] @ local + T[:3, 3]


def fitting_scale(start, vector, center, radius: float, planar: bool = False) -> float:
    """Largest s >= 0 with |start + s vector - center| <= radius (0 when start is outside);
    in the plane z = 0 only for a planar robot.

    >>> round(fitting_scale([0, 0, 0], [1, 0, 0], [0, 0, 0], 2.0), 12)
    2.0
    """
    a = np.asarray(start, float) - np.asarray(center, float)
    v = np.asarray(vector, float)
    if planar:
        a, v = a[:2], v[:2]
    vv = float(v @ v)
    c = float(a @ a) - radius ** 2
    if vv < 1e-24 or c > 0:
        return 0.0
    av = float(a @ v)
    return float((-av + np.sqrt(av * av - vv * c)) / vv)


def _world(v) -> np.ndarray:
    a = np.asarray(v, float).reshape(-1)
    return np.concatenate([a, np.zeros(3 - a.size)])[:3] if a.size <= 3 else a[:3]


class HintDrawer:
    """Draws and removes the 3D hints of one step in a session's scene (only its own overlays)."""

    def __init__(self, session):
        self.session = session
        self.names: List[str] = []
        self.arrow_scale: Optional[float] = None

    def clear(self) -> None:
        scene = self.session.scene
        for name in self.names:
            try:
                scene.remove_overlay(name)
            except Exception:       # removed with the robot already
                pass
        self.names = []
        self.arrow_scale = None

    def _name(self, base: str) -> str:
        name = f"{PREFIX}{base}"
        self.names.append(name)
        return name

    def draw(self, highlight: Dict[str, Any], q) -> None:
        """Show a step's hints with the robot at q (lit bodies and joints included)."""
        session = self.session
        scene = session.scene
        drawing = session.drawing
        self.clear()
        scene.highlight(highlight.get("bodies", []), highlight.get("joints", []))
        if drawing is None:
            return
        framing = drawing.framing(q)
        r = drawing.radius
        vectors = [v for v in highlight.get("vectors") or [] if not v.get("joint_space")]
        joint_rows = list((highlight.get("joint_values") or [])[:1])
        joint_rows += [{"label": v.get("label", ""), "values": v.get("vector", []), "role": v.get("role", "gradient")}
                       for v in highlight.get("vectors") or [] if v.get("joint_space")]
        with session.atomic():
            if vectors:
                self._draw_vectors(vectors, q, framing)
            if joint_rows:
                self._draw_joint_values(joint_rows[0], q, r)
            for k, p in enumerate(highlight.get("points") or []):
                pos = _world(p.get("position", [0, 0, 0]))
                scene.add_marker(self._name(f"point{k}"), pos, ROLE_COLORS["point"], 1.2 * r)
                self.names.append(f"{PREFIX}point{k}_label")
                scene.add_label(f"{PREFIX}point{k}_label", str(p.get("label", "")), pos + 1.5 * r)
            path = highlight.get("path")
            if path and len(path) >= 2:
                scene.add_line(self._name("path"), np.array([_world(p) for p in path]), ROLE_COLORS["path"], 3.0)

    def _draw_vectors(self, vectors, q, framing) -> None:
        scene = self.session.scene
        tip = tip_position(self.session.drawing, q)
        longest = max(float(np.linalg.norm(_world(v.get("vector", [0])))) for v in vectors)
        if longest < 1e-12:
            return
        size = framing.radius
        scale = 0.45 * size / longest
        for v in vectors:                # keep the arrows inside the framed view when possible
            start = _world(v["origin"]) if "origin" in v else tip
            fit = fitting_scale(start, _world(v.get("vector", [0])), framing.center, 0.95 * size,
                                planar=self.session.drawing.robot.is_planar)
            scale = min(scale, max(fit, 0.2 * size / longest))
        self.arrow_scale = scale
        drawn: List[tuple] = []          # (start, vector, label name, text) of the arrows drawn
        for k, v in enumerate(vectors):
            vec = _world(v.get("vector", [0, 0, 0])) * scale
            if np.linalg.norm(vec) < 1e-9:
                continue
            start = _world(v["origin"]) if "origin" in v else tip
            text = str(v.get("label", ""))
            same = next((d for d in drawn if np.linalg.norm(d[0] - start) + np.linalg.norm(d[1] - vec)
                         < 0.01 * np.linalg.norm(vec)), None)
            if same is not None:         # e.g. the task executed exactly: one arrow, both names
                same[3].append(text)
                scene.remove_overlay(same[2])
                scene.add_label(same[2], " = ".join(same[3]), same[0] + same[1] * 1.04)
                continue
            color = ROLE_COLORS.get(v.get("role", "desired"), ROLE_COLORS["desired"])
            scene.add_arrow(self._name(f"vector{k}"), start, vec, color)
            label = f"{PREFIX}vector{k}_label"
            self.names.append(label)
            scene.add_label(label, text, start + vec * 1.04)
            drawn.append((start, vec, label, [text]))

    def _draw_joint_values(self, row: Dict[str, Any], q, r: float) -> None:
        """An arc per revolute joint (a bar per prismatic one) proportional to the joint's value;
        the bounds as grey arcs; orange when saturated, red when out of bounds."""
        scene = self.session.scene
        joints = joint_geometry(self.session.drawing, q)
        values = np.asarray(row.get("values", []), float).reshape(-1)
        if values.size != len(joints):
            return
        lower, upper = row.get("lower"), row.get("upper")
        lo = np.asarray(lower, float) if lower is not None else None
        hi = np.asarray(upper, float) if upper is not None else None
        span = np.abs(values)
        for b in (lo, hi):
            if b is not None:
                span = np.maximum(span, np.where(np.isfinite(b), np.abs(b), 0))
        top = float(np.max(span)) if span.size else 0.0
        if top < 1e-12:
            return
        k_angle = MAX_ARC / top
        saturated = set(row.get("saturated") or [])
        violating = set(row.get("violating") or [])
        role = row.get("role", "joint")
        radius = 4.5 * r
        for i, (j, value) in enumerate(zip(joints, values)):
            index = i + 1
            at_bound = any(b is not None and np.isfinite(b[i]) and abs(value - b[i]) <= 1e-6 * max(1.0, abs(b[i]))
                           for b in (lo, hi))
            outside = lo is not None and hi is not None and (value < lo[i] - 1e-9 or value > hi[i] + 1e-9)
            color = (ROLE_COLORS["violating"] if index in violating or outside else
                     ROLE_COLORS["saturated"] if index in saturated or at_bound else
                     ROLE_COLORS.get(role, ROLE_COLORS["joint"]))
            center, axis, ref = j["position"], j["axis"], j["reference"]
            if self.session.drawing.robot.is_planar:     # in front of the links (camera on +z)
                center = center + np.array([0.0, 0.0, 2.0 * r])
            if j["type"] == "revolute":
                ring = radius * (1.0 + 0.12 * (i % 2))
                if lo is not None and hi is not None and np.isfinite(lo[i]) and np.isfinite(hi[i]):
                    pts = arc_points(center, axis, ref, ring * 1.18, lo[i] * k_angle, hi[i] * k_angle)
                    scene.add_line(self._name(f"bound{i}"), pts, ROLE_COLORS["bounds"], 2.0)
                if abs(value) * k_angle > 1e-3:
                    pts = arc_points(center, axis, ref, ring, 0.0, value * k_angle)
                    scene.add_line(self._name(f"arc{i}"), pts, color, 5.0)
                    tangent = pts[-1] - pts[-2]
                    tangent = tangent / max(np.linalg.norm(tangent), 1e-12) * 1.6 * r
                    scene.add_arrow(self._name(f"head{i}"), pts[-1] - tangent * 0.5, tangent, color)
                    end = pts[-1]
                else:
                    end = center + ring * ref
                    scene.add_marker(self._name(f"zero{i}"), end, color, 0.7 * r)
            else:
                unit = radius * 1.6 / top
                start = center + 2.2 * r * ref
                if lo is not None and hi is not None and np.isfinite(lo[i]) and np.isfinite(hi[i]):
                    scene.add_line(self._name(f"bound{i}"), [start + axis * lo[i] * unit, start + axis * hi[i] * unit],
                                   ROLE_COLORS["bounds"], 2.0)
                if abs(value) * unit > 1e-4:
                    scene.add_arrow(self._name(f"head{i}"), start, axis * value * unit, color)
                end = start + axis * value * unit
            label = f"{PREFIX}jlabel{i}"
            self.names.append(label)
            scene.add_label(label, f"j{index} = {value:.4g}", end + 0.8 * r * ref)
