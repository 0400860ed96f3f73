"""A seeded walk through the page as a student would use it, checking the page after every action.

``Walk(lab, browser, seed).run(actions)`` opens a tab and performs random user actions (pick a
robot, switch tab, drag a slider, type a parameter (valid or not), run and switch a controller,
reveal steps, open an exercise and a variant, play a throw, reload). After each one it checks:

- every drawn link starts at its joint and ends at its child's joint or its named point, where
  pinocchio's forward kinematics (``PinocchioTwin.body_frames``, not the drawing's own symbolic
  frames) puts them at the configuration drawn; the poses are those the browser holds for the
  scene nodes, and no node of an earlier drawing is left in the browser;
- the header and the Model panel belong to the selected robot;
- a good parameter value reaches the model, a bad one is refused and the field restored;
- a reload shows the robot of the address and, unless an exercise (which sets its own values)
  is open, the parameters the address holds (``p.m1=...``) and the robot file's for the others;
- no exception in the server's output, no ``pageerror`` in the browser;
- the page answers (the tab is ready again) within ``ANSWER_SECONDS`` (longer while a model is
  derived for the first time).

tests/test_browser_page.py runs a short walk; ``python -m benchmarks.soak --seed S --actions N``
a long one.
"""
from __future__ import annotations

import io
import random
import re
import sys
import threading
import time
from dataclasses import dataclass, field
from typing import Callable, Dict, List, Optional

import numpy as np

from app.scene import _rot, _vec
from app.viewer import screenshot as shots
from app.viewer import url_state

ANSWER_SECONDS = 15.0         # the page is ready again after an action within this time (generous:
                              # a 2-core machine shared with other jobs)
DERIVE_SECONDS = 120.0        # ... or this, while a model is derived for the first time
TOLERANCE = 1e-6              # metres between a drawn link end and its joint (scale ~1 m)
#: robots of a short walk (derived quickly) and of the soak (all kinds of joints and drawings)
SHORT_POOL = ("planar_2r", "rp_2004_03_25", "cartesian_pp_payload", "catching_arm", "elastic_2r",
              "polar_2r_2016_06_06")
SOAK_POOL = SHORT_POOL + ("throwing_arm", "spatial_3r_2024_06_12", "planar_3r", "prr_2014_10_27", "ppr_2020_04_15",
                          "viewer_demo_spatial_3r", "dh_twist_rr", "rrr_2019_04_29")
#: exercises a walk may open (robot in the pools), and a variant's field and value
EXERCISES = ("2004-03-25#1",)
ERROR_MARKERS = ("Traceback (most recent call last)", "Task failed with exception", "Callback failed",
                 "Internal error")


# ====================================================================== server output
class ServerLog:
    """Copies what the process writes to stdout and stderr while active, and counts tracebacks
    (the server's callbacks run in this process)."""

    def __init__(self):
        self.text = io.StringIO()
        self._lock = threading.Lock()

    def __enter__(self):
        self._saved = sys.stdout, sys.stderr
        sys.stdout, sys.stderr = _Tee(sys.stdout, self), _Tee(sys.stderr, self)
        return self

    def __exit__(self, *exc):
        sys.stdout, sys.stderr = self._saved

    def write(self, text: str) -> None:
        with self._lock:
            self.text.write(text)

    def errors(self) -> List[str]:
        """Lines that show an exception, in order."""
        with self._lock:
            lines = self.text.getvalue().splitlines()
        return [line for line in lines if any(m in line for m in ERROR_MARKERS)]


class _Tee:
    def __init__(self, stream, log: ServerLog):
        self.stream, self.log = stream, log

    def write(self, text):
        self.log.write(text)
        return self.stream.write(text)

    def flush(self):
        self.stream.flush()

    def __getattr__(self, name):
        return getattr(self.stream, name)


# ====================================================================== invariants
_FRAMES_JS = """(names) => { const refs = window.__viserMutable.nodeRefFromName; const out = {};
  for (const n of names) { const o = refs[n]; if (!o) { out[n] = null; continue; }
    out[n] = [o.position.x, o.position.y, o.position.z, o.quaternion.w, o.quaternion.x, o.quaternion.y,
              o.quaternion.z]; }
  return out; }"""


def _matrix(pose) -> np.ndarray:
    x, y, z, w, qx, qy, qz = pose
    R = np.array([[1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - w * qz), 2 * (qx * qz + w * qy)],
                  [2 * (qx * qy + w * qz), 1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz - w * qx)],
                  [2 * (qx * qz - w * qy), 2 * (qy * qz + w * qx), 1 - 2 * (qx * qx + qy * qy)]])
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, (x, y, z)
    return T


_TWINS: Dict[tuple, object] = {}


def _twin(robot, values):
    from app.core.numeric import PinocchioTwin
    key = (robot.content_hash or robot.name, tuple(sorted(values.items())))
    if key not in _TWINS:
        if len(_TWINS) > 64:
            _TWINS.clear()
        _TWINS[key] = PinocchioTwin(robot, values)
    return _TWINS[key]


def link_violations(page, session) -> List[str]:
    """Links drawn away from their joints, in the browser, against pinocchio at the drawn q
    (empty when the drawing is right)."""
    with session._lock:                      # one consistent state of the server
        drawing, scene = session.scene.drawing, session.scene
        if drawing is None or scene.q is None:
            return []
        root = scene.robot_root
        q = scene.q.copy()
    robot = drawing.robot
    frames = _twin(robot, drawing.values).body_frames(q)
    names = [f"{root}/{b.name}{suffix}" for b in robot.bodies for suffix in ("", "__joint")]
    poses = page.evaluate(_FRAMES_JS, [root, "/robot"] + names)
    problems = []
    for name in (root, "/robot"):
        pose = poses.get(name)
        if pose is None or np.max(np.abs(_matrix(pose) - np.eye(4))) > TOLERANCE:
            problems.append(f"{name} is not at the origin in the browser ({pose})")
    stale = [n for n in shots.scene_node_names(page) if n.startswith("/robot/") and not
             (n == root or n.startswith(root + "/"))]
    if stale:
        problems.append(f"nodes of an earlier drawing are still in the browser: {stale[:4]}")
    scale = max(1.0, drawing.scale)
    for body in robot.bodies:             # the joint frames (sleeves, joint cylinders, labels)
        pose = poses.get(f"{root}/{body.name}__joint")
        parent = frames[body.parent] if body.parent else np.eye(4)
        pre = np.eye(4)
        pre[:3, :3], pre[:3, 3] = _rot(body.joint.pre.R, drawing._subs), _vec(body.joint.pre.p, drawing._subs)
        if pose is None or np.max(np.abs(_matrix(pose) - parent @ pre)) > TOLERANCE * scale:
            problems.append(f"the joint of {body.name} is drawn away from where pinocchio puts it "
                            f"at q = {np.round(q, 4).tolist()}")
    for body in robot.bodies:
        bars = [p.segment for p in drawing.parts if p.role == "link" and p.body == body.name and
                p.name.startswith("bar")]
        pose = poses.get(f"{root}/{body.name}")
        if not bars:
            continue
        if pose is None:
            problems.append(f"{body.name}: no node in the browser")
            continue
        drawn = _matrix(pose)
        ends = [drawn[:3, :3] @ e + drawn[:3, 3] for a, b in bars for e in (a, b)]
        W = frames[body.name]
        joint_at = W[:3, :3] @ bars[0][0] + W[:3, 3]       # bars[0] starts at the joint (app/scene.py)
        if np.linalg.norm(ends[0] - joint_at) > TOLERANCE * scale:
            problems.append(f"{body.name} starts {np.linalg.norm(ends[0] - joint_at):.3g} m away from its "
                            f"joint at q = {np.round(q, 4).tolist()}")
        # a child's joint sits at its offset in this body (a prismatic child slides away from it)
        targets = [(f"joint of {c.name}", W[:3, :3] @ _vec(c.joint.pre.p, drawing._subs) + W[:3, 3])
                   for c in robot.bodies if c.parent == body.name]
        if not targets:
            targets = [(f"point {n}", W[:3, :3] @ _vec(p.position, drawing._subs) + W[:3, 3])
                       for n, p in robot.points.items() if p.body == body.name]
        for what, at in targets:
            gap = min(np.linalg.norm(e - at) for e in ends)
            if gap > TOLERANCE * scale:
                problems.append(f"{body.name} ends {gap:.3g} m away from the {what} at q = {np.round(q, 4).tolist()}")
    return problems


def header_violations(page, session) -> List[str]:
    """The header, the status and the Model panel show the session's robot."""
    name = session.robot_name
    found = page.evaluate("""() => ({status: [...document.querySelectorAll('.r2-status')].map(e => e.dataset.robot),
                                     model: [...document.querySelectorAll('.r2-model')].map(e => e.dataset.robot)})""")
    problems = []
    if found["status"] != [name]:
        problems.append(f"status names {found['status']}, the robot is {name}")
    wrong = [m for m in found["model"] if m != name]
    if wrong:
        problems.append(f"the Model panel shows {wrong[0]} while {name} is selected")
    title = session.robot.title
    if title not in page.inner_text("body"):
        problems.append(f"the title {title!r} is not on the page")
    return problems


def parameter_box(page, session, name: str):
    """The input of a parameter field, with the Parameters folder opened if it is closed."""
    unit = session.robot.parameters[name].unit
    box = shots.field(page, f"{name} [{unit}]" if unit else name)
    shots.open_folder(page, "Parameters")
    box.wait_for(state="visible", timeout=5000)
    return box


def type_text(box, text: str) -> None:
    """Replace a field's text key by key, as a user types."""
    box.click()
    box.press("Control+a")
    box.press("Backspace")
    box.type(text, delay=30)


# ====================================================================== the walk
@dataclass
class Report:
    seed: int
    actions: int = 0
    violations: List[str] = field(default_factory=list)
    seconds: float = 0.0
    slowest: float = 0.0          # the longest wait for the page to be ready after an action [s]
    counts: Dict[str, int] = field(default_factory=dict)

    def line(self) -> str:
        done = ", ".join(f"{k} {v}" for k, v in sorted(self.counts.items()))
        return (f"seed {self.seed}: {self.actions} actions, {len(self.violations)} violations, "
                f"{self.seconds:.0f} s, slowest answer {self.slowest:.1f} s ({done})")


class Walk:
    """One browser tab walked at random (``seed``) through the page, checked after each action."""

    def __init__(self, lab, browser, seed: int, pool=SHORT_POOL, log: Optional[Callable[[str], None]] = None):
        self.lab, self.browser, self.seed = lab, browser, seed
        self.rng = random.Random(seed)
        self.pool = [n for n in pool if n in {i.name for i in lab.catalog()}]
        self.report = Report(seed)
        self.log = log or (lambda text: None)
        self.page = self.session = None
        self.page_errors: List[str] = []

    # -------------------------------------------------------------- tab
    def _open(self, url: str) -> None:
        self.page = self.browser.page(url)
        self.page.on("pageerror", lambda exc: self.page_errors.append(str(exc)))
        self.session = shots.new_session(self.lab, self.page)
        self._wait_ready(opening=True)
        shots.hide_notifications(self.page)

    def _wait_ready(self, opening: bool = False) -> None:
        """Until the tab's robot and panels are ready; a violation when it takes longer than
        ANSWER_SECONDS (DERIVE_SECONDS while a model is derived, or while the tab opens)."""
        start = time.perf_counter()
        deriving = 0.0                # time spent deriving a model for the first time: not counted
        while True:
            now = time.perf_counter()
            s = self.session
            if s.ready.is_set() and self.page.locator(
                    f'.r2-status[data-ready="1"][data-robot="{s.robot_name}"]').count() == 1:
                break
            if self._deriving():
                deriving = now - start
            limit = DERIVE_SECONDS if opening else deriving + ANSWER_SECONDS
            if now - start > min(limit, DERIVE_SECONDS):
                self._violation(f"the page did not answer within {now - start - deriving:.0f} s"
                                + (f" (after {deriving:.0f} s of derivation)" if deriving else ""))
                return
            time.sleep(0.05)
        waited = time.perf_counter() - start - deriving
        if not opening:
            self.report.slowest = max(self.report.slowest, waited)

    def _deriving(self) -> bool:
        return self.session.dynamics is None

    def _violation(self, text: str) -> None:
        entry = f"action {self.report.actions} ({self._last}): {text}"
        self.report.violations.append(entry)
        self.log("VIOLATION " + entry)

    # -------------------------------------------------------------- checks
    def check(self) -> None:
        self._wait_ready()
        for attempt in range(40):       # the browser applies updates a few frames later
            problems = link_violations(self.page, self.session) + header_violations(self.page, self.session)
            if not problems:
                break
            time.sleep(0.1)
        for text in problems:
            self._violation(text)
        errors = self.server_log.errors()[self._errors_seen:]
        self._errors_seen += len(errors)
        for line in errors:
            self._violation(f"server: {line.strip()}")
        for text in self.page_errors:
            self._violation(f"pageerror: {text}")
        self.page_errors.clear()

    # -------------------------------------------------------------- actions
    def pick_robot(self) -> None:
        name = self.rng.choice([n for n in self.pool if n != self.session.robot_name])
        info = next(i for i in self.session.picker.catalog if i.name == name)
        words = (info.date or info.family) if self.rng.random() < 0.5 else ""   # narrow the list, or not
        self._find(words)
        shots.choose(self.page, "Robot", self.session.picker.option_of(info))
        shots.wait_until(lambda: self.session.robot_name == name, 10, f"{name} to load")

    def switch_tab(self) -> None:
        titles = self.page.evaluate("() => [...document.querySelector('[role=tablist]').querySelectorAll('[role=tab]')]"
                                    ".map(e => e.textContent.trim())")
        shots.select_tab(self.page, self.rng.choice(titles))

    def drag_slider(self) -> None:
        coordinate = self.rng.choice(self.session.coordinates)
        thumb = shots.slider_thumb(self.page, coordinate)
        thumb.focus()
        for _ in range(self.rng.randint(1, 6)):
            thumb.press(self.rng.choice(["ArrowRight", "ArrowLeft", "PageUp", "PageDown", "End", "Home"]))
        self.page.wait_for_timeout(150)

    def type_parameter(self) -> None:
        s = self.session
        name = self.rng.choice(list(s.params))
        kind = s.robot.parameters[name].kind
        old = s.params[name]
        good = self.rng.random() < 0.6
        if good:
            value = abs(old) * self.rng.choice([0.5, 1.5, 2.0]) if old else 0.5
            text = f"{value:.6g}" if self.rng.random() < 0.7 else f"{value:.3e}"
        else:
            text = self.rng.choice(["abc", "", "1e", "-2" if kind in ("mass", "length", "inertia") else "x+"])
        box = parameter_box(self.page, s, name)
        shown = box.input_value()
        type_text(box, text)              # one key at a time: the field commits when typing pauses
        if good:
            expected = float(text)
            shots.wait_until(lambda: abs(s.params[name] - expected) <= 1e-12 * max(1.0, abs(expected)), 10,
                             f"{name} = {text} to be taken")
        else:
            shots.wait_until(lambda: box.input_value() == shown, 5, f"{name} field to be restored")
            if s.params[name] != old:
                self._violation(f"bad text {text!r} for {name} changed it to {s.params[name]}")

    def run_controller(self) -> None:
        if "Control" not in self._tab_titles():
            return self.pick_robot()
        shots.select_tab(self.page, "Control")
        if self.rng.random() < 0.5:
            self.switch_controller()
        self._wait_ready()
        panel = self.session.open_panel("control")["panel"]
        panel.duration.value = 0.5            # (in the closed Simulation settings folder)
        self.page.get_by_role("button", name="Run", exact=True).click()
        shots.wait_until(lambda: panel.result is not None or not panel.run_button.disabled, 30, "the run to end")

    def switch_controller(self) -> None:
        if "Control" not in self._tab_titles():
            return
        shots.select_tab(self.page, "Control")
        panel = self.session.open_panel("control")["panel"]
        titles = [t for t in panel._titles if t != panel.controller.value]
        shots.choose(self.page, "Controller", self.rng.choice(titles))
        shots.wait_until(lambda: panel.result is None and not panel._result_widgets, 5,
                         "the previous run's plots to go")

    def reveal_steps(self) -> None:
        shots.select_tab(self.page, "Steps")
        state = self.session.open_panel("steps")
        for _ in range(self.rng.randint(1, 3)):
            before = state.get("index")
            forward = self.rng.random() < 0.7
            self.page.get_by_role("button", name="Next ▶" if forward else "◀ Previous").first.click()
            count = len(self.session.dynamics.steps)
            want = min(count - 1, before + 1) if forward else max(0, before - 1)
            shots.wait_until(lambda: state.get("index") == want, 5, f"step {want + 1}")

    def open_exercise(self) -> None:
        panel = self.session.open_panel("exercises").get("panel")
        if panel is None:
            return
        exercise = self.rng.choice(EXERCISES)
        panel.open(exercise)
        shots.wait_until(lambda: self.session.ready.is_set() and
                         self.session.open_panel("exercises")["panel"].solution is not None, 60, f"{exercise} to be solved")
        panel = self.session.open_panel("exercises")["panel"]
        if self.rng.random() < 0.5:
            panel.show(self.rng.randint(0, len(panel.solution.steps) - 1))
        else:                                   # a variant: one parameter changed, then solved
            self._wait_ready()
            panel = self.session.open_panel("exercises")["panel"]    # rebuilt when the tabs changed
            names = [f.name for f, _ in panel._fields if f.name in self.session.robot.parameters]
            if names:
                name = self.rng.choice(names)
                panel.solve_variant({name: f"{abs(self.session.robot.parameters[name].value) * 1.2 + 0.1:.4g}"})
                shots.wait_until(lambda: panel.solution is not None, 60, "the variant to be solved")

    def _find(self, words: str) -> None:
        """Type into the picker's search field and wait for the list to follow."""
        s = self.session
        shots.field(self.page, "Find robot").fill(words)
        shots.wait_until(lambda: s.picker.find.value == words and len(s.picker.robots.options) ==
                         1 + sum(i.matches(words) for i in s.picker.catalog), 5, f"the robots matching {words!r}")

    def play_throw(self) -> None:
        if self.session.robot_name != "throwing_arm":
            self._find("throwing")
            info = next(i for i in self.session.picker.catalog if i.name == "throwing_arm")
            shots.choose(self.page, "Robot", self.session.picker.option_of(info))
            shots.wait_until(lambda: self.session.robot_name == "throwing_arm", 10, "the throwing arm")
            self._wait_ready()
        title = next(t for t in self._tab_titles() if "Throw" in t)
        shots.select_tab(self.page, title)
        studio = self.session.open_panel("throw")["studio"]
        answered = studio.answered
        self.page.get_by_role("button", name=self.rng.choice(["Throw 1", "Throw 2", "Throw 3"]), exact=True).click()
        # loading a throw sets the model's parameters of its file: the next action starts after that
        shots.wait_until(lambda: studio.answered > answered, ANSWER_SECONDS, "the throw to be solved")

    def reload(self) -> None:
        old = self.session
        query = self.page.evaluate("() => location.search")
        self.page.reload()
        self.session = shots.new_session(self.lab, self.page)
        self._wait_ready(opening=True)
        shots.hide_notifications(self.page)
        shots.wait_until(lambda: old.closed, 10, "the old tab's session to close")
        wanted = url_state.parse_query(query)
        if wanted.get("robot") and self.session.robot_name != wanted["robot"]:
            self._violation(f"reload of {query} shows {self.session.robot_name}")
        elif "exercise" not in wanted:
            expected = self.session.robot.parameter_values()
            expected.update({url_state.parameter_name(k): float(v) for k, v in wanted.items()
                             if url_state.parameter_name(k)})
            wrong = {k: v for k, v in self.session.params.items() if abs(v - expected[k]) > 1e-12 * max(1.0, abs(v))}
            if wrong:
                self._violation(f"reload of {query} shows the parameters {wrong}, expected {expected}")

    def _tab_titles(self) -> List[str]:
        return self.page.evaluate("() => [...document.querySelector('[role=tablist]').querySelectorAll('[role=tab]')]"
                                  ".map(e => e.textContent.trim())")

    #: actions and their weights (the short walk of the suite leaves out the throw: the studio's
    #: tab costs seconds per switch in software WebGL)
    ACTIONS = {"pick_robot": 4, "switch_tab": 3, "drag_slider": 4, "type_parameter": 3, "run_controller": 2,
               "switch_controller": 1, "reveal_steps": 2, "open_exercise": 1, "play_throw": 1, "reload": 1}
    SHORT = {**ACTIONS, "play_throw": 0}

    def run(self, actions: int, weights: Optional[Dict[str, int]] = None) -> Report:
        """Perform ``actions`` random actions (drawn with ``weights``, default ACTIONS), checking
        the page after each; the report lists the violations."""
        names = [n for n, w in (weights or self.ACTIONS).items() for _ in range(w)]
        start = time.perf_counter()
        self._last = "open"
        with ServerLog() as self.server_log:
            self._errors_seen = 0
            try:
                self._open(shots.page_url(self.lab, f"robot={self.rng.choice(self.pool)}"))
                self.check()
                for k in range(actions):
                    self._last = self.rng.choice(names)
                    self.report.actions = k + 1
                    self.report.counts[self._last] = self.report.counts.get(self._last, 0) + 1
                    self.log(f"{k + 1}: {self._last} on {self.session.robot_name}")
                    try:
                        getattr(self, self._last)()
                    except Exception as exc:          # a timeout of the page is a violation too
                        self._violation(f"{type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}")
                    self.check()
            finally:
                if self.page is not None:
                    shots.close_tab(self.page)
        self.report.seconds = time.perf_counter() - start
        return self.report
