"""One browser tab of the lab: its robot, parameter values, coordinates, camera, panels.

The page is built per tab: a header (robot picker, description, pinocchio check badge, progress
bars), the joint-coordinate sliders, the parameter fields, display options, and a tab group with
one tab per panel of the server's registry (``LabServer.panels``). Panels receive this ``Session``
and use only its ``PanelSession`` interface (app/viewer/panel_api.py, docs/panels.md).
"""
from __future__ import annotations

import contextlib
import html
import math
import threading
import time
import traceback
from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path
from typing import Callable, Dict, List, Mapping, Optional

import numpy as np

from app.core.dynamics import derive, is_derived
from app.core.errors import UserError
from app.core.numeric import NumericModel, ParameterError, cross_check
from app.scene import RobotDrawing, default_q
from app.viewer import mathml, url_state
from app.viewer.coalescer import Coalescer
from app.viewer.fields import CommittedField, format_number, parse_parameter
from app.viewer.jobs import JobRunner
from app.viewer.panel_api import PanelSpec
from app.viewer.picker import RobotPicker
from app.viewer.presenter import Presenter
from app.viewer.scene_view import SceneView
from app.viewer.worker import NotPortable, derive_in_worker, in_worker

# order of the page's fixed elements (panels' tab group comes last)
ORDER_STYLE, ORDER_PICKER, ORDER_INFO, ORDER_BADGE, ORDER_PROGRESS = 0, 1, 3, 4, 5
ORDER_COORDS, ORDER_PARAMS, ORDER_DISPLAY, ORDER_TABS = 10, 11, 12, 100

URL_WAIT = 20.0        # seconds to wait for the page to report its address before the default page
DRAWN_WAIT = 1.5       # seconds the tab's first panels wait for the page to draw its first robot


class Session:
    """State and page of one browser tab. Panels use the attributes and methods documented in
    docs/panels.md; everything starting with ``_`` is private."""

    def __init__(self, lab, client):
        self.lab = lab
        self.client = client
        self.gui = client.gui
        self.scene = SceneView(client)
        self.robot = None
        self.robot_name = ""                    # the name it was loaded by (file stem)
        self.dynamics = None
        self.numeric: Optional[NumericModel] = None
        self.drawing: Optional[RobotDrawing] = None
        self.q = np.zeros(0)
        self.params: Dict[str, float] = {}
        self.state: Dict[str, object] = {}      # panels' state kept across robot switches
        self.generation = 0
        self._picks = 0                         # robots asked for so far (load_robot)
        self.closed = False
        self.ready = threading.Event()          # set when the robot's panels are built
        self.url: Dict[str, str] = {}           # the page's state as written to its address
        self._url_pending: Dict[str, str] = {}  # address values still to apply (after the panels)
        self._url_serial = 0
        self._reselect_tab = False              # the tab group was rebuilt: select url["tab"] again
        self._started = threading.Event()       # the first robot was asked for
        self._guessed: Optional[str] = None     # the address the first robot is loaded from, until the page confirms it
        self._first_pick = 0                    # the pick number of the guessed first robot
        self._font_sent = False                 # the math font's <style> is in the page
        self.drawn = threading.Event()          # the page reported it has drawn the tab's first robot
        self._lock = threading.RLock()
        self._build_lock = threading.RLock()     # one thread builds or clears the panels at a time
        self._jobs = JobRunner(self.gui, self.notify, self._internal_error, lab.limited, lambda: self.closed,
                               self._build_lock, ORDER_PROGRESS, name=f"session{client.client_id}",
                               workers=getattr(lab, "workers", None))
        self._listeners: Dict[str, List] = {"robot": [], "parameters": [], "q": [], "presenter": []}
        self._owner = threading.local()
        self._sliders: List = []
        self._param_fields: Dict[str, CommittedField] = {}
        self._tabs = None
        self._tab_handles: Dict[str, object] = {}
        self._tab_boxes: Dict[str, object] = {}   # panel name -> the container in its tab (_empty_tab)
        self._tab_titles: List[str] = []
        self._unbuilt: Dict[str, int] = {}        # panel name -> generation whose tab waits to be opened
        self._reports: Optional[ThreadPoolExecutor] = None     # handles the page's reports in order
        self._panel_errors: List[str] = []
        self._pose_job = Coalescer(self._apply_pose, 0.0, self._internal_error)
        self._q_job = Coalescer(lambda: self._fire("q", self.q.copy()), 0.05, self._internal_error)
        self._param_job = Coalescer(self._apply_parameters, 0.05, self._internal_error)
        self._check_job = Coalescer(self._run_check, 0.2, self._internal_error)
        self.checks = 0                  # pinocchio cross-checks started (numbers the badge: data-check)
        self.checked_values: Dict[str, float] = {}      # the parameters of the last one started
        self._build_page()

    # ================================================================== public API for panels
    @property
    def coordinates(self) -> List[str]:
        return list(self.robot.coordinates) if self.robot else []

    @property
    def ranges(self) -> Dict[str, tuple]:
        """Slider range (lo, hi) of every coordinate."""
        return dict(self.drawing.ranges) if self.drawing else {}

    @property
    def tab_id(self) -> int:
        """A number for this browser tab (names threads and logs)."""
        return self.client.client_id

    def robot_named(self, name: str):
        """The ``RobotModel`` of a shipped robot or robot file (shared by all tabs; not shown)."""
        return self.lab.robot(name)

    def atomic(self):
        """``with session.atomic():`` the widget and scene updates inside reach the browser together."""
        return self.client.atomic()

    def set_q(self, q) -> None:
        """Move the robot (scene and sliders) to coordinates q."""
        q = np.asarray(q, dtype=float).reshape(-1)
        if q.size != len(self.coordinates):
            raise ValueError(f"expected {len(self.coordinates)} coordinates, got {q.size}")
        with self._lock:
            self.q = q.copy()
            for slider, value in zip(self._sliders, q):
                lo, hi = slider.min, slider.max
                slider.value = float(min(max(value, lo), hi))
        self._pose_job.request()
        self._q_job.request()

    def set_parameters(self, values: Mapping[str, float]) -> None:
        """Change parameter values (validated; raises ParameterError and changes nothing if bad)."""
        checked = {}
        for name, value in values.items():
            if name not in self.params:
                raise ParameterError(f"unknown parameter '{name}'")
            try:
                number = float(value)
            except (TypeError, ValueError):
                raise ParameterError(f"{name}: {value!r} is not a number") from None
            checked[name] = self.robot.check_parameter_value(name, number)
        with self._lock:
            self.params.update(checked)
            for name, value in checked.items():
                field = self._param_fields.get(name)
                if field is not None:
                    field.set(value)
        self._param_job.request()

    def on_q_change(self, callback: Callable[[np.ndarray], None]) -> None:
        """Call ``callback(q)`` after the coordinates change (at most ~20 times per second)."""
        self._add_listener("q", callback)

    def on_parameters_change(self, callback: Callable[[Dict[str, float]], None]) -> None:
        """Call ``callback(values)`` after a parameter value changes (model already updated)."""
        self._add_listener("parameters", callback)

    def on_presenter_change(self, callback: Callable[[bool], None]) -> None:
        """Call ``callback(on)`` after presenter mode is switched on or off."""
        self._add_listener("presenter", callback)

    def on_robot_change(self, callback: Callable[[object], None]) -> None:
        """Call ``callback(robot)`` after another robot is loaded (for panels with REBUILD = False)."""
        self._add_listener("robot", callback)

    def notify(self, title: str, body: str = "", error: bool = False) -> None:
        """A notification in the corner of the page (red and longer-lived for errors)."""
        self.client.add_notification(title, body, color="red" if error else "blue",
                                     auto_close_seconds=15.0 if error else 6.0, with_close_button=True)

    def run_in_background(self, fn: Callable, progress_title: str,
                          on_done: Optional[Callable] = None, on_cancel: Optional[Callable] = None) -> Future:
        """Run ``fn(progress)`` off the event thread; ``progress(fraction, message)`` drives a
        progress bar with a Cancel button (shown when the job takes more than 0.3 s).
        ``on_done(result)`` runs after a success. A ``UserError`` becomes a clear notification, any
        other exception a notification with the error; the page keeps working either way. At most
        ``lab.max_jobs`` jobs of all tabs run at once; the others wait, saying so in their progress
        bar. When the student clicks Cancel, or the browser tab goes away (closed, reloaded), the
        next ``progress`` call raises ``JobCancelled`` and the job ends quietly (after a Cancel:
        ``on_cancel()``, then a notification). The returned future's ``cancel_job()`` does what the
        button does."""
        return self._jobs.submit(fn, progress_title, on_done, on_cancel)

    def math_html(self, latex: str, display: bool = True) -> str:
        """HTML (for ``gui.add_html``) of a LaTeX formula, typeset as MathML with the math font."""
        return mathml.math_html(latex, display)

    @contextlib.contextmanager
    def holding(self, generation: int):
        """``with session.holding(gen) as current:`` - no robot switch can happen inside the block;
        ``current`` is False when the robot of ``generation`` is no longer shown (or the tab is
        closed). A panel drawing from a background thread (a replay) draws only when current, so
        a switch never leaves the old robot's poses on the new one."""
        with self._lock:
            yield generation == self.generation and not self.closed

    def remember(self, **values: Optional[str]) -> None:
        """Put panel state into the page's address (``exercise``, ``step``, ``throw``; None
        removes a key), so that a reload or a shared link shows it again."""
        with self._lock:
            for key, value in values.items():
                if key not in url_state.KEYS:
                    raise ValueError(f"unknown address key {key!r}")
                if value is None:
                    self.url.pop(key, None)
                else:
                    self.url[key] = str(value)
        self._write_url()

    # ================================================================== page
    def _build_page(self) -> None:
        gui = self.gui
        # first of all, the field through which the page reports its address: the first robot waits on it
        self._report = gui.add_text(url_state.BRIDGE_LABEL, "", order=ORDER_STYLE + 0.1)
        gui.add_html(url_state.bridge_html(), order=ORDER_STYLE + 0.15)   # kept: the first robot may
        self._url_writer = gui.add_html("", order=ORDER_STYLE + 0.2)       # rewrite the address at once
        self._probe = gui.add_html("", order=ORDER_STYLE + 0.25)
        gui.configure_theme(control_width="large", show_logo=False, show_share_button=False,
                            brand_color=(46, 94, 170))
        self.presenter = Presenter(self, order=ORDER_STYLE + 0.3, on_switch=lambda on: self._fire("presenter", on))
        self._catalog = self.lab.catalog()
        self.picker = RobotPicker(gui, self._catalog, ORDER_PICKER, lambda: self.robot_name, self.load_robot,
                                  self._lock)
        self._info = gui.add_html("", order=ORDER_INFO)
        self._badge = gui.add_html(self._badge_html("pending", "pinocchio cross-check: waiting for the model"),
                                   order=ORDER_BADGE)
        self._status = gui.add_html(self._status_html(False), order=ORDER_BADGE + 0.5)
        self._coord_folder = gui.add_folder("Joint coordinates", order=ORDER_COORDS)
        self._param_folder = gui.add_folder("Parameters", order=ORDER_PARAMS, expand_by_default=False)
        display = gui.add_folder("Display", order=ORDER_DISPLAY, expand_by_default=False)
        with display:
            for key, label, hint in (("frames", "Body frames", "axes of every body frame (x red, y green, z blue)"),
                                     ("coms", "Centres of mass", "the CoM of every link"),
                                     ("labels", "Joint labels", "the joint variable at every joint"),
                                     ("plane", "Plane / ground", "the plane of motion or the ground grid")):
                box = gui.add_checkbox(label, self.scene.options[key], hint=hint)
                box.on_update(lambda event, key=key: self.scene.set_option(key, event.target.value))
            gui.add_button("Frame the robot", hint="camera back to the full view").on_click(
                lambda _: self.scene.frame_camera())
            self.presenter.add_switch()
        self.picker.listen()
        registry = self.lab.panels
        self._panel_specs = list(registry.specs)
        for err in registry.errors:
            self.notify("A panel failed to load", err.splitlines()[0], error=True)
        # the address of the page load this tab most likely comes from: its robot need not wait
        # for the page's report, which confirms it or corrects it (_page_report); queued first, so
        # that it is the first pick
        pages = getattr(self.lab, "page_requests", None)
        guess = pages.take() if pages is not None else None
        if guess is not None:
            with self._lock:
                self._guessed = guess
            self._queue_report(f"guess {guess}")
        # listen to the page's reports only now that everything they use is here; a report that
        # came before (a fast client: the field exists in the page since add_text) is read here
        self._report.on_update(self._page_reported)
        if self._report.value:
            self._queue_report(self._report.value)
        # the first robot comes from the page's address, once the page reports it
        timer = threading.Timer(URL_WAIT, self._start, ("",))
        timer.daemon = True
        timer.start()

    # ================================================================== the page's address
    async def _page_reported(self, event) -> None:
        """The page reported its address (``url ?...``), a click on a panel tab (``tab Title``) or
        that it has drawn its first robot (``drawn``). Read here, in viser's event loop, before
        the next report can overwrite the field (a plain callback runs later, in a thread, and two
        reports in a row were read as the second twice); handled in order on the reports' thread."""
        if event.client is None:
            return
        self._queue_report(self._report.value)

    def _queue_report(self, value: str) -> None:
        with self._lock:
            if self.closed:
                return
            # the address's robot counts as picked when the address arrived: a robot the student
            # picks afterwards (handled in another thread, maybe first) is the later pick and wins
            first = value.startswith("guess ") or (value.startswith("url ") and self._guessed is None)
            pick = self._take_pick() if first and not self._started.is_set() else None
            if self._reports is None:
                self._reports = ThreadPoolExecutor(max_workers=1, thread_name_prefix=f"reports{self.tab_id}")
            self._reports.submit(self._guarded, "the page's report", self._page_report, value, pick)

    def _guarded(self, owner: str, fn: Callable, *args) -> None:
        """``fn(*args)`` in a thread of its own making: an exception is reported, not lost."""
        try:
            fn(*args)
        except Exception:
            self._internal_error(owner=owner)

    def _page_report(self, value: str, pick: Optional[int] = None) -> None:
        kind, _, text = value.partition(" ")
        if kind == "guess":
            with self._lock:
                self._first_pick = pick
            self._start(text, pick)
        elif kind == "url":
            with self._lock:
                guessed, self._guessed = self._guessed, None
                # the guess was another tab's page load (unless the student picked a robot since)
                wrong = (guessed is not None and self._address(guessed) != self._address(text)
                         and self._picks == self._first_pick)
                if wrong:
                    self._started.clear()
            if guessed is None or wrong:
                self._start(text, pick)
        elif kind == "drawn":
            self.drawn.set()
        elif kind == "tab":
            name = next((s.name for s in self._panel_specs if s.title == text), None)
            if name is not None:
                with self._lock:
                    self.url["tab"] = name
                    self._url_pending.pop("tab", None)
                self._write_url()
                if name in self._unbuilt:        # first opened since the robot was loaded: built in a
                    # thread of its own, so that a "drawn" report queued behind this one is not held
                    # up while the first panels (holding the build lock) wait for it
                    threading.Thread(target=self._guarded, args=(f"the {name} tab", self.open_panel, name),
                                     daemon=True, name=f"open-{name}-{self.tab_id}").start()

    def _address(self, search: str) -> Dict[str, str]:
        """What an address asks for, the default robot filled in: ``""`` and ``?robot=DEFAULT``
        ask for the same page."""
        wanted = url_state.parse_query(search)
        wanted.setdefault("robot", self._default_robot())
        return wanted

    def _default_robot(self) -> str:
        """The robot of an address that names none (or an unknown one): the server's ``--robot``
        (a shipped robot or a file), else the first of the catalog."""
        initial = self.lab.initial_robot
        names = {i.name for i in self._catalog}
        return initial if initial in names or Path(initial).is_file() else self._catalog[0].name

    def _start(self, search: str, pick: Optional[int] = None) -> None:
        """Load the first robot: the address's (``?robot=...&tab=...``) or the default one; an
        unknown value gets a notice and the default page. ``pick``: taken when the address came."""
        with self._lock:
            if self._started.is_set() or self.closed:
                return
            self._started.set()
        wanted = url_state.parse_query(search)
        names = {i.name for i in self._catalog}
        problems = [f"{k}={v}" for k, v in wanted.items() if not url_state.safe(v)]
        wanted = {k: v for k, v in wanted.items() if url_state.safe(v)}
        robot = wanted.pop("robot", None)
        if robot is not None and robot not in names:
            problems.append(f"robot={robot} (no such robot)")
            robot, wanted = None, {}
        default = self._default_robot()
        with self._lock:
            self._url_pending = wanted
        if problems:
            self.notify("The page's address was not understood", "; ".join(problems) + ": showing the default page.",
                        error=True)
        self._load(robot or default, pick)

    def _reveal_when_solved(self, panel, exercise: str, k: int, timeout: float = 120.0) -> None:
        """Reveal steps 1..k+1 of the exercise the address opened, once it is solved."""
        def wait():
            deadline = time.time() + timeout
            while time.time() < deadline and not self.closed:
                if panel.exercise is None or panel.exercise.id != exercise:
                    return                    # the student opened something else meanwhile
                if panel.solution is not None and self.ready.is_set():
                    panel.show(k)
                    return
                time.sleep(0.1)
        threading.Thread(target=wait, daemon=True, name=f"address-step-{self.client.client_id}").start()

    def _write_url(self) -> None:
        """Write ``self.url`` into the address bar; after the tab group was rebuilt or the address
        named a tab, also select the tab it names. (Never otherwise: the student's own click on a
        tab reaches ``url["tab"]`` a moment later, and selecting the older value would undo it.)"""
        with self._lock:
            if self.closed:
                return
            self._url_serial += 1
            state = dict(self.url)
            tab = state.get("tab")
            title = next((s.title for s in self._panel_specs if s.name == tab), None)
            select = title if self._reselect_tab and title and tab in self._tab_handles else None
            self._reselect_tab = False
            self._url_writer.content = url_state.write_html(state, select, self._url_serial)

    def _apply_address(self) -> None:
        """After the panels are built: open the tab, exercise, step and throw the address asked
        for (each only once, and only values the panels accept)."""
        with self._lock:
            pending, self._url_pending = self._url_pending, {}
        tab = pending.get("tab")
        problems = []
        if tab is not None:
            if tab in self._tab_handles:
                self.url["tab"] = tab
                self._reselect_tab = True
                self.open_panel(tab)
            else:
                problems.append(f"tab={tab} (not a tab of {self.robot_name})")
        exercise = pending.get("exercise")
        if exercise is not None:
            panel = self.open_panel("exercises").get("panel")
            try:
                if panel is None:
                    raise UserError("no Exercises panel")
                panel.open(exercise)
                if pending.get("step", "").isdigit():
                    self._reveal_when_solved(panel, exercise, int(pending["step"]) - 1)
            except Exception as exc:
                problems.append(f"exercise={exercise} ({exc})")
        throw = pending.get("throw")
        if throw is not None:
            studio = self.open_panel("throw").get("studio")
            try:
                if studio is None or throw not in getattr(studio, "shipped", ()):
                    raise UserError("not a throw of the Throw studio")
                studio.load(throw)
            except Exception as exc:
                problems.append(f"throw={throw} ({exc})")
        values = {}               # after the throw, whose file sets parameters: the address's win
        for key, text in pending.items():
            name = url_state.parameter_name(key)
            if name is None:
                continue
            try:
                values[name] = parse_parameter(self.robot, name, text)
            except UserError as exc:
                problems.append(f"{key}={text} ({exc})")
        if values:
            self.set_parameters(values)
        if problems:
            self.notify("Part of the page's address was not understood", "; ".join(problems), error=True)
        self._write_url()

    # ================================================================== robot switching
    def load_robot(self, name: str) -> None:
        """Replace the robot: scene, sliders and parameters at once, panels when the model is ready.
        Of two picks made while the first is still being read and drawn, the later one wins."""
        self._load(name)

    def _take_pick(self) -> int:
        with self._lock:
            self._picks += 1
            return self._picks

    def _load(self, name: str, pick: Optional[int] = None) -> None:
        if pick is None:
            pick = self._take_pick()
        self.lab.note_load()
        try:
            robot = self.lab.robot(name)
            drawing = self.lab.drawing(robot)
        except UserError as exc:
            self.notify(f"Cannot load {name}", str(exc), error=True)
            return
        except Exception:
            self._internal_error(owner=f"drawing of {name}")
            return
        with self._lock:
            if pick != self._picks:            # a later pick is loading: it alone may take the tab
                return
            self._started.set()
            self.generation += 1
            generation = self.generation
            self.ready.clear()
            self.robot, self.drawing, self.robot_name = robot, drawing, name
            for spec in self._panel_specs:     # the old robot's panels stop listening now
                if spec.rebuild:
                    self._drop_listeners(spec.name)
            self.dynamics, self.numeric = None, None
            self.params = robot.parameter_values()
            self._parameters_to_address()
            self.q = default_q(robot)
            with self.client.atomic():
                self._status.content = self._status_html(False, name, generation)
                self._info.content = self._info_html(robot)
                self._badge.content = self._badge_html("pending", "pinocchio cross-check: waiting for the model")
                self.scene.clear_overlays()
                self.scene.clear_highlight()
                self.scene.show_robot(drawing, self.q)
                self._build_coordinates()
                self._build_parameters()
                self._clear_panels(robot)
            self.scene.frame_camera()
            self.picker.show(name)
            if self.url.get("robot") != name:      # panels put theirs back if they still apply
                for key in ("exercise", "step", "throw"):
                    self.url.pop(key, None)
            self.url["robot"] = name
            probe = not self._font_sent and not self.drawn.is_set()
        self._write_url()
        if probe:          # the page says when it has drawn the tab's first robot (_send_font waits)
            self._probe.content = url_state.drawn_probe_html(generation)

        def work(progress):
            if not is_derived(robot):       # a cold derivation runs in a worker process
                dynamics = in_worker(derive_in_worker, robot, progress=progress)
                if dynamics is not None:
                    return dynamics
            return derive(robot, progress=progress)     # from the cache the worker wrote

        def cancelled():
            with self._lock:
                if generation == self.generation:
                    self._badge.content = self._badge_html(
                        "pending", "model not derived (cancelled): reload the page or pick a robot to derive it")

        self.run_in_background(work, f"Deriving the model of {robot.title}",
                               on_done=lambda dyn: self._model_ready(generation, dyn), on_cancel=cancelled)

    def _model_ready(self, generation: int, dynamics) -> None:
        with self._lock:
            if generation != self.generation:
                return
            self.dynamics = dynamics
            self.numeric = NumericModel(self.robot, self.params, dynamics=dynamics)
        self._send_font()
        self._build_panels(generation)
        with self._lock:
            if generation != self.generation:
                return
            self._fire("robot", self.robot)
            if self.url.get("tab") not in self._tab_handles:     # its tab is gone: the first one shows
                self.url["tab"] = next(iter(self._tab_handles), None)
        self._apply_address()
        with self._lock:
            if generation != self.generation:
                return
            self._status.content = self._status_html(True, self.robot_name, generation)
            self.ready.set()
        self._check_job.request()

    def _send_font(self) -> None:
        """Before the tab's first formula: the math font (2 MB) once, after the page has drawn its
        first robot (or DRAWN_WAIT seconds): the first panels and the font's decoding would
        otherwise hold the browser's first frame back (by about 0.25 s in software WebGL)."""
        if self._font_sent:
            return
        self.drawn.wait(DRAWN_WAIT)
        self._font_sent = True
        self.gui.add_html(mathml.font_style(), order=ORDER_STYLE)

    # ================================================================== header widgets
    def _status_html(self, ready: bool, robot: Optional[str] = None, generation: Optional[int] = None) -> str:
        """The hidden marker tests and pictures wait on: which tab this is, its robot, whether ready;
        e.g. ``<span class="r2-status" data-tab="3" data-ready="1" data-robot="planar_2r"
        data-generation="2">``."""
        extra = "" if robot is None else f' data-robot="{robot}" data-generation="{generation}"'
        return f'<span class="r2-status" data-tab="{self.tab_id}" data-ready="{int(ready)}"{extra}></span>'

    def _info_html(self, robot) -> str:
        kind = "planar, " + robot.plane + " plane" if robot.plane else "spatial"
        joints = "".join("R" if b.joint.type == "revolute" else "P" if b.joint.type == "prismatic" else ""
                         for b in robot.bodies)
        passive = [c for c, a in zip(robot.coordinates, robot.actuated) if not a]
        extra = f" · passive: {', '.join(passive)}" if passive else ""
        return (f'<div style="font-size:0.86em;line-height:1.35;color:#333">'
                f"<b>{html.escape(robot.title)}</b><br>{html.escape(robot.description)}"
                f'<div style="color:#777;margin-top:2px">{html.escape(robot.name)} · {robot.n} DOF · '
                f"{joints} · {kind}{extra}</div></div>")

    @staticmethod
    def _badge_html(state: str, text: str, check: int = 0) -> str:
        """The pinocchio badge; ``check`` numbers the cross-check it shows (0: none yet)."""
        colors = {"ok": ("#1e7b34", "#e6f4ea", "&#10004;"), "bad": ("#b3261e", "#fce8e6", "&#10008;"),
                  "pending": ("#5f6368", "#f1f3f4", "&#8943;")}
        fg, bg, icon = colors[state]
        return (f'<div class="r2-badge" data-state="{state}" data-check="{check}" '
                f'style="font-size:0.82em;color:{fg};background:{bg};'
                f'border-radius:6px;padding:3px 8px;margin:2px 0">{icon} {html.escape(text)}</div>')

    def _build_coordinates(self) -> None:
        for slider in self._sliders:
            slider.remove()
        self._sliders = []
        robot, ranges = self.robot, self.drawing.ranges
        prismatic = {s.name for b in robot.bodies if b.joint.type == "prismatic" for s in b.joint.value.free_symbols}
        with self._coord_folder:
            for i, name in enumerate(robot.coordinates):
                lo, hi = ranges[name]
                unit = "m" if name in prismatic else "rad"
                step = (hi - lo) / 1000 if name in prismatic else 0.001
                lo, hi = math.floor(lo * 1000) / 1000, math.ceil(hi * 1000) / 1000
                slider = self.gui.add_slider(name, min=float(lo), max=float(hi), step=float(step),
                                             initial_value=float(self.q[i]),
                                             hint=f"{name} [{unit}], range [{lo:.3g}, {hi:.3g}]")
                slider.on_update(self._slider_moved)
                self._sliders.append(slider)

    def _slider_moved(self, event) -> None:
        if event.client is None:       # set by the server (set_q): already applied
            return
        with self._lock:
            if not self._sliders or event.target not in self._sliders:
                return
            self.q = np.array([s.value for s in self._sliders], dtype=float)
        self._pose_job.request()
        self._q_job.request()

    def _apply_pose(self) -> None:
        with self._lock:        # a robot switch cannot slip between reading q and drawing it
            self.scene.set_pose(self.q.copy())

    def _build_parameters(self) -> None:
        for field in self._param_fields.values():
            field.close()
            field.handle.remove()
        self._param_fields = {}
        robot = self.robot
        with self._param_folder:
            for name, p in robot.parameters.items():
                unit = f" [{p.unit}]" if p.unit else ""
                handle = self.gui.add_text(f"{name}{unit}", format_number(self.params[name]),
                                           hint=(p.doc or p.kind) + f" (default {format_number(p.value)})")
                self._param_fields[name] = CommittedField(
                    handle, lambda text, name=name, robot=robot: parse_parameter(robot, name, text),
                    lambda value, name=name, robot=robot: self._parameter_committed(robot, name, value),
                    lambda message, name=name: self.notify(
                        "Parameter not changed", f"{message}; keeping {name} = {format_number(self.params[name])}",
                        error=True),
                    format=format_number)

    def _parameter_committed(self, robot, name: str, value: float) -> None:
        """A parameter field's edit was committed with a good value: model, drawing, badge follow."""
        with self._lock:
            if robot is not self.robot or value == self.params.get(name):
                return
            self.params[name] = value
        self._param_job.request()

    def _apply_parameters(self) -> None:
        with self._lock:
            values = dict(self.params)
            robot = self.robot
            if self.numeric is not None:
                self.numeric.set_parameters(values)
            drawing = RobotDrawing(robot, values)
            self.drawing = drawing
            self.scene.show_robot(drawing, self.q)
            moved = self._parameters_to_address()
        if moved:
            self._write_url()
        self._fire("parameters", values)
        self._check_job.request()

    def _parameters_to_address(self) -> bool:
        """(lock held) The address's ``p.<name>`` keys: every parameter whose value differs from
        the robot file's, so that a reload or a shared link shows the same model. True when
        they changed."""
        old = {k: v for k, v in self.url.items() if url_state.parameter_name(k)}
        new = {url_state.parameter_key(name): url_state.address_number(self.params.get(name, default))
               for name, default in self.robot.parameter_values().items()
               if self.params.get(name, default) != default}
        for key in old:
            del self.url[key]
        self.url.update(new)
        return new != old

    def _run_check(self) -> None:
        with self._lock:
            robot, values, generation = self.robot, dict(self.params), self.generation
            dynamics = self.dynamics
            ready = self.numeric is not None
            if ready:
                self.checks += 1
                self.checked_values = values
            check = self.checks
        if not ready or self.closed:
            return
        self._badge.content = self._badge_html("pending", "pinocchio cross-check: running", check)
        try:
            result = self._cross_check(robot, values, dynamics)
        except Exception as exc:
            text, state = f"pinocchio cross-check failed: {exc}", "bad"
        else:
            worst = max(result.max_rel_error.values()) if result.max_rel_error else 0.0
            if result.ok:
                text, state = f"pinocchio agrees: M, C q̇, g to {worst:.0e} at {result.states} random states", "ok"
            else:
                errs = ", ".join(f"{k} {v:.1e}" for k, v in result.max_rel_error.items())
                text, state = f"pinocchio disagrees: {errs}", "bad"
        with self._lock:
            if generation == self.generation and values == self.params and not self.closed:
                self._badge.content = self._badge_html(state, text, check)

    def _cross_check(self, robot, values, dynamics):
        """``cross_check`` in the server's checking process (its compiled model and pinocchio's
        never hold this process's interpreter lock), or here when there is none."""
        pool = getattr(self.lab, "checks", None)
        if pool is not None:
            try:
                return pool.call(cross_check, (robot, values), {"states": 30, "dynamics": dynamics})
            except NotPortable:
                pass
        return cross_check(robot, values, states=30, dynamics=dynamics)

    # ================================================================== panels
    def _build_panels(self, generation: int) -> None:
        """Build the panel on display for the robot of ``generation`` (the others when their tab is
        first opened, ``open_panel``); stops early when the robot is switched meanwhile, and then
        leaves the new robot's placeholders."""
        with self._build_lock:
            if generation == self.generation:
                self._build_panels_locked(generation)
            if generation != self.generation and not self.closed:
                self._clear_panels(self.robot)

    def _build_panels_locked(self, generation: int) -> None:
        robot = self.robot
        specs = [s for s in self._panel_specs if self._safe_applies(s, robot)]
        titles = [s.title for s in specs]
        fresh = self._tabs is None or titles != self._tab_titles
        if fresh:
            if self._tabs is not None:
                self._tabs.remove()
            self._tabs = self.gui.add_tab_group(order=ORDER_TABS)
            self._tab_handles = {s.name: self._tabs.add_tab(s.title) for s in specs}
            self._tab_boxes = {}
            self._tab_titles = titles
            self._unbuilt = {}
            with self._lock:
                self._reselect_tab = True
        names = [s.name for s in specs]
        with self._lock:
            wanted = [self._url_pending.get("tab"), self.url.get("tab")]
        on_display = next((name for name in wanted if name in names), names[0] if names else None)
        for spec in specs:
            if generation != self.generation:          # switched meanwhile
                return
            if not spec.rebuild:            # kept across robots: built with a new tab group only (now,
                if fresh:                   # so that its previous instance, still working, is replaced)
                    self._build_panel(spec, generation)
            elif spec.name == on_display:
                self._build_panel(spec, generation)
            else:
                self._drop_listeners(spec.name)
                with self._empty_tab(spec.name):
                    self.gui.add_html(mathml.label_html(f"Opening the {spec.title} tab ..."))
                self._unbuilt[spec.name] = generation

    def _build_panel(self, spec: PanelSpec, generation: int) -> None:
        """Build one panel into its emptied tab, ending with the marker ``select_tab`` waits for."""
        self._drop_listeners(spec.name)
        box = self._empty_tab(spec.name)
        self._unbuilt.pop(spec.name, None)
        self._owner.name = spec.name
        try:
            with box:
                spec.build(self)
        except UserError as exc:
            with box:
                self.gui.add_markdown(f"**{spec.title}**: {exc}")
        except Exception:
            detail = traceback.format_exc(limit=4)
            with box:
                self.gui.add_markdown(f"**{spec.title}** could not be built for this robot "
                                      f"(internal error):\n\n```\n{detail[-1200:]}\n```")
            self.notify(f"Panel {spec.title} failed", detail.strip().splitlines()[-1], error=True)
        finally:
            self._owner.name = None
        with box:
            self.gui.add_html(f'<span class="r2-panel" data-panel="{spec.name}" data-title="{html.escape(spec.title)}" '
                              f'data-generation="{generation}"></span>')

    def open_panel(self, name: str) -> dict:
        """Build panel ``name`` now if its tab has not been opened since the robot was loaded (a
        switch builds only the tab on display; a click on another tab builds that one), and return
        its ``state`` entry. Tests and pictures call it before reaching into a panel.

        E.g. ``session.open_panel("control")["panel"].run()``."""
        with self._build_lock:
            spec = next((s for s in self._panel_specs if s.name == name), None)
            generation = self.generation
            if (spec is not None and self._unbuilt.get(name) == generation and self.dynamics is not None
                    and not self.closed):
                self._build_panel(spec, generation)
        return self.state.get(name, {})

    def _clear_panels(self, robot) -> None:
        """Right after a switch, the panels rebuilt per robot show that the new model is being
        derived (never the previous robot's matrices under the new robot's title). While panels
        are being built in another thread, that builder does it when it notices the switch."""
        if not self._build_lock.acquire(blocking=False):
            return
        try:
            for spec in self._panel_specs:
                if spec.name not in self._tab_handles or not spec.rebuild:
                    continue
                with self._empty_tab(spec.name):
                    self.gui.add_html(mathml.label_html(f"Deriving the model of {robot.title} ..."))
        finally:
            self._build_lock.release()

    def _empty_tab(self, name: str):
        """An empty container in the tab of panel ``name``: everything a panel adds goes into one
        label-less folder (viser draws no header or border for it), removed with its contents."""
        old = self._tab_boxes.pop(name, None)
        if old is not None:
            old.remove()
        with self._tab_handles[name]:
            box = self._tab_boxes[name] = self.gui.add_folder(None)
        return box

    @staticmethod
    def _safe_applies(spec: PanelSpec, robot) -> bool:
        try:
            return spec.applies_to(robot)
        except Exception:
            return False

    # ================================================================== listeners and jobs
    def _add_listener(self, kind: str, callback) -> None:
        owner = getattr(self._owner, "name", None)
        with self._lock:
            self._listeners[kind].append((owner, callback))

    def _drop_listeners(self, owner: str) -> None:
        with self._lock:
            for kind in self._listeners:
                self._listeners[kind] = [(o, cb) for o, cb in self._listeners[kind] if o != owner]

    def _fire(self, kind: str, value) -> None:
        with self._lock:
            if kind != "robot" and (self.numeric is None or self.closed):   # a robot is loading
                return
            callbacks = list(self._listeners[kind])
        for owner, cb in callbacks:
            try:
                cb(value)
            except UserError as exc:
                self.notify("Input problem", str(exc), error=True)
            except Exception:
                self._internal_error(None, owner)

    def _internal_error(self, exc=None, owner=None) -> None:
        detail = traceback.format_exc(limit=4)
        print(detail, flush=True)
        where = f" in panel {owner}" if owner else ""
        last = detail.strip().splitlines()[-1] if detail.strip() else repr(exc)
        self.notify(f"Internal error{where}", last, error=True)

    def close(self) -> None:
        """The browser tab went away: stop background work and GUI updates."""
        with self._lock:
            self.closed = True
            for field in self._param_fields.values():
                field.close()
            if self._reports is not None:
                self._reports.shutdown(wait=False)
        self._jobs.shutdown()
