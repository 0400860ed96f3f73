"""The lab's web server: a viser server whose every browser tab gets its own ``Session``.

>>> lab = LabServer(port=0, verbose=False)
>>> lab.url.startswith("http://127.0.0.1:")
True
>>> lab.stop()
"""
from __future__ import annotations

import contextlib
import io
import os
import re
import threading
import time
import traceback
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Dict, List, Optional, Tuple

import viser

from app.core.robot import RobotModel, list_robot_names, load_robot, robot_path
from app.viewer.guard import HandshakePolicy, guard_widget_updates, handshake_checked, widget_name
from app.viewer import url_state
from app.viewer.panel_api import PanelRegistry
from app.viewer.session import Session
from app.viewer.worker import FairSlots, WorkerPool

DEFAULT_ROBOT = "planar_2r"
IDLE_QUIET = 1.0      # seconds after a tab asked for a robot before the warm-up goes on (LabServer.idle)
IDLE_START = 10.0     # seconds the warm-up of every robot waits for the first tab


@dataclass(frozen=True)
class RobotInfo:
    """What the robot picker shows about a robot file (and searches in)."""
    name: str
    title: str
    group: str
    description: str
    dof: int
    joints: str = ""          # joint letters from the base: "RP", "RRR"
    date: str = ""            # the exam's date, 2004-03-25, when the robot comes from one

    @property
    def family(self) -> str:
        """``RP``, ``PRP``; repeated letters counted: ``3R`` for RRR.

        >>> RobotInfo("x", "x", "exam", "", 3, "RRR").family, RobotInfo("y", "y", "exam", "", 2, "RP").family
        ('3R', 'RP')
        """
        j = self.joints
        return f"{len(j)}{j[0]}" if len(j) > 1 and len(set(j)) == 1 else j

    def sort_key(self):
        """Picker order: by number of joints, family, exam date, title."""
        return (len(self.joints), self.family, self.date, self.title.lower(), self.name)

    def matches(self, query: str) -> bool:
        """Whether every word of ``query`` is in the name, title, family (``3R`` or ``RRR``) or
        exam date (``2004-03-25``, ``2004``).

        >>> info = RobotInfo("rp_2004_03_25", "Planar RP (exam 2004-03-25)", "exam", "", 2, "RP", "2004-03-25")
        >>> info.matches("rp 2004"), info.matches("planar 03-25"), info.matches("3R")
        (True, True, False)
        """
        haystack = " ".join((self.name, self.title, self.family, self.joints, self.date)).lower()
        return all(word in haystack for word in query.lower().split())


def robot_info(name: str, robot: RobotModel) -> RobotInfo:
    """The picker's entry of a robot file."""
    joints = "".join({"revolute": "R", "prismatic": "P"}.get(b.joint.type, "") for b in robot.bodies)
    found = re.search(r"(\d{4})[-_](\d{2})[-_](\d{2})", name) or re.search(r"(\d{4})-(\d{2})-(\d{2})", robot.title)
    date = "-".join(found.groups()) if found else ""
    return RobotInfo(name, robot.title, robot.group, robot.description, robot.n, joints, date)


class LabServer:
    """Serves the lab on ``host:port`` (port 0 picks a free one). Robots are loaded once and shared
    by all sessions (reloaded when their file changes); each tab has its own state. Requests and
    widget values are checked as app/viewer/guard.py says (beyond loopback, ``url`` holds the
    per-server token). ``panels`` are the page's tabs (``app.panels.registry()``; none when not
    given: the viewer does not know the panels)."""

    def __init__(self, host: str = "127.0.0.1", port: int = 8080, robot: Optional[str] = None,
                 verbose: bool = True, panels: PanelRegistry = PanelRegistry()):
        self.panels = panels
        self._robots: Dict[str, Tuple[float, RobotModel]] = {}
        self._drawings: Dict[int, Tuple[RobotModel, object]] = {}   # id(robot) -> (robot, its default drawing)
        self._last_load = 0.0          # time.monotonic() of the last robot a tab asked for (warm_up's idle)
        self._catalog: Dict[str, Tuple[float, RobotInfo]] = {}
        self._catalog_lock = threading.Lock()     # one reader builds it; a tab opening meanwhile waits
        self._lock = threading.Lock()
        self.sessions: Dict[int, Session] = {}
        self.stopped = False
        self.warmed = threading.Event()    # every robot was warmed (warm_up)
        names = list_robot_names()
        if robot is not None:
            self.robot(robot)          # fail early (UserError) on an unknown robot
        self.initial_robot = robot or (DEFAULT_ROBOT if DEFAULT_ROBOT in names else names[0])
        self.verbose = verbose
        self.max_jobs = max(1, os.cpu_count() or 1)
        self._job_slots = FairSlots(self.max_jobs)    # in turn: no tab's job waits behind another's for ever
        self.workers = WorkerPool(self.max_jobs)     # heavy jobs' processes (app/viewer/worker.py)
        self.checks = WorkerPool(1)                  # the pinocchio badges' cross-checks
        self.policy = HandshakePolicy(host)
        self.page_requests = url_state.PageRequests()    # a new tab's address before it reports it
        with self._quiet(), handshake_checked(self.policy, self.page_requests.note):
            self.viser = viser.ViserServer(host=host, port=port, label="Robotics II Lab", verbose=verbose)
        guard_widget_updates(self.viser.gui, lambda handle, reason: None)
        self.viser.on_client_connect(self._connect)
        self.viser.on_client_disconnect(self._disconnect)

    @property
    def url(self) -> str:
        host = self.viser.get_host()
        shown = "127.0.0.1" if host in ("0.0.0.0", "") else host
        token = f"/{self.policy.token}/" if self.policy.token else ""
        return f"http://{shown}:{self.viser.get_port()}{token}"

    def stop(self) -> None:
        self.stopped = True
        for session in list(self.sessions.values()):
            session.close()
        self.workers.close()
        self.checks.close()
        with self._quiet():
            self.viser.stop()

    def _quiet(self):
        """Silence viser's banner and stop message unless verbose."""
        return contextlib.nullcontext() if self.verbose else contextlib.redirect_stdout(io.StringIO())

    # ------------------------------------------------------------------ robots
    def robot(self, name: str) -> RobotModel:
        """The robot named ``name`` (cached; reloaded when its file changed)."""
        path = robot_path(name)
        mtime = Path(path).stat().st_mtime
        with self._lock:
            cached = self._robots.get(name)
        if cached is not None and cached[0] == mtime:
            return cached[1]
        robot = load_robot(name)
        with self._lock:
            self._robots[name] = (mtime, robot)
        return robot

    def catalog(self) -> List[RobotInfo]:
        """Every shipped robot in the picker's order (files are read again only when they change);
        broken files are left out of the picker (``python -m app check NAME`` says what is wrong)."""
        with self._catalog_lock:
            return self._read_catalog()

    def _read_catalog(self) -> List[RobotInfo]:
        out = []
        for name in list_robot_names():
            try:
                mtime = robot_path(name).stat().st_mtime
                cached = self._catalog.get(name)
                if cached is None or cached[0] != mtime:
                    r = self.robot(name)
                    cached = (mtime, robot_info(name, r))
                    self._catalog[name] = cached
                out.append(cached[1])
            except Exception:    # a file being written by someone else, or broken: skip it
                continue
        return sorted(out, key=RobotInfo.sort_key)

    def drawing(self, robot: RobotModel):
        """The drawing of ``robot`` at its file's parameter values (made once per loaded robot;
        a drawing never changes once made, so the tabs share it).

        >>> lab = LabServer(port=0, verbose=False)
        >>> robot = lab.robot("planar_2r")
        >>> lab.drawing(robot) is lab.drawing(robot)
        True
        >>> lab.stop()
        """
        from app.scene import RobotDrawing
        with self._lock:
            cached = self._drawings.get(id(robot))
        if cached is not None and cached[0] is robot:
            return cached[1]
        drawing = RobotDrawing(robot)
        with self._lock:
            self._drawings = {k: v for k, v in self._drawings.items()
                              if any(v[0] is r for _, r in self._robots.values())}    # robots reloaded since
            self._drawings[id(robot)] = (robot, drawing)
        return drawing

    def note_load(self) -> None:
        """A tab asks for a robot now (the idle warm-up keeps out of its way)."""
        self._last_load = time.monotonic()

    def idle(self) -> bool:
        """No tab is loading a robot or building its panels, and none asked for one in the last
        IDLE_QUIET seconds."""
        if time.monotonic() - self._last_load < IDLE_QUIET:
            return False
        return all(session.ready.is_set() or session.closed for session in list(self.sessions.values()))

    def warm_robot(self, name: str) -> bool:
        """Do ahead what a switch to ``name`` would compute, when its model is in the disk cache
        (a robot never derived is left to its first switch, which shows its progress): the robot
        file, its drawing, its model, and each panel's ``warm`` (compiled functions, typeset
        formulas). True when warmed."""
        from app.core.dynamics import derive, is_derived
        robot = self.robot(name)
        self.drawing(robot)
        if not is_derived(robot):
            return False
        dynamics = derive(robot)
        for spec in self.panels.specs:
            if spec.warm is not None and spec.applies_to(robot):
                spec.warm(robot, dynamics)
        return True

    def warm_up(self, *extra: Callable[[], object], every_robot: bool = False) -> threading.Thread:
        """Read in a background thread what the first tab needs (issue 16: a page that answers at
        once): the robot picker's catalog (every robot file), the first robot's model (from the
        disk cache, or derived) and drawing, then each of ``extra`` (the panels' own lists). The
        server answers meanwhile; a tab that opens early waits only for what is still missing.
        Then, with ``every_robot``, whenever the server is idle (``idle``: after the first tab is
        ready, or IDLE_START seconds without one), every other robot is warmed (``warm_robot``),
        the largest first: a first switch to it then costs what a second one does."""
        def work():
            try:
                self.catalog()
                from app.core.dynamics import derive
                robot = self.robot(self.initial_robot)
                self.drawing(robot)
                derive(robot)
                for fn in extra:
                    fn()
            except Exception:         # the tab that needs it will say what is wrong
                pass
            if every_robot:
                self._warm_every_robot()
        thread = threading.Thread(target=work, name="warm-up", daemon=True)
        thread.start()
        return thread

    def _warm_every_robot(self) -> None:
        started = time.monotonic()
        while not self.sessions and time.monotonic() - started < IDLE_START and not self.stopped:
            time.sleep(0.1)
        names = [info.name for info in sorted(self.catalog(), key=lambda info: -info.dof)]
        for name in names:
            while not self.idle() and not self.stopped:
                time.sleep(0.1)
            if self.stopped:
                return
            try:
                self.warm_robot(name)
            except Exception:         # a switch to it will say what is wrong
                continue
        self.warmed.set()

    # ------------------------------------------------------------------ jobs
    def limited(self, fn: Callable) -> Callable:
        """``fn(progress, ...)`` that first waits for one of the server's ``max_jobs`` job slots
        (one per core: more heavy jobs at once only slow every tab down), saying so through
        ``progress`` while it waits. Heavy work inside runs in ``workers``, one process per slot.

        >>> lab = LabServer(port=0, verbose=False)
        >>> lab.limited(lambda progress, x: 2 * x)(lambda f, m="": None, 21)
        42
        >>> lab.stop()
        """
        def run(progress, *args, **kwargs):
            self._job_slots.acquire(lambda: progress(0.0, f"waiting: the server already runs {self.max_jobs} "
                                                          "long computations"))
            try:
                return fn(progress, *args, **kwargs)
            finally:
                self._job_slots.release()
        return run

    # ------------------------------------------------------------------ sessions
    def _connect(self, client) -> None:
        def refused(handle, reason):
            client.add_notification("Value refused", f"{widget_name(handle)}: {reason}.",
                                    color="red", with_close_button=True)
        guard_widget_updates(client.gui, refused)
        try:
            session = Session(self, client)
        except Exception as exc:       # a bug must not leave a blank page without a word
            traceback.print_exc()
            client.add_notification("The page could not be built", f"{type(exc).__name__}: {exc}",
                                    color="red", with_close_button=True)
            return
        self.sessions[client.client_id] = session

    def _disconnect(self, client) -> None:
        session = self.sessions.pop(client.client_id, None)
        if session is not None:
            session.close()
