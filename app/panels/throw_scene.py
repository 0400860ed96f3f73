"""The Throw studio's drawings in the 3D view: the ground with a distance ruler, the theta axis,
the ball's path during the swing, both flights (true velocity and the thesis's convention) with
their landing markers and distances, velocity arrows at the release, and the ball itself; and
a camera that frames the whole throw beside the side panel.

Everything lives under one scene node root per tab (a ``SceneGroup`` of the tab's scene view), so
that the studio can remove exactly what it drew when the robot changes.
"""
from __future__ import annotations

import itertools
import math
from typing import Optional, Tuple

import numpy as np

from app.core.throw.study import ThrowView, ball_at
from app.viewer import SceneGroup

from .throw_plots import FLIGHTS

SIDE_PANEL_PX = 400            # the side panel floats over the right of the canvas
FOV = math.radians(28.0)       # as the viewer's planar framing: little perspective
BALL_COLOR = (214, 39, 40)
GROUND_COLOR = (90, 96, 108)
AXIS_COLOR = (120, 150, 200)
SWING_COLOR = (23, 150, 160)


# ====================================================================== camera
def throw_camera(region: Tuple[float, float, float, float], width: int, height: int, fov: float = FOV,
                 fill: float = 0.93, side_panel: int = SIDE_PANEL_PX):
    """(position, look_at, up) of a camera square-on to the plane z = 0 that shows the rectangle
    ``region`` = (x_min, x_max, y_min, y_max) [m] in the part of the canvas not covered by the side
    panel.

    >>> pos, look, up = throw_camera((-1.0, 3.0, -1.0, 2.0), 1280, 720)
    >>> bool(pos[2] > 0 and look[0] > 1.0 and abs(pos[1] - 0.5) < 1e-12), up.tolist()     # exact: up is set
    (True, [0.0, 1.0, 0.0])
    """
    x0, x1, y0, y1 = region
    aspect = width / height if height > 0 else 16 / 9
    occluded = side_panel / width if width > 2.2 * side_panel else 0.0
    tan = math.tan(fov / 2)
    visible_aspect = aspect * (1.0 - occluded)
    distance = max((y1 - y0) / 2 / tan, (x1 - x0) / 2 / (tan * visible_aspect)) / fill
    center = np.array([(x0 + x1) / 2, (y0 + y1) / 2, 0.0])
    # the screen's centre sits right of the region's so that the region is centred in the visible part
    look_at = center + np.array([occluded * distance * tan * aspect, 0.0, 0.0])
    return look_at + np.array([0.0, 0.0, distance]), look_at, np.array([0.0, 1.0, 0.0])


MAX_GROUND = 1e6        # metres of ground drawn at most (a spring of 1e9 N m/rad throws very far)


def ground_ticks(x_to: float, most: int = 40) -> Tuple[float, int]:
    """(tick spacing [m], label every that many ticks) for a ground line to x_to metres: 0.5 m
    and a label every metre on a short ground, coarser (1-2-5 steps) so that at most ``most``
    ticks are drawn on a long one.

    >>> ground_ticks(3.0), ground_ticks(50.0), ground_ticks(1e8)     # exact: 1-2-5 steps
    ((0.5, 2), (2.0, 5), (5000000.0, 2))
    """
    for exponent in itertools.count(-1):
        for mantissa in (1, 2, 5):
            step = mantissa * 10.0 ** exponent
            if step >= 0.5 and x_to / step <= most:
                return step, 5 if mantissa == 2 else 2


# ====================================================================== the throw
class ThrowDrawing:
    """The throw's overlays (see the module docstring); ``show(view)`` draws a throw, ``at(t)``
    places the ball (and returns the arm's angles) at time t of the animation."""

    def __init__(self, nodes: SceneGroup, shoulder_height: float, ball_radius: float = 0.035):
        self.nodes = nodes
        self.shoulder = np.array([0.0, shoulder_height])
        self.ball_radius = ball_radius
        self.view: Optional[ThrowView] = None
        self._ground_to: Optional[float] = None

    def ground(self, x_to: float) -> None:
        """The ground line y = 0 from behind the base to x_to, with ticks and labels every
        ``ground_ticks(x_to)`` metres (a few dozen at most, however far the ball flies)."""
        x_to = max(2.0, math.ceil(min(x_to, MAX_GROUND) * 2) / 2 + 0.5) if math.isfinite(x_to) else MAX_GROUND
        if self._ground_to == x_to:
            return
        self._ground_to = x_to
        n = self.nodes
        n.segments("ground", [[[-1.0, 0.0], [x_to, 0.0]]], GROUND_COLOR, 2.5)
        step, every = ground_ticks(x_to)
        ticks = step * np.arange(1, int((x_to - 0.5 * step) / step) + 1)
        labelled = np.arange(1, ticks.size + 1) % every == 0
        n.segments("ground_ticks", [[[x, 0.0], [x, -0.05 if big else -0.03]] for x, big in zip(ticks, labelled)],
                   GROUND_COLOR, 1.5)
        n.clear("ground_label")
        for k, x in enumerate(ticks[labelled]):
            n.label(f"ground_label{k}", f"{x:g} m", (x, -0.07), anchor="top-center", scale=0.9)

    def show(self, view: ThrowView) -> None:
        """Draw a throw: theta axis, swing path, flights, landing markers and labels, release arrows."""
        self.view = view
        n, spec, rel = self.nodes, view.spec, view.release
        lands = {k: f.landing_x for k, f in view.flights.items()}
        self.ground(max(lands.values()))
        u = np.array([math.cos(spec.psi), math.sin(spec.psi)])
        n.polyline("theta_axis", [self.shoulder + spec.theta_b * u, self.shoulder + spec.theta_e * u],
                   AXIS_COLOR, 1.5, dashed=False)
        n.label("theta_axis_label", f"θ axis, ψ = {spec.psi_deg:.1f}°", self.shoulder + (spec.theta_e + 0.03) * u,
                anchor="center-left", scale=0.85)
        n.polyline("swing", view.samples.ball.T, SWING_COLOR, 2.0)
        for key, flight in view.flights.items():
            _label, color = FLIGHTS[key]
            n.polyline(f"flight_{key}", flight.path(120), color, 2.5 if key == "true" else 2.0, dashed=key != "true")
            n.sphere(f"land_{key}", (lands[key], 0.0), 0.03, color)
            n.arrow(f"velocity_{key}", rel.position, 0.12 * np.asarray(flight.velocity), color, 0.011)
        true_x, thesis_x = lands["true"], lands["thesis"]
        # the labels stacked above their markers, the farther one higher, so that they never overlap
        high, low = ("true", "thesis") if true_x >= thesis_x else ("thesis", "true")
        texts = {"true": f"J q̇: {rel.distance_from_base:.3f} m from the base, {rel.distance_from_release:.3f} m "
                         f"from the release",
                 "thesis": f"θ̇ along ψ (thesis): {rel.distance_from_base_thesis:.3f} m from the base, "
                           f"{rel.distance_from_release_thesis:.3f} m from the release"}
        for key, height in ((high, 0.36), (low, 0.2)):
            x = lands[key]
            n.segments(f"land_{key}_stem", [[[x, 0.03], [x, height - 0.01]]], FLIGHTS[key][1], 1.2)
            n.label(f"land_{key}_label", texts[key], (x, height), anchor="bottom-right", scale=0.9)
        self.at(0.0)

    def at(self, t: float) -> Optional[np.ndarray]:
        """Put the ball where it is at time t; returns the arm's joint angles then (None without a throw)."""
        if self.view is None:
            return None
        q, ball = ball_at(self.view, t)
        handle = self.nodes.get("ball")
        if handle is None:
            self.nodes.sphere("ball", ball, self.ball_radius, BALL_COLOR)
        else:
            handle.position = (float(ball[0]), float(ball[1]), 0.0)
        return q

    def end_time(self) -> float:
        return self.view.duration + self.view.flight_time("true") if self.view else 0.0

    def region(self, extra_below: float = 0.0) -> Tuple[float, float, float, float]:
        """The rectangle the camera should show: base, arm, both flights and the landing labels."""
        view = self.view
        x_hi = max([f.landing_x for f in view.flights.values()] + [1.5]) + 0.35
        apex = max(float(np.max(f.path(60)[:, 1])) for f in view.flights.values())
        y_hi = max(apex, float(self.shoulder[1]) + 1.05) + 0.3
        return -1.0, x_hi, -0.3 - extra_below, y_hi

