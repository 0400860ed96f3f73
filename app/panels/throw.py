"""Throw studio: plan a throw of the three-link arm with a passive spring wrist by virtual
holonomic constraints (app/core/throw/), see at once whether it respects every limit, watch the
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

import html
import threading
import time
from pathlib import Path
from typing import Optional

import numpy as np
import yaml

from app.core.errors import UserError
from app.core.throw.arm import ThrowingArm, has_throwing_structure
from app.core.throw.config import ThrowConfig, ThrowSpec, load_throw_config, parse_throw_config
from app.core.throw.study import ThrowDraft, ThrowStudy, ThrowView, wrist_curve
from app.viewer import Coalescer

from .throw_chart import BezierChart
from .throw_closed_loop import ClosedLoopTab
from .throw_edit import EditTab
from .throw_optimize import OptimizeTab
from .throw_plots import (BLOCK, angles_plot, badge_html, feasibility_badge, phase_plot, speeds_plot, status_html,
                          summary_html, torques_plot)
from .throw_scene import FOV, ThrowDrawing, throw_camera

TITLE = "Throw studio"
ORDER = 5                 # first tab of the throwing arm

#: the load buttons: label -> shipped throw file (app/throws)
THESIS_THROWS = {"Throw 1": "throw1", "Throw 2": "throw2", "Throw 3": "throw3"}
OPTIMIZED_THROWS = {"θ̇ along ψ (thesis)": "optimized_thesis", "true velocity J q̇": "optimized_physical"}
SHIPPED_THROWS = (*THESIS_THROWS.values(), *OPTIMIZED_THROWS.values())     # may come from the address
SPEEDS = {"1x (true speed)": 1.0, "0.5x": 0.5, "0.25x": 0.25, "0.1x": 0.1}
FPS = 30.0
#: the Bezier chart's rectangle in the plane (x0, y0, width, height) [m], below the ground
CHART_RECT = (0.0, -1.6, 2.6, 1.05)


def available(robot) -> bool:
    """The studio needs the throwing arm's structure (what ``ThrowingArm`` checks)."""
    return has_throwing_structure(robot)


def build(session) -> None:
    old = session.state.get("throw", {}).get("studio")
    if old is not None:
        old.close()
    ThrowStudio(session)


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
        self.study = ThrowStudy(session.robot)         # the arm at the tab's parameter values
        self._flags: set = set()
        self._anim = {"t": 0.0, "playing": False, "speed": 0.25}
        self._anim_lock = threading.Lock()
        self._thread: Optional[threading.Thread] = None
        self.shown = 0                                 # throws shown so far (tests, screenshots)
        self.answered = 0                              # throws solved so far, shown or refused
        self.nodes = session.scene.group("/throw")
        arm = self.arm()
        self.limits = arm.limits                       # the robot file's limits (Table A.2)
        self.drawing = ThrowDrawing(self.nodes, arm.shoulder_height)
        self.chart = BezierChart(self.nodes, CHART_RECT, lambda *a: self.editor.chart_dragged(*a),
                                 lambda *a: self.editor.chart_selected(*a))
        remembered = self.state.get("config")
        self.config: ThrowConfig = remembered if remembered is not None else load_throw_config("throw1")
        self.edited = bool(self.state.get("edited", False))
        remembered = self.state.get("draft")
        self.draft: ThrowDraft = remembered.copy() if remembered is not None else ThrowDraft.of(self.config.spec)
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
            self.editor = EditTab(self)
        with tabs.add_tab("Optimize"):
            self.optimizer = OptimizeTab(self)
        with tabs.add_tab("Closed loop"):
            self.closed_loop = ClosedLoopTab(self)
        self.load_thesis.on_click(lambda e: self._guarded(self.load, THESIS_THROWS[e.target.value]))
        self.load_optimized.on_click(lambda e: self._guarded(self.load, OPTIMIZED_THROWS[e.target.value]))
        self.play.on_click(self._play_clicked)
        self.speed.on_update(lambda _e: self._set_speed())
        self.time.on_update(self._time_moved)

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
        return self.study.arm(self.session.params)

    def evaluate(self, spec: ThrowSpec) -> ThrowView:
        """A throw solved on the tab's arm with everything the studio shows (UserError when it cannot be)."""
        return self.study.view(spec, self.session.params)

    def _remember(self) -> None:
        self.state.update(draft=self.draft.copy(), config=self.config, edited=self.edited)

    # ================================================================== edits
    def draft_changed(self) -> None:
        """The user changed the throw: solve it again (coalesced, off the event thread)."""
        self.edited = True
        self._remember()
        self.request()

    def request(self, flags=()) -> None:
        with self.lock:
            self._flags |= set(flags)
        self._job.request()

    def _parameters_changed(self, values) -> None:
        if not self._alive():
            return
        if values.get("k") != self._params_seen.get("k"):
            with self.lock:
                self.draft.k = float(values["k"])
            self.editor.sync()
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
            self.draft = ThrowDraft.of(config.spec)
            self._params_seen = dict(self.session.params)
        self.editor.sync()
        self._remember()
        self._stop()
        self.request({"frame", "play", "load"} if play else {"frame", "load"})

    # ================================================================== solving and showing
    def _compute(self) -> None:
        if not self._alive():
            return
        with self.lock:
            draft = self.draft.copy()
            flags, self._flags = self._flags, set()
        spec = None
        try:
            spec = draft.spec()
            view = self.study.view(spec, self.session.params)
        except UserError as exc:
            self._show_problem(str(exc), draft, spec, flags)
            self.answered += 1
            return
        if self._alive():
            self._show(view, draft, flags)
        self.answered += 1

    def redraw_chart(self, draft: Optional[ThrowDraft] = None, spec: Optional[ThrowSpec] = None) -> None:
        """The Bezier chart of ``draft`` (default: the one edited) with the wrist's curve when it makes a throw."""
        draft = draft or self.draft
        if spec is None:
            try:
                spec = draft.spec()
            except UserError:
                spec = None
        curve = wrist_curve(self.arm(), spec) if spec is not None else None
        self.chart.draw(draft.a, draft.b, curve, self.editor.selected)

    def _show(self, view: ThrowView, draft: ThrowDraft, flags) -> None:
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
        self.redraw_chart(draft, view.spec)
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

    def _show_problem(self, message: str, draft: ThrowDraft, spec, flags=()) -> None:
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
        self.redraw_chart(draft, spec)
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

    # ================================================================== background jobs
    def background(self, work, title: str, status, on_done, wait: bool = False):
        """Run ``work(progress)`` off the event thread under a progress bar titled ``title``, then
        ``on_done(result)`` while the studio lives; a Cancel says so in ``status`` (an HTML widget,
        or None). With ``wait`` it returns when the job has ended (tests, pictures)."""
        def done(result):
            if self._alive():
                on_done(result)

        def cancelled():
            if self._alive() and status is not None:
                status.content = status_html("cancelled")

        future = self.session.run_in_background(work, title, on_done=done, on_cancel=cancelled)
        if wait:
            future.result()
        return future

    # ================================================================== files
    def _download(self, event) -> None:
        try:
            spec = self.draft.spec()
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
        self.editor.close()
        self.nodes.clear()
        for ghost in ("throw_start", "throw_release"):
            self.session.scene.remove_ghost(ghost)
