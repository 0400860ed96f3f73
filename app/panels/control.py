"""Control panel: pick a controller of the course (its law typeset as in the exams), a reference
and gains, run it in closed loop from the sliders' configuration (app/core/sim.py), then replay
the motion in 3D with the reference as a ghost, and read the plots of errors, torques and the
controller's internals (estimates, residuals, forces; their series and the PNG in
app/panels/control_plots.py). CSV and PNG downloads."""
from __future__ import annotations

import html
import threading
import time
from typing import Dict, List, Optional

import numpy as np

from app.core.control import CONTROLLERS, coefficient_values
from app.core.errors import UserError
from app.core.plot_series import base_title, index_at, merge_runs, value_range, with_time_marker
from app.core.sim import SimResult, simulate
from app.core.sim_input import parse_assignments, parse_contact, parse_numbers
from app.core.trajectories import REFERENCE_KINDS
from app.viewer import in_worker, mathml

from .control_plots import COLORS, decade, plot_groups, plot_indices, plots_png

TITLE = "Control"
ORDER = 40

#: controllers in the order of the course
ORDER_OF_CONTROLLERS = ["pd", "pd_gravity", "pd_gravity_const", "computed_torque", "robust", "adaptive",
                        "learning", "pfl_collocated", "pfl_noncollocated", "elastic_pd", "elastic_pd_online", "impedance",
                        "admittance", "hybrid"]
HOLD = "hold the start"
#: reference templates per kind: (joint space, task space); "by" is a displacement from the start
TEMPLATES = {
    HOLD: ("", ""),
    "setpoint": ("by=0.5", "by=0.1"),
    "cubic": ("by=0.8 T=2", "by=0.2 T=2"),
    "quintic": ("by=0.8 T=2", "by=0.2 T=2"),
    "bangbang": ("by=0.8 amax=2", "by=0.2 amax=0.5"),
    "trapezoidal": ("by=0.8 vmax=0.8 amax=2", "by=0.2 vmax=0.2 amax=0.5"),
    "sine": ("amplitude=0.4 f=0.5", "amplitude=0.05 f=0.5"),
}
SPEEDS = {"0.1x": 0.1, "0.25x": 0.25, "0.5x": 0.5, "1x": 1.0, "2x": 2.0}
FPS = 30.0
#: the plots' time marker is redrawn at most this often (each redraw sends the plots' data)
MARKER_INTERVAL = 0.2
#: runs this short (simulated seconds) re-run by themselves when a field of the controller changes
AUTO_RERUN_MAX = 2.0
#: seconds without a further change before such a re-run starts
AUTO_RERUN_DELAY = 0.6


def controllers_for(robot) -> List[str]:
    """Controllers offered for a robot: elastic-joint control only for robots with motors."""
    names = [n for n in ORDER_OF_CONTROLLERS if n in CONTROLLERS]
    names += sorted(n for n in CONTROLLERS if n not in names)
    if not robot.motor_inertias:
        names = [n for n in names if not n.startswith("elastic")]
    return names


def default_controller(robot) -> str:
    if robot.motor_inertias:
        return "elastic_pd"
    if not all(robot.actuated):
        return "pfl_collocated"
    return "computed_torque"


def runs_as_is(name: str, robot) -> bool:
    """Whether a controller runs on the robot with the panel's default fields (the robot's own
    passive joints): a law that needs every joint actuated does not on an underactuated robot, nor
    does a rigid-robot law on a robot with motor coordinates.

    >>> from app.core.robot import load_robot
    >>> runs_as_is("computed_torque", load_robot("elastic_2r")), runs_as_is("elastic_pd", load_robot("elastic_2r"))
    (False, True)
    """
    if robot.motor_inertias and not name.startswith("elastic"):
        return False
    return all(robot.actuated) or not CONTROLLERS[name].needs_full_actuation


# ====================================================================== the panel
def build(session) -> None:
    ControlPanel(session)


class ControlPanel:
    """The widgets and the replay of one tab's Control panel."""

    def __init__(self, session):
        session.scene.remove_ghost("control_ref")      # a previous robot's reference
        self.session = session
        self.gui = session.gui
        self.robot = session.robot
        self.generation = session.generation
        self.state = session.state.setdefault("control", {})
        self.result: Optional[SimResult] = None
        self._runs = 0                   # runs started or cleared: a run shows only if still the last
        self.true_coefficients = None
        self._replay = {"t": 0.0, "playing": False, "speed": 1.0}
        self._replay_lock = threading.Lock()
        self._wake = threading.Event()           # set when the replay should run
        self._result_widgets: List = []
        self._plots: List = []
        self._overlays = set()           # names of this panel's scene overlays
        self._force_scale = 0.0
        self._plot_data: List[Dict] = []   # per plot: handle, x, columns, marker span
        self._marker = {"t": 0.0, "last": 0.0, "timer": None}
        self._marker_lock = threading.Lock()
        self._rerun_timer: Optional[threading.Timer] = None
        self._has_run = False
        self._build()
        self.state["panel"] = self

    # -------------------------------------------------------------- widgets
    def _build(self) -> None:
        gui, robot = self.gui, self.robot
        gui.add_html(mathml.label_html(
            "Run a control law in closed loop from the sliders' configuration, with the parameter "
            "values above as the real robot; then replay it and read the plots."))
        names = controllers_for(robot)
        self._names = names
        self._titles = {CONTROLLERS[n].title: n for n in names}
        chosen = self.state.get("controller")       # the last choice, if it runs on this robot
        if chosen not in names or not runs_as_is(chosen, robot):
            chosen = default_controller(robot)
        self.controller = gui.add_dropdown("Controller", list(self._titles), initial_value=CONTROLLERS[chosen].title,
                                           hint="The control laws of the course")
        self.law = gui.add_html("")
        self.gains = gui.add_text("Gains", "", hint="name=value, comma-separated: Kp=100 (all joints), Kp2=50 "
                                                    "(joint 2 only); empty: the defaults listed above")
        kinds = [HOLD] + list(REFERENCE_KINDS)
        self.ref_kind = gui.add_dropdown("Reference", kinds, initial_value=self.state.get("ref_kind", "quintic"),
                                         hint="q_d(t) (or p_d(t) for Cartesian controllers)")
        self.ref_params = gui.add_text("Reference values", "", hint="key=value separated by spaces; vectors "
                                       "comma-separated, one value per coordinate or one for all; by= is a "
                                       "displacement from the start, goal= an absolute value; pi allowed")
        self.ref_help = gui.add_html("")
        with gui.add_folder("Simulation settings", expand_by_default=False):
            self.duration = gui.add_number("Duration [s]", float(self.state.get("duration", 4.0)), min=0.01,
                                           max=120.0, step=0.5)
            self.rate = gui.add_number("Control rate [Hz]", 1000.0, min=10.0, max=20000.0, step=100.0,
                                       hint="the controller is sampled at this rate (zero-order hold)")
            self.mismatch = gui.add_text("Model mismatch", self.state.get("mismatch", ""),
                                         hint="parameters of the controller's model that differ from the real "
                                              "robot, e.g. m2=3, I2=0.1 (the real robot uses the Parameters fields)")
            self.viscous = gui.add_text("Extra friction [N m s/rad]", "",
                                        hint="viscous friction of the real robot unknown to the controller "
                                             "(one value or one per joint)")
            self.saturation = gui.add_text("Torque bounds", "", hint="one value or one per joint, or 'limits' "
                                                                      "for the robot file's torque limits")
            passive = ",".join(c for c, a in zip(robot.coordinates, robot.actuated) if not a)
            self.passive = gui.add_text("Passive joints", passive, hint="coordinates without actuator (zero "
                                                                         "torque), e.g. q2 for partial feedback linearization")
            self.observer = gui.add_text("Collision observer K_I", self.state.get("observer", ""),
                                         hint="run the momentum-based residual with this gain (1/s), e.g. 50")
            self.force = gui.add_text("Force on a point", "", hint="POINT F=fx,fy [M=moment] [from=t0] [to=t1] "
                                      "[at=x,y,z]: "
                                      f"points {', '.join(robot.points) or '-'} or a body with at=")
            self.surface = gui.add_text("Surface", "", hint="POINT normal=nx,ny [offset=o] [k=stiffness d=damping]"
                                                            ": rigid without k (needed by hybrid control)")
        self.run_button = gui.add_button("Run", hint="simulate and replay")
        self.status = gui.add_html("")
        self.results = gui.add_folder("Replay and plots", expand_by_default=True)

        self.controller.on_update(lambda event: self._controller_changed(event.client is not None))
        self.ref_kind.on_update(lambda event: self._kind_changed() if event.client is not None else None)
        self.run_button.on_click(lambda _: self.run())
        for field in (self.gains, self.ref_kind, self.ref_params, self.duration, self.rate, self.mismatch,
                      self.viscous, self.saturation, self.passive, self.observer, self.force, self.surface):
            field.on_update(self._field_changed)
        self._controller_changed(reset_fields=True, initial=True)

    def _name(self) -> str:
        return self._titles[self.controller.value]

    def _controller_changed(self, reset_fields: bool = True, initial: bool = False) -> None:
        name = self._name()
        cls = CONTROLLERS[name]
        self.state["controller"] = name
        if not initial:
            self._clear_result()      # the previous controller's plots, status and replay go
        parts = mathml.split_top_level(cls.law_latex)
        rows = "".join(f"<tr><td><code>{html.escape(g.name)}</code></td><td>{html.escape(g.doc)}</td>"
                       f"<td>{g.default:g}{' × M<sub>ii</sub>(q₀)' if g.per_inertia else ''}"
                       f"{' ' + html.escape(g.unit) if g.unit and g.unit != '-' else ''}</td></tr>"
                       for g in cls.gain_specs)
        self.law.content = (
            "".join(self.session.math_html(p) for p in parts)
            + f'<div class="r2-label" style="margin:2px 0 4px 0">{html.escape(cls.closed_loop)}</div>'
            + f'<table style="font-size:0.78em;color:#333;border-collapse:collapse" class="r2-gains">{rows}</table>')
        if reset_fields and not initial:
            self.gains.value = ""
        # fill what a controller cannot do without (each stays editable)
        if name == "hybrid" and not self.surface.value.strip():
            point = "ee" if "ee" in self.robot.points else next(iter(self.robot.points), "ee")
            self.surface.value = f"{point} normal=0,1"
        if name.startswith("pfl") and not self.passive.value.strip():
            self.passive.value = self.robot.coordinates[-1]
        if name in ("learning", "elastic_pd", "elastic_pd_online") and self.ref_kind.value not in (HOLD, "setpoint"):
            self.ref_kind.value = "setpoint"                 # regulation schemes
        if name == "learning":
            self.duration.value = max(float(self.duration.value), 20.0)   # four iterations of 5 s
        self._kind_changed(keep=initial and bool(self.state.get("ref_params")))

    def _kind_changed(self, keep: bool = False) -> None:
        kind = self.ref_kind.value
        self.state["ref_kind"] = kind
        task = CONTROLLERS[self._name()].space == "task"
        if keep:
            self.ref_params.value = self.state["ref_params"]
        else:
            self.ref_params.value = TEMPLATES[kind][1 if task else 0]
        help_text = "hold the initial value" if kind == HOLD else REFERENCE_KINDS[kind][2]
        unit = "m (a point's x, y)" if task else "rad or m (the controller's coordinates)"
        if self._name() == "hybrid":
            unit = "m (position s along the surface)"
        self.ref_help.content = mathml.label_html(f"{help_text}; values in {unit}")
        self.ref_params.disabled = kind == HOLD

    # -------------------------------------------------------------- running
    def settings(self) -> Dict:
        """The keyword arguments of ``simulate`` from the fields (raises UserError on bad input)."""
        from app.core.controller_base import parse_gains
        session = self.session
        name = self._name()
        kind = self.ref_kind.value
        reference = None if kind == HOLD else f"{kind} {self.ref_params.value}".strip()
        plant = dict(session.params)
        mismatch = parse_assignments(self.mismatch.value, "model mismatch")
        unknown = [k for k in mismatch if k not in plant]
        if unknown:
            raise UserError(f"model mismatch: unknown parameter(s) {', '.join(unknown)}")
        model = {**plant, **mismatch}
        saturation = self.saturation.value.strip() or None
        if saturation is not None and saturation != "limits":
            saturation = parse_numbers(saturation, "torque bounds")
        contacts = []
        if self.force.value.strip():
            contacts.append(parse_contact("force", self.force.value))
        if self.surface.value.strip() and name in ("hybrid", "impedance", "admittance"):
            contacts.append(parse_contact("surface", self.surface.value))
        observer = parse_numbers(self.observer.value, "observer K_I") if self.observer.value.strip() else None
        return dict(robot=self.robot, controller=name, reference=reference, gains=parse_gains(self.gains.value),
                    duration=float(self.duration.value), rate=float(self.rate.value), q0=np.array(session.q),
                    plant_params=plant, model_params=model,
                    viscous=parse_numbers(self.viscous.value, "extra friction") if self.viscous.value.strip() else None,
                    saturation=saturation, passive=[c.strip() for c in self.passive.value.split(",") if c.strip()],
                    contacts=contacts, observer=observer)

    def configure(self, controller: str, reference: str = "", mismatch: str = "", duration: Optional[float] = None,
                  gains: str = "", **fields) -> None:
        """Fill the fields from code (scripts, screenshots): a controller name, a reference text
        ('quintic by=0.5 T=2', '' to hold), a model mismatch, the duration, gains; ``fields`` sets
        other text fields by attribute name (observer, force, surface, passive, saturation, viscous)."""
        self.controller.value = CONTROLLERS[controller].title
        self._controller_changed()
        kind, _, values = reference.partition(" ")
        self.ref_kind.value = kind or HOLD
        self._kind_changed()
        self.ref_params.value = values
        self.mismatch.value = mismatch
        self.gains.value = gains
        if duration is not None:
            self.duration.value = float(duration)
        for name, value in fields.items():
            getattr(self, name).value = value

    def show_time(self, t: float) -> None:
        """Stop the replay and show the run at time t."""
        if self.result is None:
            raise RuntimeError("no run to show (the last one failed: see the notification)")
        with self._replay_lock:
            self._replay.update(t=float(t), playing=False)
        self.time.value = float(t)
        self._show_time(float(t))
        self._mark_time(float(t), now=True)

    def run(self, wait: bool = False, auto: bool = False):
        """Simulate with the current fields (in the background; ``wait`` blocks until done). A
        newer run replaces one still going: the older one stops at its next progress report and
        never shows. ``auto``: started by a changed field (bad input then shows in the status
        line only)."""
        try:
            kwargs = self.settings()
        except UserError as exc:
            if auto:
                self.status.content = (f'<div class="r2-label" style="color:#b3261e">not run: '
                                       f'{html.escape(str(exc))}</div>')
            else:
                self.session.notify("Cannot run", str(exc), error=True)
            return None
        self.state.update(duration=self.duration.value, mismatch=self.mismatch.value, observer=self.observer.value,
                          ref_params=self.ref_params.value)
        self._stop_replay()
        self._has_run = True
        self._runs += 1
        run = self._runs
        self.run_button.disabled = True
        self.status.content = mathml.label_html("running ..." + (" (re-run after a change)" if auto else ""))
        title = f"Simulating {CONTROLLERS[kwargs['controller']].title}"

        def current() -> bool:
            return self._alive() and run == self._runs

        def work(progress):
            try:
                return in_worker(simulate, progress=lambda f, m: progress(f, m) if current() else False, **kwargs)
            except UserError as exc:
                if current():
                    self.status.content = (f'<div class="r2-label" style="color:#b3261e">not run: '
                                           f'{html.escape(str(exc))}</div>')
                raise
            finally:
                if current():
                    self.run_button.disabled = False

        def done(res):
            if current():    # not after a controller switch or a newer run
                self._show_result(res, kwargs)

        def cancelled():
            if current():
                self.status.content = mathml.label_html("cancelled")

        future = self.session.run_in_background(work, title, on_done=done, on_cancel=cancelled)
        if wait:
            future.result()
        return future

    def _field_changed(self, event) -> None:
        """A field of the controller changed: re-run a short simulation (AUTO_RERUN_MAX seconds or
        less) once the student stops typing for AUTO_RERUN_DELAY seconds."""
        if event.client is None or not self._has_run:
            return
        try:
            duration = float(self.duration.value)
        except (TypeError, ValueError):
            return
        if duration > AUTO_RERUN_MAX:
            return
        if self._rerun_timer is not None:
            self._rerun_timer.cancel()

        def fire():
            if self._alive():
                self.run(auto=True)
        self._rerun_timer = threading.Timer(AUTO_RERUN_DELAY, fire)
        self._rerun_timer.daemon = True
        self._rerun_timer.start()

    def _alive(self) -> bool:
        return (self.session.generation == self.generation and self.state.get("panel") is self
                and not self.session.closed)

    # -------------------------------------------------------------- results
    def _clear_result(self) -> None:
        """Remove the last run: its status, replay widgets, plots, ghost and overlays."""
        self._stop_replay()
        self._runs += 1                  # a run still going will not show its result
        self.result = None
        self.status.content = ""
        for widget in self._result_widgets:
            widget.remove()
        self._result_widgets, self._plots, self._plot_data = [], [], []
        scene = self.session.scene
        for name in self._overlays:
            scene.remove_overlay(name)
        self._overlays = set()
        scene.remove_ghost("control_ref")

    def _show_result(self, res: SimResult, kwargs) -> None:
        self.result = res
        self.true_coefficients = None
        if any(k.startswith("a_hat") for k in res.internals):
            self.true_coefficients = coefficient_values(self.robot, kwargs["plant_params"])
        mismatch = res.settings.get("model_mismatch")
        if res.completed:
            text = (f"completed: {len(res.t)} samples, {res.real_time_factor:.0f}x real time; "
                    f"final |e| = {np.max(np.abs(res.e[-1])):.2e}" + (f"; model: {mismatch}" if mismatch else ""))
            self.status.content = f'<div class="r2-label" style="color:#1e7b34">{html.escape(text)}</div>'
        else:
            self.status.content = (f'<div class="r2-label" style="color:#b3261e">stopped: '
                                   f'{html.escape(res.message)}</div>')
            self.session.notify("The run stopped early", res.message, error=True)
        for widget in self._result_widgets:
            widget.remove()
        self._result_widgets, self._plots, self._plot_data = [], [], []
        gui = self.gui
        end = float(res.t[-1])
        with self.results:
            self.time = gui.add_slider("Time [s]", min=0.0, max=max(end, 1e-3), step=max(end / 1000, 1e-3),
                                       initial_value=0.0, hint="scrub through the run; the plots' grey line "
                                                               "follows")
            self.play = gui.add_button_group("Replay", ("▶ Play", "❚❚ Pause", "Restart"))
            self.speed = gui.add_dropdown("Speed", list(SPEEDS), initial_value="1x")
            self.keep_button = gui.add_button("Keep this run for comparison", color="gray",
                                              hint="the next runs' plots show this run's curves, dashed")
            self.clear_button = gui.add_button("Clear comparison", color="gray", hint="drop the kept run")
            self.kept_note = gui.add_html("")
            self._result_widgets += [self.time, self.play, self.speed, self.keep_button, self.clear_button,
                                     self.kept_note]
        self.time.on_update(self._time_moved)
        self.play.on_click(self._play_clicked)
        self.speed.on_update(lambda _: self._set_speed())
        self.keep_button.on_click(lambda _: self.keep_for_comparison())
        self.clear_button.on_click(lambda _: self.clear_comparison())
        self._draw_plots()
        self._draw_paths()
        with self._replay_lock:
            self._replay.update(t=0.0, playing=False)
        self._show_time(0.0)
        self._start_replay()

    # -------------------------------------------------------------- comparison
    def kept(self) -> Optional[Dict]:
        """The run kept for comparison (on this robot), or None."""
        kept = self.state.get("kept")
        return kept if kept is not None and kept["robot"] == self.robot.name else None

    def keep_for_comparison(self) -> None:
        """Keep the run on display: the next runs' plots show its curves beside theirs."""
        res = self.result
        if res is None:
            return
        idx = plot_indices(len(res.t))
        groups = {base_title(title): [(label, np.asarray(v, dtype=float)[idx], ci) for label, v, _, ci in series]
                  for title, series in plot_groups(res, self.true_coefficients)}
        self.state["kept"] = {"robot": self.robot.name, "name": res.controller, "title": res.title,
                              "mismatch": res.settings.get("model_mismatch") or "", "t": res.t[idx],
                              "groups": groups}
        self._show_kept_note(just_kept=True)

    def clear_comparison(self) -> None:
        self.state.pop("kept", None)
        if self.result is not None:
            self._draw_plots()

    def _show_kept_note(self, just_kept: bool = False) -> None:
        kept = self.kept()
        self.clear_button.disabled = kept is None
        if kept is None:
            self.kept_note.content = ""
            return
        what = kept["title"] + (f" (model: {kept['mismatch']})" if kept["mismatch"] else "")
        text = (f"kept for comparison: {what}; run again to see both" if just_kept
                else f"dashed, lighter: the kept run, {what}")
        self.kept_note.content = mathml.label_html(text)

    # -------------------------------------------------------------- plots
    def _draw_plots(self) -> None:
        """(Re)draw the plots of the run on display, with the kept run's curves if any, and the
        Download buttons after them."""
        downloads = getattr(self, "downloads", None)
        gone = self._plots + ([downloads] if any(w is downloads for w in self._result_widgets) else [])
        for widget in gone:
            widget.remove()
        self._result_widgets = [w for w in self._result_widgets if not any(w is g for g in gone)]
        self._plots, self._plot_data = [], []
        kept = self.kept()
        with self.results:
            for title, series in plot_groups(self.result, self.true_coefficients):
                extra = kept["groups"].get(base_title(title), []) if kept is not None else []
                self._plots.append(self._add_plot(title, series, extra, kept))
            self.downloads = self.gui.add_button_group("Download", ("CSV", "PNG"))
        self.downloads.on_click(self._download)
        self._result_widgets += self._plots + [self.downloads]
        self._show_kept_note()
        with self._replay_lock:
            t = self._replay["t"]
        self._mark_time(t, now=True)

    def _add_plot(self, title: str, series, extra=(), kept=None):
        res = self.result
        idx = plot_indices(len(res.t))
        power = decade(series + [(label, v, True, ci) for label, v, ci in extra])
        if power:
            title = f"{title}  [× 1e{power}]"
        scale = 10.0 ** -power
        new = [scale * np.asarray(v, dtype=float)[idx] for _, v, _, _ in series]
        if extra:
            x, columns = merge_runs(res.t[idx], new, kept["t"], [scale * v for _, v, _ in extra])
        else:
            x, columns = res.t[idx], new
        cfg = [{"label": "t [s]"}]
        cfg += [{"label": label, "stroke": COLORS[ci % len(COLORS)], "width": 1.5,
                 **({"dash": [6, 4]} if dashed else {})} for label, _, dashed, ci in series]
        cfg += [{"label": f"{label} [{kept['name']}]", "stroke": COLORS[ci % len(COLORS)] + "88", "width": 1.5,
                 "dash": [2, 3]} for label, _, ci in extra]
        cfg.append({"label": "replay", "stroke": "#555555", "width": 1.0, "points": {"show": False}})
        low, high = value_range(columns)
        pad = 0.05 * (high - low)
        low, high = low - pad, high + pad      # a fixed y range: uPlot's autoscale does not skip NaN
        with self._replay_lock:
            t = self._replay["t"]
        x2, data = with_time_marker(x, columns, t, low, high)
        handle = self.gui.add_uplot(data=(x2, *data), series=tuple(cfg), title=title, aspect=1.6,
                                    scales={"x": {"time": False}, "y": {"range": [low, high]}},
                                    axes=({"label": "t [s]", "size": 36}, {"size": 52}),
                                    cursor={"drag": {"x": True, "y": False}})
        self._plot_data.append({"handle": handle, "x": x, "columns": columns, "span": (low, high)})
        return handle

    def _mark_time(self, t: float, now: bool = False) -> None:
        """Move the plots' time marker to t: at once, or at most every MARKER_INTERVAL seconds
        (the last time asked for is always drawn, by a timer)."""
        with self._marker_lock:
            self._marker["t"] = float(t)
            wait = MARKER_INTERVAL - (time.monotonic() - self._marker["last"])
            if not now and wait > 0:
                if self._marker["timer"] is None:
                    timer = threading.Timer(wait, self._push_marker)
                    timer.daemon = True
                    self._marker["timer"] = timer
                    timer.start()
                return
        self._push_marker()

    def _push_marker(self) -> None:
        with self._marker_lock:
            self._marker["timer"] = None
            self._marker["last"] = time.monotonic()
            t = self._marker["t"]
            plots = list(self._plot_data)
        if not self._alive():
            return
        with self.session.atomic():
            for plot in plots:
                x, data = with_time_marker(plot["x"], plot["columns"], t, *plot["span"])
                try:
                    plot["handle"].data = (x, *data)
                except Exception:     # removed by a newer run or a rebuild
                    return

    def marker_time(self) -> Optional[float]:
        """Where the plots' time marker is drawn (None without plots): for tests."""
        if not self._plot_data:
            return None
        marker = np.asarray(self._plot_data[0]["handle"].data[-1])
        x = np.asarray(self._plot_data[0]["handle"].data[0])
        return float(x[marker >= self._plot_data[0]["span"][0]][0])

    def _draw_paths(self) -> None:
        """The run's fixed overlays: reference and actual paths of a task point, the surfaces."""
        scene, res = self.session.scene, self.result
        for name in self._overlays:
            scene.remove_overlay(name)
        self._overlays = {"control_ref_path", "control_path", "control_ref_point"}
        self._overlays |= {f"control_surface{i}" for i in range(len(res.surfaces))}
        self._overlays |= {f"control_force{i}{end}" for i in range(len(res.forces)) for end in ("", "_label")}
        scene.remove_ghost("control_ref")
        if res.ref_points is not None:
            scene.add_trajectory("control_ref_path", res.ref_points, color=(150, 150, 150))
            scene.add_trajectory("control_path", res.actual_points, color=(31, 119, 180))
        half = 0.6 * self.session.drawing.scale
        for i, (point, normal, offset, kind) in enumerate(res.surfaces):
            start = res.contact_points[point][0]
            foot = start - (normal @ start - offset) * normal           # on the surface
            tangent = np.cross(normal, [0.0, 0.0, 1.0]) if abs(normal[2]) < 0.9 else np.cross(normal, [1.0, 0, 0])
            tangent /= np.linalg.norm(tangent)
            scene.add_line(f"control_surface{i}", [foot - half * tangent, foot + half * tangent],
                           color=(90, 90, 90) if kind == "rigid" else (160, 120, 60), width=5.0)
        peak = max((float(np.max(np.linalg.norm(f, axis=1))) for f in res.forces.values()), default=0.0)
        self._force_scale = 0.35 * self.session.drawing.scale / peak if peak > 0 else 0.0

    def _reference_q(self, k: int) -> Optional[np.ndarray]:
        """The reference as a configuration for the ghost (referenced coordinates from q_d, the
        others from the actual motion), or None for Cartesian references."""
        res = self.result
        coords = res.coordinates
        if not all(r in coords for r in res.reference_names):
            return None
        q = res.q[k].copy()
        for i, r in enumerate(res.reference_names):
            q[coords.index(r)] = res.ref[k, i]
        return q

    def _show_time(self, t: float) -> None:
        res = self.result
        if res is None or not self._alive():
            return
        k = index_at(res.t, t)
        scene = self.session.scene
        with self.session.holding(self.generation) as current, self.session.atomic():
            if not current:                 # the robot was switched: draw nothing of this run
                return
            scene.set_pose(res.q[k])
            ghost = self._reference_q(k)
            if ghost is not None:
                scene.ghost(ghost, "control_ref", color=(120, 160, 230), opacity=0.3)
            elif res.ref_points is not None:
                scene.add_marker("control_ref_point", res.ref_points[k], color=(120, 160, 230))
            for i, (name, forces) in enumerate(res.forces.items()):     # contact forces on the robot
                F = np.zeros(3)
                F[:forces.shape[1]] = forces[k]
                if np.linalg.norm(F) * self._force_scale > 1e-4:
                    scene.add_arrow(f"control_force{i}", res.contact_points[name][k], F * self._force_scale,
                                    color=(214, 39, 40), label=f"{np.linalg.norm(F):.3g} N")
                else:
                    scene.remove_overlay(f"control_force{i}")
                    scene.remove_overlay(f"control_force{i}_label")

    # -------------------------------------------------------------- replay
    def _time_moved(self, event) -> None:
        if event.client is None:         # moved by the replay itself
            return
        with self._replay_lock:
            self._replay.update(t=float(self.time.value), playing=False)
        self._show_time(float(self.time.value))
        self._mark_time(float(self.time.value))

    def _play_clicked(self, event) -> None:
        value = event.target.value
        with self._replay_lock:
            if value.endswith("Play"):
                if self._replay["t"] >= float(self.result.t[-1]) - 1e-9:
                    self._replay["t"] = 0.0
                self._replay["playing"] = True
                self._wake.set()
            elif value.endswith("Pause"):
                self._replay["playing"] = False
            else:
                self._replay.update(t=0.0, playing=False)
                self.time.value = 0.0
                self._show_time(0.0)
                self._mark_time(0.0)

    def _set_speed(self) -> None:
        with self._replay_lock:
            self._replay["speed"] = SPEEDS[self.speed.value]

    def _start_replay(self) -> None:
        if getattr(self, "_thread", None) is not None and self._thread.is_alive():
            return
        self._thread = threading.Thread(target=self._replay_loop, daemon=True,
                                        name=f"control-replay-{self.session.tab_id}")
        self._thread.start()

    def _stop_replay(self) -> None:
        with self._replay_lock:
            self._replay["playing"] = False

    def _replay_loop(self) -> None:
        """Advance the replay at FPS frames per second while playing; idle (no polling) otherwise."""
        last = time.monotonic()
        while self._alive():
            with self._replay_lock:
                idle = not self._replay["playing"]
                if idle:
                    self._wake.clear()
            if idle:
                self._wake.wait(timeout=2.0)          # woken by Play; checks now and then for a rebuild
                last = time.monotonic()
                continue
            time.sleep(1.0 / FPS)
            now = time.monotonic()
            with self._replay_lock:
                playing = self._replay["playing"]
                if playing and self.result is not None:
                    end = float(self.result.t[-1])
                    t = min(end, self._replay["t"] + (now - last) * self._replay["speed"])
                    self._replay["t"] = t
                    if t >= end:
                        self._replay["playing"] = False
            last = now
            if playing:
                try:
                    self.time.value = t
                    self._show_time(t)
                    self._mark_time(t)
                except Exception:      # widgets removed by a rebuild: stop quietly
                    return

    # -------------------------------------------------------------- downloads
    def _download(self, event) -> None:
        res = self.result
        if res is None:
            return
        stem = f"{res.robot}_{res.controller}"
        if event.target.value == "CSV":
            event.client.send_file_download(f"{stem}.csv", res.to_csv().encode("utf-8"))
        else:
            png = plots_png(res, plot_groups(res, self.true_coefficients))
            event.client.send_file_download(f"{stem}.png", png)
