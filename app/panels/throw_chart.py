"""A chart of the VHC's Bezier curves phi1(s), phi2(s) (and the wrist angle q3(s) that follows)
drawn in the 3D view below the ground, whose control points the user drags with the mouse.

viser has no draggable points in its 2D plots, but scene nodes report drags (``on_drag``, the
pointer projected onto a plane facing the camera). The chart maps s in [0, 1] to x and an angle
to y on a rectangle of the plane z = 0, so a dragged sphere's height is the control point's new
value. The vertical scale stays fixed while a point is dragged and fits the curves again after.
"""
from __future__ import annotations

import math
import threading
from dataclasses import dataclass
from typing import Callable, List, Optional, Sequence, Tuple

import numpy as np

from app.core.throw.bezier import bernstein
from app.viewer import SceneGroup

from .throw_plots import JOINT_COLORS

FRAME_COLOR = (120, 126, 136)
GRID_COLOR = (205, 210, 218)
SELECTED_COLOR = (255, 196, 0)
CURVE_SAMPLES = 121


@dataclass(frozen=True)
class ChartGeometry:
    """The chart's rectangle in the plane (x0, y0 lower-left corner, width, height [m]) and the
    angle range [lo, hi] [rad] it shows.

    >>> g = ChartGeometry(0.0, -1.5, 2.0, 1.0, 0.0, 2.0)
    >>> g.point(0.5, 1.0).round(12).tolist(), round(g.value(-0.75), 12)
    ([1.0, -1.0], 1.5)
    """
    x0: float
    y0: float
    width: float
    height: float
    lo: float
    hi: float

    def point(self, s, value) -> np.ndarray:
        """World (x, y) of chart coordinates (s, angle); arrays give (N, 2)."""
        s, value = np.broadcast_arrays(np.asarray(s, float), np.asarray(value, float))
        x = self.x0 + s * self.width
        y = self.y0 + (value - self.lo) / (self.hi - self.lo) * self.height
        return np.stack([x, y], axis=-1)

    def value(self, y: float) -> float:
        """The angle shown at world height y."""
        return self.lo + (float(y) - self.y0) / self.height * (self.hi - self.lo)


def nice_step(span: float, count: int = 5) -> float:
    """A round tick spacing (1, 2, 2.5 or 5 times a power of ten) giving about ``count`` ticks.

    >>> tuple(round(nice_step(span), 12) for span in (1.3, 1.1, 0.2))
    (0.5, 0.25, 0.05)
    """
    raw = max(span, 1e-9) / count
    exp = math.floor(math.log10(raw))
    for m in (1.0, 2.0, 2.5, 5.0, 10.0):
        if m * 10 ** exp >= raw:
            return m * 10 ** exp
    return 10.0 ** (exp + 1)


def fit_range(values: Sequence[float], pad: float = 0.12) -> Tuple[float, float]:
    """An angle range on round ticks that holds every finite value with a margin.

    >>> tuple(round(v, 12) + 0.0 for v in fit_range([0.33, 1.73]))
    (0.0, 2.0)
    """
    v = np.asarray(values, float)
    v = v[np.isfinite(v)]
    lo, hi = (float(v.min()), float(v.max())) if v.size else (0.0, 1.0)
    span = max(hi - lo, 0.2)
    lo, hi = lo - pad * span, hi + pad * span
    step = nice_step(hi - lo)
    return math.floor(lo / step) * step, math.ceil(hi / step) * step


def curve_samples(points: Sequence[float], s: np.ndarray) -> np.ndarray:
    """The Bezier polynomial with control points ``points`` at s.

    >>> curve_samples([0.0, 1.0, 0.0], np.array([0.5])).round(12).tolist()
    [0.5]
    """
    return bernstein(len(points) - 1, s) @ np.asarray(points, float)


DragCallback = Callable[[str, int, float, str], None]       # (kind "a"/"b", index, value, phase)
SelectCallback = Callable[[str, int], None]


class BezierChart:
    """The chart's scene nodes; ``draw`` redraws it, a drag calls ``on_drag(kind, index, value,
    phase)`` with the value under the pointer (phase "start", "update", "end"), a click calls
    ``on_select(kind, index)``."""

    def __init__(self, nodes: SceneGroup, rect: Tuple[float, float, float, float], on_drag: DragCallback,
                 on_select: SelectCallback, point_radius: float = 0.028):
        self.nodes = nodes
        self.rect = rect
        self.on_drag = on_drag
        self.on_select = on_select
        self.point_radius = point_radius
        self.geometry: Optional[ChartGeometry] = None
        self.frozen = False             # keep the scale while a point is dragged
        self.visible = True
        self._markers: List[Tuple[str, int]] = []
        self._ticks: Optional[tuple] = None
        self._lock = threading.RLock()

    @property
    def bottom(self) -> float:
        return self.rect[1]

    def draw(self, a: Sequence[float], b: Sequence[float], q3: Optional[Tuple[np.ndarray, np.ndarray]] = None,
             selected: Optional[Tuple[str, int]] = None) -> None:
        """Curves, control polygons and points of phi1 (from ``a``) and phi2 (``b``); ``q3`` = (s, values)
        of the wrist angle (NaN where unreachable)."""
        with self._lock:
            s = np.linspace(0.0, 1.0, CURVE_SAMPLES)
            curves = {"a": curve_samples(a, s), "b": curve_samples(b, s)}
            if self.geometry is None or not self.frozen:
                values = list(a) + list(b) + list(curves["a"]) + list(curves["b"])
                if q3 is not None:
                    values += list(q3[1][np.isfinite(q3[1])])
                lo, hi = fit_range(values)
                x0, y0, w, h = self.rect
                self.geometry = ChartGeometry(x0, y0, w, h, lo, hi)
            g = self.geometry
            self._frame(g)
            n, vis = self.nodes, self.visible
            for kind, points, color in (("a", a, JOINT_COLORS[0]), ("b", b, JOINT_COLORS[1])):
                n.polyline(f"chart_curve_{kind}", self._clip(g, s, curves[kind]), color, 3.0, visible=vis)
                abscissa = np.linspace(0.0, 1.0, len(points))
                light = tuple(int(c + (255 - c) * 0.45) for c in color)
                n.polyline(f"chart_polygon_{kind}", self._clip(g, abscissa, np.asarray(points, float)), light, 1.2,
                           dashed=False, visible=vis)
            if q3 is not None:
                n.polyline("chart_curve_q3", self._clip(g, q3[0], q3[1]), JOINT_COLORS[2], 2.0, dashed=True,
                           visible=vis)
            else:
                n.remove("chart_curve_q3")
            self._points(g, a, b, selected)

    @staticmethod
    def _clip(g: ChartGeometry, s, values) -> np.ndarray:
        """World points of a curve; the parts outside the chart's range become NaN (not drawn)."""
        values = np.asarray(values, float).copy()
        values[(values < g.lo - 1e-9) | (values > g.hi + 1e-9)] = np.nan
        return g.point(s, values)

    def _frame(self, g: ChartGeometry) -> None:
        n, vis = self.nodes, self.visible
        ticks = (g.lo, g.hi, g.x0, g.y0, g.width, g.height, vis)
        if ticks == self._ticks:
            return
        self._ticks = ticks
        x0, y0, x1, y1 = g.x0, g.y0, g.x0 + g.width, g.y0 + g.height
        n.segments("chart_frame", [[[x0, y0], [x1, y0]], [[x1, y0], [x1, y1]], [[x1, y1], [x0, y1]],
                                   [[x0, y1], [x0, y0]]], FRAME_COLOR, 1.5, visible=vis)
        step = nice_step(g.hi - g.lo)
        values = np.arange(math.ceil(g.lo / step - 1e-9) * step, g.hi + 1e-9, step)
        grid = [[[x0, y], [x1, y]] for y in g.point(0.0, values)[:, 1]]
        grid += [[[x, y0], [x, y1]] for x in g.point(np.array([0.25, 0.5, 0.75]), g.lo)[:, 0]]
        n.segments("chart_grid", grid, GRID_COLOR, 1.0, visible=vis)
        n.clear("chart_tick")
        for k, v in enumerate(values):
            n.label(f"chart_tick_y{k}", f"{v:g}", (x0 - 0.03, g.point(0.0, v)[1]), anchor="center-right",
                    scale=0.8, visible=vis)
        for k, sv in enumerate((0.0, 0.5, 1.0)):
            n.label(f"chart_tick_s{k}", f"{sv:g}", (g.point(sv, g.lo)[0], y0 - 0.03), anchor="top-center",
                    scale=0.8, visible=vis)
        n.label("chart_s", "s = (θ − θb) / (θe − θb)", (x1, y0 - 0.1), anchor="top-right", scale=0.85, visible=vis)
        n.label("chart_title", "Bézier VHC [rad]: φ1 = q1 (blue), φ2 = q2 (orange), q3 follows (green, dashed). "
                               "Drag a control point.", (x0, y1 + 0.04), anchor="bottom-left", scale=0.85, visible=vis)

    def _points(self, g: ChartGeometry, a, b, selected) -> None:
        wanted = [("a", i) for i in range(len(a))] + [("b", i) for i in range(len(b))]
        if wanted != self._markers:
            self.nodes.clear("chart_point")
            for kind, i in wanted:
                handle = self.nodes.sphere(f"chart_point_{kind}{i}", (0.0, 0.0), self.point_radius, (0, 0, 0),
                                           visible=self.visible)
                self._bind(handle, kind, i)
            self._markers = wanted
        for kind, i in wanted:
            value = (a if kind == "a" else b)[i]
            x, y = g.point(i / (len(a if kind == "a" else b) - 1), value)
            handle = self.nodes.get(f"chart_point_{kind}{i}")
            if handle is None:
                continue
            color = SELECTED_COLOR if selected == (kind, i) else JOINT_COLORS[0 if kind == "a" else 1]
            handle.position = (float(x), float(y), 0.0)
            if tuple(handle.color) != tuple(color):
                handle.color = color

    def _bind(self, handle, kind: str, index: int) -> None:
        async def dragged(event):
            if self.geometry is None:
                return
            if event.phase == "start":
                self.frozen = True
            value = self.geometry.value(event.end_position[1])
            if event.phase == "end":
                self.frozen = False
            self.on_drag(kind, index, value, event.phase)

        async def clicked(_event):
            self.on_select(kind, index)

        handle.on_drag(dragged)
        handle.on_click(clicked)

    def set_visible(self, visible: bool) -> None:
        with self._lock:
            self.visible = bool(visible)
            for name in self.nodes.names():
                if name.startswith("chart_"):
                    handle = self.nodes.get(name)
                    if handle is not None:
                        handle.visible = self.visible

    def move_point(self, kind: str, index: int, count: int, value: float) -> None:
        """Move one control point's sphere at once (before the curves are recomputed)."""
        handle = self.nodes.get(f"chart_point_{kind}{index}")
        if handle is not None and self.geometry is not None:
            x, y = self.geometry.point(index / (count - 1), value)
            handle.position = (float(x), float(y), 0.0)
