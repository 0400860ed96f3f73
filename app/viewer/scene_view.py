"""The robot in one browser tab's 3D scene: draws an ``app.scene.RobotDrawing`` with viser, moves
it, highlights bodies and joints, shows ghosts and overlays (markers, lines, trajectories, arrows,
labels), and a panel's own named drawings (``group``). Panels reach it as ``session.scene`` and
draw in the 3D view only through it; see docs/panels.md.
"""
from __future__ import annotations

import threading
import warnings
from typing import Callable, Dict, Iterable, List, Optional, Tuple

import numpy as np

from app.scene import (HIGHLIGHT_COLOR, Framing, RobotDrawing, align_z, arrow, camera_pose,
                       quaternion_wxyz)

Color = Tuple[int, int, int]

ROBOT_ROOT = "/robot"     # every drawing of a robot lives under ROBOT_ROOT/d<k>, a name never reused
OVERLAY_ROOT = "/overlay"
ENV_ROOT = "/env"
SIDE_PANEL_PX = 400      # the control panel floats over the right of the canvas


def _node(attach: str) -> str:
    return attach.replace("@", "__")


def _dim(color: Color, amount: float = 0.55) -> Color:
    """A washed-out version of a colour (towards white), for the parts that are not highlighted."""
    return tuple(int(c + (255 - c) * amount) for c in color)


class SceneView:
    """One tab's 3D view of the current robot (thread-safe)."""

    def __init__(self, client):
        self.client = client
        self.scene = client.scene
        self.drawing: Optional[RobotDrawing] = None
        self.q: Optional[np.ndarray] = None          # the configuration drawn
        self._lock = threading.RLock()
        self._frames: Dict[str, object] = {}
        self._root: Optional[object] = None           # the current drawing's root node
        self._env_root: Optional[object] = None       # its graph paper and gravity arrow
        self._drawings = 0                            # drawings made so far: names them
        self._meshes: List[Tuple[object, object]] = []       # (handle, part)
        self._axes: List[object] = []
        self._labels: List[object] = []
        self._env: List[object] = []
        self._ghosts: Dict[str, Tuple[RobotDrawing, Dict[str, object]]] = {}
        self._overlays: Dict[str, object] = {}
        self.options = {"frames": False, "coms": True, "labels": True, "plane": True}
        self.highlighted: Dict[str, List[str]] = {"bodies": [], "joints": []}
        self._pending_camera: Optional[Callable[[int, int], Optional[Tuple]]] = None
        self._camera_hooked = False
        self.line_scale = 1.0                  # presenter mode: lines are drawn thicker (set_line_scale)
        self._line_widths: Dict[str, float] = {}      # overlay line name -> width asked for [px]
        self.panel_fraction: Optional[float] = None   # presenter mode: share of the width the panel covers
        self._gravity = None
        self._gravity_place = None
        # flat textbook look, and cheap frames in software WebGL: no shadows, no environment map
        self.scene.configure_default_lights(enabled=True, cast_shadow=False)
        self.scene.configure_environment_map(hdri=None)
        self.scene.add_light_ambient("/lights/ambient", intensity=0.9)     # the environment map's share

    # ------------------------------------------------------------------ robot
    def _fresh_root(self, prefix: str) -> Tuple[str, object]:
        """A new scene node ``prefix``d<k> for one drawing. Names are never reused: viser's browser
        keeps the pose of a node removed and re-created under the same name within one update
        window, which drew a new robot's link where the previous robot's link had been."""
        self._drawings += 1
        path = f"{prefix}d{self._drawings}"
        return path, self.scene.add_frame(path, show_axes=False)

    @property
    def robot_root(self) -> str:
        """Scene path of the robot drawn now (e.g. ``/robot/d3``); its frames are
        ``<root>/<body>`` and ``<root>/<body>__joint``."""
        return self._root.name if self._root is not None else ""

    def show_robot(self, drawing: RobotDrawing, q) -> None:
        """Replace the drawn robot (and its environment) by ``drawing`` at coordinates q."""
        with self._lock, self.client.atomic():
            self._remove_robot()
            self.drawing = drawing
            r = drawing.radius
            root, self._root = self._fresh_root(f"{ROBOT_ROOT}/")
            attaches = ["base"] + [a for b in drawing.robot.bodies for a in (f"{b.name}@joint", b.name)]
            for attach in attaches:
                self._frames[attach] = self.scene.add_frame(f"{root}/{_node(attach)}", show_axes=False)
            for part in drawing.parts:
                mesh = part.mesh
                handle = self.scene.add_mesh_simple(
                    f"{root}/{_node(part.attach)}/{part.name}", mesh.vertices.astype(np.float32),
                    mesh.faces.astype(np.uint32), color=part.color, opacity=None if part.opacity >= 1 else part.opacity,
                    flat_shading=False, cast_shadow=False, receive_shadow=False,
                    visible=self.options["coms"] or part.role != "com")
                self._meshes.append((handle, part))
            for attach in ["base"] + [b.name for b in drawing.robot.bodies]:
                self._axes.append(self.scene.add_frame(
                    f"{root}/{_node(attach)}/axes", show_axes=True, axes_length=4.5 * r,
                    axes_radius=0.18 * r, origin_radius=0.3 * r, visible=self.options["frames"]))
            for mark in drawing.joint_marks:
                self._labels.append(self.scene.add_label(
                    f"{root}/{_node(mark.attach)}/label", mark.text, position=tuple(mark.position),
                    anchor="bottom-left", font_screen_scale=1.1, visible=self.options["labels"]))
            self._draw_environment(drawing)
            if self._gravity_place is not None:       # same view as before (a parameter changed)
                self._place_gravity(*self._gravity_place)
            self.set_pose(q)
            self._apply_highlight()

    def _remove_robot(self) -> None:
        if self._root is not None:
            self._root.remove()          # and every node below it
            self._root = None
        if self._env_root is not None:
            self._env_root.remove()
            self._env_root = None
        self._frames.clear()
        self._meshes.clear()
        self._axes.clear()
        self._labels.clear()
        self._env.clear()
        self._gravity = None
        for name in list(self._ghosts):
            self.remove_ghost(name)

    def _draw_environment(self, drawing: RobotDrawing) -> None:
        """Graph paper: lines in the plane of motion behind a planar robot, or on the ground under
        a spatial one. Lines only: a filled plane costs most of the frame time in software WebGL."""
        framing = drawing.framing()
        root, self._env_root = self._fresh_root(f"{ENV_ROOT}/")
        r = drawing.radius
        size = 7.0 * framing.radius
        cell = _nice_cell(size / 14)
        if drawing.robot.is_planar:
            R = np.eye(3)
            origin = np.array([framing.center[0], framing.center[1], -3.2 * r])
            cells, sections = (212, 219, 230), (172, 184, 204)
        else:
            R = align_z(drawing.up)
            origin = -3.5 * r * drawing.up
            cells, sections = (212, 215, 221), (165, 171, 181)
        half = size / 2
        ticks = np.arange(-np.floor(half / cell), np.floor(half / cell) + 1) * cell
        segments, colors = [], []
        for t in ticks:
            major = abs(t / (5 * cell) - round(t / (5 * cell))) < 1e-6
            for seg in (((t, -half, 0.0), (t, half, 0.0)), ((-half, t, 0.0), (half, t, 0.0))):
                segments.append(seg)
                colors.append([sections if major else cells] * 2)
        lines = self.scene.add_line_segments(f"{root}/plane", np.array(segments, np.float32),
                                             np.array(colors, np.uint8), thickness=1.0, thickness_units="screen",
                                             position=tuple(origin), wxyz=tuple(quaternion_wxyz(R)),
                                             visible=self.options["plane"])
        self._env.append(lines)
        g = drawing.gravity
        if np.linalg.norm(g) > 1e-12:
            self._env.extend(self._gravity_arrow(drawing, framing, root))

    def _gravity_arrow(self, drawing: RobotDrawing, framing: Framing, root: str):
        """The gravity arrow (and its label) in a node of its own, placed by ``frame_camera``."""
        length = 0.22 * framing.radius
        mesh = arrow(np.zeros(3), -drawing.up * length, 0.45 * drawing.radius)
        node = self.scene.add_frame(f"{root}/gravity", show_axes=False)
        self.scene.add_mesh_simple(f"{root}/gravity/arrow", mesh.vertices.astype(np.float32),
                                   mesh.faces.astype(np.uint32), color=(40, 60, 110),
                                   cast_shadow=False, receive_shadow=False)
        self.scene.add_label(f"{root}/gravity/label", "g", position=(0.0, 0.0, 0.0),
                             anchor="bottom-center", font_screen_scale=1.3)
        self._gravity = node
        return [node]

    def _place_gravity(self, framing: Framing, right: np.ndarray, visible_half_width: float) -> None:
        """Put the gravity arrow in the upper left of the view."""
        if self._gravity is None:
            return
        up = self.drawing.up
        screen_up = up - np.dot(up, right) * right
        norm = np.linalg.norm(screen_up)
        screen_up = screen_up / norm if norm > 1e-9 else np.cross(right, [0.0, 0.0, -1.0])
        position = framing.center - 0.8 * visible_half_width * right + 0.55 * framing.radius * screen_up
        if self.drawing.robot.is_planar:
            position[2] = 0.0
        self._gravity.position = tuple(position)

    def set_pose(self, q) -> None:
        """Move the drawn robot to coordinates q (a few pose updates, no mesh traffic)."""
        with self._lock:
            if self.drawing is None:
                return
            q = np.asarray(q, dtype=float).copy()
            poses = self.drawing.poses(q)      # raises on a wrong size: self.q stays valid
            self.q = q
            with self.client.atomic():
                for attach, handle in self._frames.items():
                    T = poses[attach]
                    handle.position = T[:3, 3]
                    handle.wxyz = quaternion_wxyz(T[:3, :3])

    # ------------------------------------------------------------------ display options
    def set_option(self, name: str, value: bool) -> None:
        """Toggle ``frames``, ``coms``, ``labels`` or ``plane``."""
        with self._lock:
            self.options[name] = bool(value)
            targets = {"frames": self._axes, "labels": self._labels,
                       "coms": [h for h, p in self._meshes if p.role == "com"],
                       "plane": self._env[:1]}[name]
            for handle in targets:
                handle.visible = bool(value)

    # ------------------------------------------------------------------ highlight
    def highlight(self, bodies: Iterable[str] = (), joints: Iterable[str] = ()) -> None:
        """Light up bodies (their links) and joints (named by their body); dim the rest."""
        with self._lock:
            self.highlighted = {"bodies": list(bodies), "joints": list(joints)}
            self._apply_highlight()

    def clear_highlight(self) -> None:
        self.highlight((), ())

    def _apply_highlight(self) -> None:
        bodies, joints = set(self.highlighted["bodies"]), set(self.highlighted["joints"])
        active = bool(bodies or joints)
        with self.client.atomic():
            for handle, part in self._meshes:
                if part.role == "com":
                    continue
                if not active:
                    color = part.color
                elif part.role in ("link",) and part.body in bodies:
                    color = HIGHLIGHT_COLOR
                elif part.role == "joint" and part.body in joints:
                    color = HIGHLIGHT_COLOR
                else:
                    color = _dim(part.color)
                if tuple(handle.color) != tuple(color):
                    handle.color = color

    # ------------------------------------------------------------------ ghosts
    def ghost(self, q, name: str = "ghost", color: Color = (150, 150, 150), opacity: float = 0.35) -> None:
        """Draw (or move) a translucent copy of the robot at coordinates q."""
        with self._lock:
            if self.drawing is None:
                return
            if name not in self._ghosts or self._ghosts[name][0] is not self.drawing:
                self.remove_ghost(name)
                root, root_handle = self._fresh_root(f"/ghost_{name}/")
                frames = {"": root_handle}
                for attach in ["base"] + [a for b in self.drawing.robot.bodies for a in (f"{b.name}@joint", b.name)]:
                    frames[attach] = self.scene.add_frame(f"{root}/{_node(attach)}", show_axes=False)
                for part in self.drawing.parts:
                    if part.role in ("base", "com"):
                        continue
                    mesh = part.mesh
                    self.scene.add_mesh_simple(f"{root}/{_node(part.attach)}/{part.name}",
                                               mesh.vertices.astype(np.float32), mesh.faces.astype(np.uint32),
                                               color=color, opacity=opacity, cast_shadow=False,
                                               receive_shadow=False)
                self._ghosts[name] = (self.drawing, frames)
            poses = self.drawing.poses(q)
            with self.client.atomic():
                for attach, handle in self._ghosts[name][1].items():
                    if not attach:
                        continue
                    T = poses[attach]
                    handle.position = T[:3, 3]
                    handle.wxyz = quaternion_wxyz(T[:3, :3])

    def remove_ghost(self, name: str = "ghost") -> None:
        with self._lock:
            entry = self._ghosts.pop(name, None)
            if entry is not None:
                entry[1][""].remove()        # the ghost's root, and everything below it

    # ------------------------------------------------------------------ overlays
    def _node(self, name: str) -> str:
        """A fresh scene path for the overlay ``name`` (``/overlay/<name>/d<k>``); an overlay of
        the same name is removed first. Paths are never reused (see ``_fresh_root``)."""
        with self._lock:
            old = self._overlays.pop(name, None)
            if old is not None:
                try:
                    old.remove()
                except Exception:     # already removed with its parent
                    pass
            self._drawings += 1
            return f"{OVERLAY_ROOT}/{name}/d{self._drawings}"

    def _put(self, name: str, handle) -> object:
        self._line_widths.pop(name, None)
        self._overlays[name] = handle
        return handle

    def add_marker(self, name: str, position, color: Color = (214, 39, 40), radius: Optional[float] = None,
                   label: Optional[str] = None):
        """A small sphere (and optional text) at a world position."""
        r = radius or (1.3 * self.drawing.radius if self.drawing else 0.03)
        handle = self.scene.add_icosphere(self._node(name), radius=r, color=color,
                                          position=tuple(np.asarray(position, float)))
        self._put(name, handle)
        if label:
            self.add_label(f"{name}_label", label, np.asarray(position, float) + r)
        return handle

    def add_line(self, name: str, points, color: Color = (214, 39, 40), width: float = 3.0):
        """A polyline through world points (N x 3)."""
        pts = np.asarray(points, dtype=np.float32).reshape(-1, 3)
        segments = np.stack([pts[:-1], pts[1:]], axis=1)
        handle = self.scene.add_line_segments(self._node(name), segments, colors=color,
                                              thickness=width * self.line_scale, thickness_units="screen")
        self._put(name, handle)
        self._line_widths[name] = width
        return handle

    def set_line_scale(self, scale: float) -> None:
        """Draw lines ``scale`` times as thick as asked, the ones on display included (presenter mode)."""
        with self._lock:
            self.line_scale = float(scale)
            with self.client.atomic():
                for name, width in self._line_widths.items():
                    handle = self._overlays.get(name)
                    if handle is not None:
                        handle.thickness = width * self.line_scale

    def add_trajectory(self, name: str, points, color: Color = (31, 119, 180), width: float = 2.5):
        """A path through world points, e.g. an end-effector or ball trajectory."""
        return self.add_line(name, points, color, width)

    def add_arrow(self, name: str, start, vector, color: Color = (214, 39, 40), label: Optional[str] = None):
        """A solid arrow (force, velocity) from ``start`` along ``vector`` (world coordinates)."""
        r = 0.5 * (self.drawing.radius if self.drawing else 0.02)
        mesh = arrow(start, vector, r)
        handle = self.scene.add_mesh_simple(self._node(name), mesh.vertices.astype(np.float32),
                                            mesh.faces.astype(np.uint32), color=color,
                                            cast_shadow=False, receive_shadow=False)
        self._put(name, handle)
        if label:
            self.add_label(f"{name}_label", label, np.asarray(start, float) + np.asarray(vector, float))
        return handle

    def add_label(self, name: str, text: str, position):
        handle = self.scene.add_label(self._node(name), text, position=tuple(np.asarray(position, float)),
                                      anchor="bottom-left")
        return self._put(name, handle)

    def remove_overlay(self, name: str) -> None:
        self._line_widths.pop(name, None)
        handle = self._overlays.pop(name, None)
        if handle is not None:
            handle.remove()

    def clear_overlays(self) -> None:
        """Remove every marker, line, trajectory, arrow and label added by panels."""
        with self.client.atomic():
            for name in list(self._overlays):
                self.remove_overlay(name)

    # ------------------------------------------------------------------ a panel's own nodes
    def group(self, root: str) -> "SceneGroup":
        """A ``SceneGroup``: named drawings of a panel under the scene path ``root`` (e.g.
        ``/throw``), which the panel removes with ``clear()``."""
        return SceneGroup(self.scene, root)

    # ------------------------------------------------------------------ camera
    @property
    def camera(self):
        """The browser's camera (viser's ``CameraHandle``): read its pose and image size; set it
        with ``point_camera``."""
        return self.client.camera

    def frame_camera(self) -> None:
        """Point the camera at the robot as drawn now (with a margin for moving it); planar robots
        square-on to their plane (see ``point_camera`` for when it happens)."""
        self.point_camera(self._robot_camera)

    def point_camera(self, pose_for_view: Callable[[int, int], Optional[Tuple]]) -> None:
        """Set the camera to ``pose_for_view(width, height)`` of the browser's 3D view in pixels:
        (fov in radians, position, look_at, up) or None to leave it. Before the browser has reported
        its camera (and so its size), the request waits for that first report; the last request
        wins, so a panel's framing is not undone by an earlier one that waited."""
        with self._lock:
            camera = self.client.camera
            if camera.update_timestamp == 0.0:
                self._pending_camera = pose_for_view
                if not self._camera_hooked:
                    self._camera_hooked = True
                    camera.on_update(self._first_camera_report)
                return
            self._pending_camera = None
            width = camera.image_width if camera.image_height > 0 else 1280
            height = camera.image_height if camera.image_height > 0 else 720
            pose = pose_for_view(width, height)
            if pose is None:
                return
            fov, position, look_at, up = pose
            with self.client.atomic():
                camera.fov = float(fov)
                camera.up_direction = tuple(up)
                camera.position = tuple(position)
                camera.look_at = tuple(look_at)

    def _robot_camera(self, width: int, height: int) -> Optional[Tuple]:
        if self.drawing is None:
            return None
        fov = np.radians(28.0 if self.drawing.robot.is_planar else 40.0)   # little perspective
        aspect = width / height
        occluded = SIDE_PANEL_PX / width if width > 2.2 * SIDE_PANEL_PX else 0.0
        if self.panel_fraction is not None:
            occluded = self.panel_fraction
        framing = self.drawing.framing(self.q)
        position, look_at, up = camera_pose(framing, fov=fov, aspect=aspect, occluded_right=occluded)
        forward = (look_at - position) / np.linalg.norm(look_at - position)
        right = np.cross(forward, up)
        right /= np.linalg.norm(right)
        half_width = np.linalg.norm(look_at - position) * np.tan(fov / 2) * aspect * (1 - occluded)
        with self.client.atomic():
            self._gravity_place = (framing, right, half_width)
            self._place_gravity(framing, right, half_width)
        return fov, position, look_at, up

    def _first_camera_report(self, _camera) -> None:
        pending = self._pending_camera
        if pending is not None:
            self.point_camera(pending)


class SceneGroup:
    """Scene nodes of one tab under ``root``, by short name; adding a name again replaces it
    (``SceneView.group``: a panel's own drawings, e.g. the Throw studio's, beside the robot).
    Points may be given in the plane z = 0 (x, y) or in space."""

    def __init__(self, scene, root: str = "/throw"):
        self.scene = scene
        self.root = root
        self._handles: Dict[str, object] = {}
        self._lock = threading.RLock()

    def _put(self, name: str, handle):
        # viser replaces a node of the same scene name (the old handle goes inert), so there is
        # nothing to remove here
        with self._lock:
            self._handles[name] = handle
        return handle

    def get(self, name: str):
        with self._lock:
            return self._handles.get(name)

    def path(self, name: str) -> str:
        return f"{self.root}/{name}"

    def segments(self, name: str, segs, color, width: float = 2.0, visible: bool = True):
        """Line segments (N, 2, 2 or 3) in the plane z = 0, ``width`` in pixels."""
        segs = np.asarray(segs, dtype=np.float32)
        if segs.shape[-1] == 2:
            segs = np.concatenate([segs, np.zeros(segs.shape[:-1] + (1,), np.float32)], axis=-1)
        if segs.shape[0] == 0:
            self.remove(name)
            return None
        return self._put(name, self.scene.add_line_segments(self.path(name), segs, colors=tuple(color),
                                                            thickness=width, thickness_units="screen",
                                                            visible=visible))

    def polyline(self, name: str, points, color, width: float = 2.0, dashed: bool = False, visible: bool = True):
        """A polyline through (N, 2) points; ``dashed`` draws every other segment. Non-finite
        points break the line."""
        pts = np.asarray(points, dtype=float)
        segs = np.stack([pts[:-1], pts[1:]], axis=1)
        keep = np.all(np.isfinite(segs), axis=(1, 2))
        if dashed:
            keep &= (np.arange(len(segs)) % 2) == 0
        return self.segments(name, segs[keep], color, width, visible)

    def sphere(self, name: str, position, radius: float, color, visible: bool = True):
        pos = np.zeros(3)
        pos[:len(position)] = position
        return self._put(name, self.scene.add_icosphere(self.path(name), radius=radius, color=tuple(color),
                                                        position=tuple(pos), cast_shadow=False,
                                                        receive_shadow=False, visible=visible))

    def label(self, name: str, text: str, position, anchor: str = "bottom-left", scale: float = 1.0,
              visible: bool = True):
        pos = np.zeros(3)
        pos[:len(position)] = position
        return self._put(name, self.scene.add_label(self.path(name), text, position=tuple(pos), anchor=anchor,
                                                    font_screen_scale=scale, visible=visible))

    def arrow(self, name: str, start, vector, color, radius: float = 0.012, visible: bool = True):
        s = np.zeros(3)
        s[:len(start)] = start
        v = np.zeros(3)
        v[:len(vector)] = vector
        if np.linalg.norm(v) < 1e-9:
            self.remove(name)
            return None
        mesh = arrow(s, v, radius)
        return self._put(name, self.scene.add_mesh_simple(self.path(name), mesh.vertices.astype(np.float32),
                                                          mesh.faces.astype(np.uint32), color=tuple(color),
                                                          cast_shadow=False, receive_shadow=False,
                                                          visible=visible))

    def remove(self, name: str) -> None:
        with self._lock:
            handle = self._handles.pop(name, None)
        if handle is not None:
            _remove(handle)

    def names(self):
        with self._lock:
            return list(self._handles)

    def clear(self, prefix: str = "") -> None:
        for name in self.names():
            if name.startswith(prefix):
                self.remove(name)


def _remove(handle) -> None:
    with warnings.catch_warnings():       # viser warns about nodes already replaced or removed
        warnings.simplefilter("ignore")
        try:
            handle.remove()
        except Exception:     # already gone (its parent was removed, or the tab closed)
            pass


def _nice_cell(step: float) -> float:
    """A round grid spacing (1, 2 or 5 times a power of ten) near ``step``.

    >>> round(_nice_cell(0.13), 12), round(_nice_cell(0.04), 12)
    (0.1, 0.05)
    """
    exp = np.floor(np.log10(step))
    base = step / 10 ** exp
    nice = 1 if base < 1.5 else 2 if base < 3.5 else 5 if base < 7.5 else 10
    return float(nice * 10 ** exp)
