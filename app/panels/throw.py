"""Throw studio: plan a throw of the three-link arm with a passive spring wrist by virtual
holonomic constraints (app/core/vhc.py), see at once whether it respects every limit, watch the
arm swing and the ball fly to its landing point, read the phase portrait, joint angles, speeds
and torques against their limits, load the thesis's throws and the optimized ones, run the
optimizer, and confirm a throw in the full 3-DOF dynamics.

Editing: the sliders of the Edit tab (psi, theta_b, theta_e, k, one control point at a time), the
control points as text, or dragging the control points of the Bezier chart drawn in the 3D view
below the ground (app/panels/throw_chart.py). Every change is solved off the event thread (one
pending computation at most); a throw that cannot be carried out (unreachable constraint, alpha
crossing zero, the arm stalling, bad numbers) is a notification and a red badge, and the last
throw that could be carried out stays on display.
"""
from __future__ import annotations

import dataclasses
import html
import math
import re
import threading
import time
from pathlib import Path
from typing import Dict, List, Optional

import numpy as np
import yaml

from app.core.errors import UserError
from app.core.expressions import ExpressionError, excerpt, parse_expression
from app.core.vhc import (DEFAULT_EVALUATIONS, REQUIRED_PARAMETERS, ThrowConfig, ThrowingArm, ThrowOptimizer, ThrowSpec,
                          elevate_bezier, load_throw_config, parse_throw_config, simulate_full)
from app.viewer import Coalescer, CommittedField, in_worker

from .throw_chart import BezierChart
from .throw_closed_loop import ClosedLoopTab
from .throw_plots import (BLOCK, ThrowView, angles_plot, badge_html, evaluate, feasibility_badge, phase_plot,
                          speeds_plot, summary_html, torques_plot, verification_html)
from .throw_scene import FOV, ThrowDrawing, throw_camera

TITLE = "Throw studio"
ORDER = 5                 # first tab of the throwing arm

#: the load buttons: label -> shipped throw file (app/throws)
THESIS_THROWS = {"Throw 1": "throw1", "Throw 2": "throw2", "Throw 3": "throw3"}
OPTIMIZED_THROWS = {"θ̇ along ψ (thesis)": "optimized_thesis", "true velocity J q̇": "optimized_physical"}
SHIPPED_THROWS = (*THESIS_THROWS.values(), *OPTIMIZED_THROWS.values())     # may come from the address
SPEEDS = {"1x (true speed)": 1.0, "0.5x": 0.5, "0.25x": 0.25, "0.1x": 0.1}
OBJECTIVES = {"thesis convention (θ̇ along ψ)": "thesis", "true ball velocity (J q̇)": "physical"}
FPS = 30.0
#: the Bezier chart's rectangle in the plane (x0, y0, width, height) [m], below the ground
CHART_RECT = (0.0, -1.6, 2.6, 1.05)
TYPING_PAUSE = 0.8        # seconds of quiet before typed control points are applied (or refused)


def available(robot) -> bool:
    """The studio needs the throwing arm's structure (what ``ThrowingArm`` checks)."""
    return (robot.n == 3 and tuple(robot.actuated) == (True, True, False) and "ball" in robot.points
            and all(p in robot.parameters for p in REQUIRED_PARAMETERS))


def build(session) -> None:
    old = session.state.get("throw", {}).get("studio")
    if old is not None:
        old.close()
    ThrowStudio(session)


def parse_points(text: str, name: str) -> List[float]:
    """Control points typed as numbers or constant expressions, separated by commas (or spaces).

    >>> [round(v, 6) for v in parse_points("1.7, pi/2, 1.3", "a")]
    [1.7, 1.570796, 1.3]
    >>> parse_points("1.7, x", "a")
    Traceback (most recent call last):
    ...
    app.core.errors.UserError: a: 'x' is not a number
    """
    text = (text or "").strip().strip("[]")
    parts = [p.strip() for p in (text.split(",") if "," in text else re.split(r"\s+", text)) if p.strip()]
    values = []
    for p in parts:
        try:
            v = float(parse_expression(p, allowed_names=()))
        except (ExpressionError, UserError, TypeError, ValueError, ZeroDivisionError):
            raise UserError(f"{name}: '{p}' is not a number") from None
        if not math.isfinite(v):
            raise UserError(f"{name}: '{p}' is not a finite number")
        values.append(v)
    if len(values) < 2:
        raise UserError(f"{name}: give at least two control points, separated by commas")
    return values


def format_points(values) -> str:
    """Control points as text for a field.

    >>> format_points([1.7, 1.5707963267948966])
    '1.7, 1.5708'
    """
    return ", ".join(f"{v:.5g}" for v in values)


def spec_values(spec: ThrowSpec) -> Dict[str, object]:
    """The editable numbers of a throw (psi in degrees)."""
    return {"theta_b": spec.theta_b, "theta_e": spec.theta_e, "psi_deg": spec.psi_deg, "k": spec.k,
            "theta_dot_b": spec.theta_dot_b, "a": list(spec.a), "b": list(spec.b), "branch": spec.branch}


def values_spec(values: Dict[str, object]) -> ThrowSpec:
    """A ThrowSpec from the editable numbers (UserError when they do not make a throw)."""
    return ThrowSpec(float(values["theta_b"]), float(values["theta_e"]), math.radians(float(values["psi_deg"])),
                     float(values["k"]), tuple(values["a"]), tuple(values["b"]), float(values["theta_dot_b"]),
                     int(values["branch"]))


def parse_stiffness(text: str) -> float:
    """The wrist spring's stiffness typed in the studio: a finite number >= 0 [N m/rad], written
    as a number or a constant expression.

    >>> parse_stiffness("1e9"), parse_stiffness("2*pi") > 6.28    # exact: 1e9 is a float exactly
    (1000000000.0, True)
    >>> parse_stiffness("-3")
    Traceback (most recent call last):
    ...
    app.core.errors.UserError: k: the wrist spring must not be negative (got -3)
    """
    try:
        value = float(parse_expression(text.strip(), allowed_names=()))
    except (ExpressionError, TypeError, ValueError):
        raise UserError(f"k: {excerpt(text)} is not a number") from None
    if not math.isfinite(value):
        raise UserError(f"k: expected a finite number, got {excerpt(text)}")
    if value < 0:
        raise UserError(f"k: the wrist spring must not be negative (got {value:g})")
    return value


def optimize_and_verify(robot, values, objective: str, seed: int, budget: int, progress):
    """The Optimize button's work: the optimizer's best throw, then its two full-dynamics
    simulations (progress 0-0.9, then 0.9-1). Returns the result without its arm, throw and
    feasibility (compiled functions that do not leave a worker process), and the simulations."""
    arm = ThrowingArm(robot, params=values)
    result = ThrowOptimizer(arm, objective=objective).run(seed=seed, evaluations=budget, progress=progress)
    sims = []
    for k, controller in enumerate(("feedforward", "computed_torque")):
        stage = f"full dynamics: {controller.replace('_', ' ')}"
        progress(0.9 + 0.05 * k, stage)
        sims.append(simulate_full(result.throw, controller,
                                  progress=lambda f, m, k=k, stage=stage: progress(0.9 + 0.05 * (k + f), stage)))
    return dataclasses.replace(result, throw=None, feasibility=None), sims



def verify_throw(robot, values, spec: ThrowSpec, progress) -> list:
    """The Verify button's work: the throw of ``spec`` simulated in the full dynamics under both
    controllers (progress 0-0.5, then 0.5-1)."""
    throw = ThrowingArm(robot, params=values).solve(spec)
    sims = []
    for k, controller in enumerate(("feedforward", "computed_torque")):
        stage = controller.replace("_", " ")
        progress(0.5 * k, stage)
        sims.append(simulate_full(throw, controller,
                                  progress=lambda f, m, k=k, stage=stage: progress(0.5 * (k + f), stage)))
    return sims


class ThrowStudio:
    """One tab's Throw studio: widgets, live solving, drawings, animation, optimizer."""

    shipped = SHIPPED_THROWS          # throws a page's address may name (``?throw=throw1``)

    def __init__(self, session):
        self.session = session
        self.gui = session.gui
        self.robot = session.robot
        self.generation = session.generation
        self.state = session.state.setdefault("throw", {})
        self.closed = False
        self.lock = threading.RLock()
        self.view: Optional[ThrowView] = None          # the last throw that could be carried out
        self.error: Optional[str] = None               # why the current values do not make a throw
        self._in_error = False                         # a notification was shown for the current problem
        self._arm: Optional[ThrowingArm] = None
        self._arm_key = None
        self._flags: set = set()
        self._typing_timers: Dict[str, threading.Timer] = {}
        self._anim = {"t": 0.0, "playing": False, "speed": 0.25}
        self._anim_lock = threading.Lock()
        self._thread: Optional[threading.Thread] = None
        self._optimizing = False
        self.shown = 0                                 # throws shown so far (tests, screenshots)
        self.answered = 0                              # throws solved so far, shown or refused
        self.selected = ("a", 0)
        self.nodes = session.scene.group("/throw")
        arm = self.arm()
        self.limits = arm.limits                       # the robot file's limits (Table A.2)
        self.drawing = ThrowDrawing(self.nodes, arm.shoulder_height)
        self.chart = BezierChart(self.nodes, CHART_RECT, self._chart_dragged, self._chart_selected)
        remembered = self.state.get("config")
        self.config: ThrowConfig = remembered if remembered is not None else load_throw_config("throw1")
        self.edited = bool(self.state.get("edited", False))
        self.values = dict(self.state.get("values") or spec_values(self.config.spec))
        self._params_seen = dict(session.params)
        self._job = Coalescer(self._compute, 0.02, self._internal_error)
        self._build()
        self.state["studio"] = self
        self._compute()               # the first throw is on the page when the tab appears
        session.on_parameters_change(self._parameters_changed)
        self._start_animation_thread()

    # ================================================================== widgets
    def _build(self) -> None:
        gui = self.gui
        gui.add_html(f'<div class="r2-label" style="font-size:0.8em;color:#444;{BLOCK}">A throw planned with virtual '
                     'holonomic constraints q1 = φ1(θ), q2 = φ2(θ) (Bézier curves); the spring wrist q3 follows. '
                     'Edit it in the Edit tab or drag the control points of the chart below the ground.</div>')
        self.badge = gui.add_html(badge_html("pending", "Solving the throw ..."))
        self.load_thesis = gui.add_button_group("Thesis", list(THESIS_THROWS),
                                                hint="the thesis's three throws (Tables 5.1-5.3)")
        self.load_optimized = gui.add_button_group("Optimized", list(OPTIMIZED_THROWS),
                                                   hint="the optimizer's best throws (seed 0), in each convention")
        self.info = gui.add_html("")
        self.play = gui.add_button_group("Throw", ("▶ Throw", "❚❚ Pause", "Frame the throw"),
                                         hint="play the throw: the arm swings, the ball flies and lands")
        self.speed = gui.add_dropdown("Speed", list(SPEEDS), initial_value="0.25x",
                                      hint="1x is the true speed (the swing lasts a few tenths of a second)")
        self.time = gui.add_slider("Time [s]", min=0.0, max=1.0, step=0.001, initial_value=0.0,
                                   hint="scrub through the swing and the flight")
        self.summary = gui.add_html("")
        tabs = gui.add_tab_group()
        with tabs.add_tab("Plots"):
            self.plots = {}
            for key, x_label, y_label in (("speeds", "t [s]", "|q̇| / limit"), ("torques", "t [s]", "τ [N m]"),
                                          ("phase", "θ [m]", "θ̇ [m/s]"), ("angles", "t [s]", "q [rad]")):
                legend = gui.add_html("")
                chart = gui.add_uplot(data=(np.array([0.0, 1.0]), np.array([0.0, 0.0])),
                                      series=({"label": "x"}, {"label": "y"}), aspect=1.45,
                                      legend={"show": False}, scales={"x": {"time": False}},
                                      axes=({"label": x_label, "size": 40, "ticks": {"show": False}},
                                            {"label": y_label, "size": 58, "ticks": {"show": False}}),
                                      cursor={"drag": {"x": True, "y": False}})
                self.plots[key] = (legend, chart)
        with tabs.add_tab("Edit"):
            self._build_editor()
        with tabs.add_tab("Optimize"):
            self._build_optimizer()
        with tabs.add_tab("Closed loop"):
            self.closed_loop = ClosedLoopTab(self)
        self.load_thesis.on_click(lambda e: self._guarded(self.load, THESIS_THROWS[e.target.value]))
        self.load_optimized.on_click(lambda e: self._guarded(self.load, OPTIMIZED_THROWS[e.target.value]))
        self.play.on_click(self._play_clicked)
        self.speed.on_update(lambda _e: self._set_speed())
        self.time.on_update(self._time_moved)

    def _build_editor(self) -> None:
        gui, v = self.gui, self.values
        reach = self.arm().l1 + self.arm().l2 + self.arm().l3
        self.psi = gui.add_slider("ψ [deg]", min=-30.0, max=90.0, step=0.01, initial_value=float(v["psi_deg"]),
                                  hint="rotation of the θ axis through the shoulder (the thesis's release angle)")
        self.theta_b = gui.add_slider("θb [m]", min=-round(reach, 3), max=round(reach, 3), step=0.0005,
                                      initial_value=float(v["theta_b"]), hint="θ at the start (s = 0)")
        self.theta_e = gui.add_slider("θe [m]", min=-round(reach, 3), max=round(reach, 3), step=0.0005,
                                      initial_value=float(v["theta_e"]), hint="θ at the release (s = 1)")
        self.k = CommittedField(
            gui.add_text("Spring k [N m/rad]", f"{float(v['k']):.6g}",
                         hint="stiffness of the wrist spring: a number or an expression (1e3, 2*pi); "
                              "taken when you stop typing"),
            parse_stiffness, self._stiffness_committed,
            lambda message: self.session.notify("Spring not changed", f"{message}; keeping k = {self.values['k']:.6g}",
                                                error=True),
            format=lambda value: f"{float(value):.6g}")
        self.theta_dot_b = gui.add_number("θ̇b [m/s]", float(v["theta_dot_b"]), min=0.0, max=20.0, step=0.01,
                                          hint="initial speed along θ (0: from rest)")
        for key, handle in (("psi_deg", self.psi), ("theta_b", self.theta_b), ("theta_e", self.theta_e),
                            ("theta_dot_b", self.theta_dot_b)):
            handle.on_update(lambda e, key=key: self._number_edited(key, e))
        gui.add_html(f'<div class="r2-label" style="font-size:0.8em;color:#555;margin-top:6px;{BLOCK}">Bézier control '
                     'points: pick one and slide it, type them all, or drag them in the chart of the 3D view.</div>')
        self.point = gui.add_dropdown("Control point", self._point_options(), initial_value=self._point_options()[0])
        self.point_value = gui.add_slider("Value [rad]", min=-2.1, max=3.7, step=0.001, initial_value=float(v["a"][0]))
        self.a_text = gui.add_text("φ1 points a [rad]", format_points(v["a"]),
                                   hint="control points of q1 = φ1(s), comma-separated (pi allowed)")
        self.b_text = gui.add_text("φ2 points b [rad]", format_points(v["b"]),
                                   hint="control points of q2 = φ2(s), comma-separated (pi allowed)")
        self.raise_degree = gui.add_button("Raise the degree", hint="the same curves with one more control point each")
        self.show_chart = gui.add_checkbox("Chart in the 3D view", True,
                                           hint="the Bézier curves below the ground, with draggable control points")
        self.point.on_update(lambda e: self._point_picked(e))
        self.point_value.on_update(self._point_slid)
        self.a_text.on_update(lambda e: self._points_typed("a", e))
        self.b_text.on_update(lambda e: self._points_typed("b", e))
        self.raise_degree.on_click(lambda _e: self._guarded(self._raise_degree))
        self.show_chart.on_update(lambda e: self._chart_toggled(e))
        self.download = self.gui.add_button("Download the throw (YAML)",
                                            hint="a throw file for `python -m app throw FILE --json`")
        self.upload = self.gui.add_upload_button("Open a throw file", mime_type=".yaml,.yml,.json",
                                                 hint="YAML or JSON with theta_b, theta_e, psi_deg, k, a, b")
        self.download.on_click(self._download)
        self.upload.on_upload(self._uploaded)
        self._sync_point_slider()

    def _build_optimizer(self) -> None:
        gui = self.gui
        gui.add_html(f'<div class="r2-label" style="font-size:0.8em;color:#444;{BLOCK}">Maximize the distance from the '
                     'base over the control points (degree 6), θb, θe, ψ and k under every limit of Table A.2 '
                     '(and q1 ≥ π/6 of eq. 4.5), then confirm the best throw in the full 3-DOF dynamics.</div>')
        self.objective = gui.add_dropdown("Objective", list(OBJECTIVES), initial_value=list(OBJECTIVES)[0],
                                          hint="which release velocity the distance uses")
        self.budget = gui.add_slider("Budget [evaluations]", min=2000, max=60000, step=1000,
                                     initial_value=DEFAULT_EVALUATIONS,
                                     hint="throw evaluations the search may spend (the same seed gives the same "
                                          "throw on any machine); it also stops near the speed-limit bound")
        self.seed = gui.add_number("Seed", 0, min=0, max=10 ** 6, step=1, hint="random start of the global stage")
        self.optimize_button = gui.add_button("Optimize", hint="run the optimizer (off the event thread)")
        self.opt_progress = gui.add_progress_bar(0.0, visible=False, animated=True)
        self.opt_status = gui.add_html("")
        self.verify_button = gui.add_button("Verify in full dynamics",
                                            hint="simulate the complete arm (wrist free) with the VHC torques "
                                                 "and with a tracking controller")
        self.verification = gui.add_html("")
        self.optimize_button.on_click(lambda _e: self._guarded(self.optimize))
        self.verify_button.on_click(lambda _e: self._guarded(self.verify))

    # ================================================================== helpers
    def _alive(self) -> bool:
        s = self.session
        return (not self.closed and not s.closed and s.generation == self.generation
                and self.state.get("studio") is self)

    def _guarded(self, fn, *args):
        try:
            return fn(*args)
        except UserError as exc:
            self.session.notify("Throw studio", str(exc), error=True)
        except Exception as exc:
            self._internal_error(exc)
        return None

    def _internal_error(self, exc) -> None:
        import traceback
        print(traceback.format_exc(), flush=True)
        self.session.notify("Internal error in the Throw studio", f"{type(exc).__name__}: {exc}", error=True)

    def arm(self) -> ThrowingArm:
        """The throwing arm with the tab's parameter values (rebuilt when they change)."""
        params = dict(self.session.params)
        key = tuple(sorted(params.items()))
        with self.lock:
            if self._arm is None or key != self._arm_key:
                self._arm = ThrowingArm(self.session.robot, params=params)
                self._arm_key = key
            return self._arm

    def _point_options(self) -> List[str]:
        a, b = self.values["a"], self.values["b"]
        return ([f"a{i}  (φ1 at s = {i / (len(a) - 1):.3g})" for i in range(len(a))]
                + [f"b{i}  (φ2 at s = {i / (len(b) - 1):.3g})" for i in range(len(b))])

    def _selected_label(self) -> str:
        kind, i = self.selected
        return next(o for o in self._point_options() if o.split()[0] == f"{kind}{i}")

    def _sync_point_slider(self) -> None:
        kind, i = self.selected
        lim = self.limits
        j = 0 if kind == "a" else 1
        lo, hi = float(lim["lower"][j]), float(lim["upper"][j])
        value = float(self.values[kind][i])
        self.point_value.min = math.floor(min(lo, value) * 1000) / 1000
        self.point_value.max = math.ceil(max(hi, value) * 1000) / 1000
        self.point_value.value = value

    def _sync_widgets(self) -> None:
        """Every editor widget from self.values (after a load, a drag, a typed list)."""
        v = self.values
        self.psi.value = float(v["psi_deg"])
        self.theta_b.value = float(v["theta_b"])
        self.theta_e.value = float(v["theta_e"])
        self.k.set(float(v["k"]))
        self.theta_dot_b.value = float(v["theta_dot_b"])
        self._sync_texts()
        options = self._point_options()
        kind, i = self.selected
        if i >= len(v[kind]):
            self.selected = (kind, len(v[kind]) - 1)
        if list(self.point.options) != options:
            self.point.options = options
        self.point.value = self._selected_label()
        self._sync_point_slider()

    def _sync_texts(self) -> None:
        for kind, field in (("a", self.a_text), ("b", self.b_text)):
            text = format_points(self.values[kind])
            try:
                same = parse_points(field.value, kind) == [float(f"{x:.5g}") for x in self.values[kind]]
            except UserError:
                same = False
            if not same:
                field.value = text

    def _remember(self) -> None:
        self.state.update(values=dict(self.values), config=self.config, edited=self.edited)

    # ================================================================== edits
    def _edited(self) -> None:
        """The user changed the throw: solve it again (coalesced, off the event thread)."""
        self.edited = True
        self._remember()
        self.request()

    def request(self, flags=()) -> None:
        with self.lock:
            self._flags |= set(flags)
        self._job.request()

    def _stiffness_committed(self, value: float) -> None:
        with self.lock:
            self.values["k"] = value
        self._edited()

    def _number_edited(self, key: str, event) -> None:
        if event.client is None:
            return
        with self.lock:
            self.values[key] = float(event.target.value)
        self._edited()

    def _point_picked(self, event) -> None:
        if event.client is None:
            return
        label = event.target.value.split()[0]
        self.selected = (label[0], int(label[1:]))
        self._sync_point_slider()
        self._redraw_chart()

    def _point_slid(self, event) -> None:
        if event.client is None:
            return
        kind, i = self.selected
        with self.lock:
            self.values[kind][i] = float(event.target.value)
        self._sync_texts()
        self.chart.move_point(kind, i, len(self.values[kind]), float(event.target.value))
        self._edited()

    def _points_typed(self, kind: str, event) -> None:
        """A control-point list is being typed (the browser sends every keystroke): it is applied once
        the typing pauses, so that half-typed lists are neither solved nor refused."""
        if event.client is None:
            return
        timer = self._typing_timers.pop(kind, None)
        if timer is not None:
            timer.cancel()
        timer = threading.Timer(TYPING_PAUSE, self._guarded, (self._apply_typed, kind, event.target))
        timer.daemon = True
        self._typing_timers[kind] = timer
        timer.start()

    def _apply_typed(self, kind: str, field) -> None:
        """Apply a typed list; a bad one is refused with a message and the last good list comes back."""
        if not self._alive():
            return
        try:
            values = parse_points(field.value, f"φ{1 if kind == 'a' else 2} points {kind}")
        except UserError as exc:
            field.value = format_points(self.values[kind])
            self.session.notify("Control points not changed", f"{exc}; keeping {format_points(self.values[kind])}",
                                error=True)
            return
        with self.lock:
            if values == self.values[kind]:
                return
            self.values[kind] = values
        options = self._point_options()
        sel_kind, i = self.selected
        if i >= len(self.values[sel_kind]):
            self.selected = (sel_kind, len(self.values[sel_kind]) - 1)
        if list(self.point.options) != options:
            self.point.options = options
            self.point.value = self._selected_label()
        self._sync_point_slider()
        self._edited()

    def _raise_degree(self) -> None:
        with self.lock:
            for kind in ("a", "b"):
                self.values[kind] = elevate_bezier(self.values[kind], len(self.values[kind]))
        self._sync_widgets()
        self._edited()

    def _chart_dragged(self, kind: str, index: int, value: float, phase: str) -> None:
        lim = self.limits
        j = 0 if kind == "a" else 1
        value = float(min(max(value, lim["lower"][j]), lim["upper"][j]))
        with self.lock:
            self.values[kind][index] = value
        if phase == "start" or self.selected != (kind, index):
            self.selected = (kind, index)
            self.point.value = self._selected_label()
            self._sync_point_slider()
        else:
            self.point_value.value = value
        self.chart.move_point(kind, index, len(self.values[kind]), value)
        self._sync_texts()
        self._edited()

    def _chart_selected(self, kind: str, index: int) -> None:
        self.selected = (kind, index)
        self.point.value = self._selected_label()
        self._sync_point_slider()
        self._redraw_chart()

    def _chart_toggled(self, event) -> None:
        self.chart.set_visible(bool(event.target.value))
        if self.view is not None:
            self.frame()

    def _parameters_changed(self, values) -> None:
        if not self._alive():
            return
        if values.get("k") != self._params_seen.get("k"):
            with self.lock:
                self.values["k"] = float(values["k"])
            self._sync_widgets()
        self._params_seen = dict(values)
        self.request()          # the model changed, not the throw

    # ================================================================== loading
    def load(self, name: str) -> None:
        """Load a shipped throw (``throw1``, ``optimized_thesis``, ...) or a throw file, then play it."""
        self.load_config(load_throw_config(name))
        if name in SHIPPED_THROWS:
            self.session.remember(throw=name)      # in the page's address

    def load_config(self, config: ThrowConfig, play: bool = True) -> None:
        if config.model:
            self.session.set_parameters(config.model)       # ParameterError (a UserError) when bad
        with self.lock:
            self.config = config
            self.edited = False
            self.values = spec_values(config.spec)
            self._params_seen = dict(self.session.params)
        self._sync_widgets()
        self._remember()
        self._stop()
        self.request({"frame", "play", "load"} if play else {"frame", "load"})

    # ================================================================== solving and showing
    def _compute(self) -> None:
        if not self._alive():
            return
        with self.lock:
            values = {k: (list(v) if isinstance(v, list) else v) for k, v in self.values.items()}
            flags, self._flags = self._flags, set()
        spec = None
        try:
            spec = values_spec(values)
            arm = self.arm()
            view = evaluate(arm, spec)
        except UserError as exc:
            self._show_problem(str(exc), values, spec, flags)
            self.answered += 1
            return
        if self._alive():
            self._show(view, values, flags)
        self.answered += 1

    def _q3_curve(self, spec: Optional[ThrowSpec]):
        """(s, q3(s)) with NaN where the constraint cannot be reached, or None."""
        if spec is None:
            return None
        s = np.linspace(0.0, 1.0, 121)
        with np.errstate(all="ignore"):
            st = self.arm().constraint(spec, spec.theta_b + s * (spec.theta_e - spec.theta_b), dynamics=False,
                                       strict=False)
        q3 = st.q[2, 0].copy()
        q3[np.abs(st.u[0]) > 1.0] = np.nan
        return s, q3

    def _redraw_chart(self, values=None, spec=None) -> None:
        values = values or self.values
        if spec is None:
            try:
                spec = values_spec(values)
            except UserError:
                spec = None
        self.chart.draw(values["a"], values["b"], self._q3_curve(spec), self.selected)

    def _show(self, view: ThrowView, values, flags) -> None:
        session = self.session
        with self.lock:
            self.view = view
            self.error = None
            self._in_error = False
        title = self._title()
        thesis = self.config.thesis if not self.edited else None
        self.badge.content = feasibility_badge(view.feasibility)
        self.info.content = title
        self.summary.content = summary_html(view, thesis)
        limits = view.throw.arm.limits
        for key, spec in (("phase", phase_plot(view)), ("speeds", speeds_plot(view, limits)),
                          ("torques", torques_plot(view, limits)), ("angles", angles_plot(view, limits))):
            legend, chart = self.plots[key]
            legend.content = spec.legend
            with session.atomic():      # series and data of a new shape arrive together
                if len(chart.series) != len(spec.series):
                    chart.series = spec.series
                chart.data = spec.data
                chart.bands = spec.bands
                chart.scales = spec.scales
        self._redraw_chart(values, view.spec)
        self.drawing.shoulder = np.array([0.0, view.throw.arm.shoulder_height])   # platform and l0 may change
        with session.atomic():
            self.drawing.show(view)
            for name, q in (("throw_start", view.samples.q[:, 0]), ("throw_release", view.samples.q[:, -1])):
                if self._owns_robot():
                    session.scene.ghost(q, name, color=(150, 150, 150), opacity=0.25)
        end = self.drawing.end_time()
        self.time.max = max(round(end + 0.0005, 3), 0.01)
        with self._anim_lock:
            playing = self._anim["playing"]
            self._anim["t"] = min(self._anim["t"], end)
        if not playing:
            self._show_time(0.0 if "play" in flags or not self._anim["t"] else self._anim["t"])
        if "frame" in flags:
            self.frame()
        if "play" in flags:
            self.start()
        self.shown += 1

    def _title(self) -> str:
        cfg = self.config
        title = cfg.title or Path(cfg.source).stem
        if self.edited:
            return f'<div style="font-size:0.82em;color:#444;{BLOCK}"><b>{html.escape(title)}</b>, edited</div>'
        return (f'<div style="font-size:0.8em;color:#444;{BLOCK}"><b>{html.escape(title)}</b>'
                f'<div style="color:#666;font-size:0.92em;line-height:1.3">{html.escape(cfg.notes)}</div></div>')

    def _show_problem(self, message: str, values, spec, flags=()) -> None:
        """The values make no throw: red badge with the reason, a notification when the throw
        turns bad (not again for every step of a drag that stays bad, but for every load)."""
        with self.lock:
            notify = not self._in_error or "load" in flags
            self.error = message
            self._in_error = True
            shown = self.view is not None
        self.badge.content = badge_html(
            "error", "This throw cannot be carried out", [message],
            note="The plots and the 3D view keep the last throw that could be carried out." if shown else "")
        self._redraw_chart(values, spec)
        if notify:
            self.session.notify("The throw cannot be carried out", message, error=True)

    # ================================================================== camera and animation
    def frame(self) -> None:
        """Point the camera at the whole throw (and the chart below the ground when shown)."""
        if self.view is None:
            return
        region = self.drawing.region((0.0 - self.chart.bottom + 0.1) if self.chart.visible else 0.0)

        def pose(width: int, height: int):
            return (FOV, *throw_camera(region, width, height))

        self.session.scene.point_camera(pose)

    def start(self) -> None:
        """Play the throw from the start."""
        with self._anim_lock:
            self._anim.update(t=0.0, playing=True)

    def _stop(self) -> None:
        with self._anim_lock:
            self._anim["playing"] = False

    def show_time(self, t: float) -> None:
        """Stop the animation and show time t (the swing, then the flight)."""
        self._stop()
        with self._anim_lock:
            self._anim["t"] = float(t)
        self.time.value = float(min(t, self.time.max))
        self._show_time(float(t))

    def _show_time(self, t: float) -> None:
        with self.session.atomic():
            q = self.drawing.at(t)
            if q is not None:
                self._pose(q, sliders=t <= 0.0)

    def _owns_robot(self) -> bool:
        """Whether the tab still shows this studio's robot (checked right before touching it: the
        user may switch the robot while a throw is solved or played)."""
        drawing = self.session.scene.drawing
        return self._alive() and drawing is not None and drawing.robot is self.robot

    def _pose(self, q, sliders: bool = False) -> None:
        """The robot at q; with ``sliders`` the joint sliders follow (at the throw's start)."""
        if not self._owns_robot():
            return
        if sliders and not np.array_equal(np.asarray(q, float), self.session.q):
            self.session.set_q(q)           # other panels follow q: only when it changes
        else:
            self.session.scene.set_pose(q)

    def _play_clicked(self, event) -> None:
        value = event.target.value
        if value.startswith("▶"):
            with self._anim_lock:
                if self._anim["t"] >= self.drawing.end_time() - 1e-9:
                    self._anim["t"] = 0.0
                self._anim["playing"] = True
        elif value.startswith("❚❚"):
            self._stop()
        else:
            self.frame()

    def _set_speed(self) -> None:
        with self._anim_lock:
            self._anim["speed"] = SPEEDS[self.speed.value]

    def _time_moved(self, event) -> None:
        if event.client is None:
            return
        with self._anim_lock:
            self._anim.update(t=float(event.target.value), playing=False)
        self._show_time(float(event.target.value))

    def _start_animation_thread(self) -> None:
        self._set_speed()
        self._thread = threading.Thread(target=self._animate, daemon=True,
                                        name=f"throw-anim-{self.session.tab_id}")
        self._thread.start()

    def _animate(self) -> None:
        """Plays the throw while the studio lives; when the robot is switched away (this panel's
        listeners are dropped then), it removes the studio's drawings."""
        try:
            self._animation_loop()
        finally:
            if not self.closed and not self.session.closed:
                self.close()

    def _animation_loop(self) -> None:
        last = time.monotonic()
        while self._alive():
            time.sleep(1.0 / FPS)
            now = time.monotonic()
            with self._anim_lock:
                playing = self._anim["playing"]
                if playing:
                    end = self.drawing.end_time()
                    t = min(end, self._anim["t"] + (now - last) * self._anim["speed"])
                    self._anim["t"] = t
                    if t >= end:
                        self._anim["playing"] = False
            last = now
            if playing:
                try:
                    self.time.value = float(min(t, self.time.max))
                    with self.session.atomic():
                        q = self.drawing.at(t)
                        if q is not None:
                            self._pose(q)
                except Exception:      # widgets or nodes removed by a rebuild: stop quietly
                    return

    # ================================================================== optimizer and verification
    def optimize(self, wait: bool = False):
        """Run the optimizer with the Optimize tab's settings, then verify the best throw in the full
        dynamics and load it (in the background; ``wait`` blocks until done)."""
        if self._optimizing:
            raise UserError("the optimizer is already running")
        objective = OBJECTIVES[self.objective.value]
        budget = int(self.budget.value)
        seed = int(self.seed.value)
        arm = self.arm()
        self._optimizing = True
        self.optimize_button.disabled = True
        self.opt_progress.value = 0.0
        self.opt_progress.visible = True
        self.opt_status.content = self._status("starting ...")
        started = time.monotonic()
        shown = {"fraction": 0.0, "message": "starting"}
        done_event = threading.Event()

        def tick():     # the bar also advances with the clock between the optimizer's reports
            while not done_event.wait(0.5):
                if not self._alive():
                    return
                clock = min(0.85, 0.85 * (time.monotonic() - started) / (budget / 2000.0))
                if clock > shown["fraction"] and shown["fraction"] < 0.85:
                    self.opt_progress.value = 100 * clock

        def work(progress):
            def report(fraction, message):
                shown.update(fraction=0.85 * fraction, message=message)
                progress(0.85 * fraction, message)
                if self._alive():
                    self.opt_progress.value = max(self.opt_progress.value, 100 * 0.85 * fraction)
                    self.opt_status.content = self._status(message)
            threading.Thread(target=tick, daemon=True).start()
            try:       # in a worker process of the server (app/viewer/worker.py)
                return in_worker(optimize_and_verify, arm.robot, arm.values, objective, seed, budget, progress=report)
            finally:
                done_event.set()
                self._optimizing = False
                if self._alive():
                    self.optimize_button.disabled = False
                    self.opt_progress.visible = False

        def done(out):
            result, sims = out
            convention = "θ̇ along ψ" if result.objective == "thesis" else "J q̇"
            title = f"Optimized throw, {convention}, seed {seed}"
            notes = (f"{result.distance_from_base:.4f} m from the base ({convention}) after {result.elapsed:.1f} s, "
                     f"{result.evaluations} throw evaluations; the speed limits alone allow "
                     f"{result.bound.distance_from_base:.4f} m.")
            self.opt_status.content = self._status(notes, done=True)
            self.load_config(ThrowConfig(result.spec, {}, title, notes, {}, "optimizer"))
            self._show_verification(sims, result.spec)

        return self.background(work, "Optimizing the throw", self.opt_status, done, wait)

    def verify(self, wait: bool = False):
        """Simulate the current throw in the full dynamics (both controllers) and show the drifts."""
        view = self.view
        if view is None or self.error:
            raise UserError("there is no throw to verify: " + (self.error or "none solved yet"))
        self.verify_button.disabled = True
        self.verification.content = self._status("simulating the full arm ...")

        arm = view.throw.arm

        def work(progress):
            try:       # in a worker process of the server (app/viewer/worker.py)
                return in_worker(verify_throw, arm.robot, arm.values, view.spec, progress=progress)
            finally:
                if self._alive():
                    self.verify_button.disabled = False

        return self.background(work, "Full-dynamics simulation", self.verification,
                               lambda sims: self._show_verification(sims, view.spec), wait)

    def background(self, work, title: str, status, on_done, wait: bool = False):
        """Run ``work(progress)`` off the event thread under a progress bar titled ``title``, then
        ``on_done(result)`` while the studio lives; a Cancel says so in ``status`` (an HTML widget,
        or None). With ``wait`` it returns when the job has ended (tests, pictures)."""
        def done(result):
            if self._alive():
                on_done(result)

        def cancelled():
            if self._alive() and status is not None:
                status.content = self._status("cancelled")

        future = self.session.run_in_background(work, title, on_done=done, on_cancel=cancelled)
        if wait:
            future.result()
        return future

    def _show_verification(self, sims, spec: ThrowSpec) -> None:
        if not self._alive():
            return
        view = self.view
        if view is None or view.spec != spec:
            try:
                view = evaluate(self.arm(), spec)
            except UserError:
                return
        self.verification.content = verification_html(sims, view)

    @staticmethod
    def _status(text: str, done: bool = False) -> str:
        color = "#1e7b34" if done else "#333"
        return f'<div class="r2-label" style="font-size:0.8em;color:{color};{BLOCK}">{html.escape(text)}</div>'

    # ================================================================== files
    def _download(self, event) -> None:
        try:
            spec = values_spec(self.values)
        except UserError as exc:
            self.session.notify("Nothing to download", str(exc), error=True)
            return
        data = {"title": self._plain_title(), **spec.to_config()}
        event.client.send_file_download("throw.yaml", yaml.safe_dump(data, sort_keys=False).encode("utf-8"),
                                         save_immediately=True)

    def _plain_title(self) -> str:
        title = self.config.title or "Throw"
        return f"{title} (edited)" if self.edited else title

    def _uploaded(self, event) -> None:
        upload = event.target.value
        try:
            try:
                data = yaml.safe_load(upload.content.decode("utf-8"))
            except (yaml.YAMLError, UnicodeDecodeError) as exc:
                raise UserError(f"{upload.name}: not valid YAML/JSON: {exc}") from None
            self.load_config(parse_throw_config(data, upload.name))
        except UserError as exc:
            self.session.notify("Cannot open the throw file", str(exc), error=True)

    # ================================================================== teardown
    def close(self) -> None:
        """Stop the animation and remove the studio's drawings (robot switched, panel rebuilt)."""
        self.closed = True
        for timer in self._typing_timers.values():
            timer.cancel()
        self.nodes.clear()
        for ghost in ("throw_start", "throw_release"):
            self.session.scene.remove_ghost(ghost)
