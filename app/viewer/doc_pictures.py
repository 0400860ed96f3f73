"""The pictures of docs/screenshots/ that show the page, in one place: ``python -m app screenshot
--all-docs`` makes them all (``save_all``). Each picture drives the real page in headless
Chromium (app/viewer/screenshot.py) and reaches a panel only through what it keeps in
``session.state`` (the Control panel, the Exercises panel, the Throw studio), never by importing
it: the server passed in has the panels (``app.commands.serve.lab_server``).
"""
from __future__ import annotations

import threading
from pathlib import Path
from typing import Dict, List, Optional

import numpy as np

from app.viewer.screenshot import (Browser, capture, close_tab, hide_notifications, new_session, project, select_tab,
                                   settle, wait_ready, wait_until)

DOCS_DIR = Path(__file__).resolve().parents[2] / "docs" / "screenshots"

#: a robot with a tab open: (file, robot, tab, coordinates or None, step index or None); a tuple
#: of names picks the first robot whose name starts with one of them
PAGE_SHOTS = [
    ("rp_2004_03_25_model.png", "rp_2004_03_25", "Model", [0.5, 0.25], None),
    ("spatial_3r_model.png", ("spatial_3r", "viewer_demo_spatial_3r"), "Model", None, None),
    ("throwing_arm_model.png", "throwing_arm", "Model", None, None),
    ("planar_2r_steps.png", "planar_2r", "Steps", [0.6, 0.9], 3),
]

# ====================================================================== Control tab
#: file -> (robot, the Control panel's configure() arguments, time shown, panel scroll in pixels,
#: picture height)
CONTROL_SHOTS = {
    "planar_2r_computed_torque.png": ("planar_2r", dict(controller="computed_torque", mismatch="m2=3, I2=0.15",
                                                        reference="sine amplitude=0.6,0.8 f=0.5,0.35", duration=6),
                                      2.3, 520, 900),
    "planar_2r_adaptive.png": ("planar_2r", dict(controller="adaptive", mismatch="m2=3, I2=0.15",
                                                 reference="sine amplitude=0.6,0.8 f=0.5,0.35", duration=10),
                               0.45, 880, 1060),
    # the plots of an adaptive run beside a kept computed-torque run with the same mismatch, and
    # the grey time marker at the replay's time
    "planar_2r_comparison.png": ("planar_2r", dict(controller="adaptive", mismatch="m2=3, I2=0.15",
                                                   reference="sine amplitude=0.6,0.8 f=0.5,0.35", duration=6,
                                                   compare_with=dict(controller="computed_torque")),
                                 2.3, 560, 1000),
}


def control_picture(out, robot: str, settings: Dict, t_show: float, scroll: int, lab, browser=None,
                    height: int = 900, q=None) -> Path:
    """Run a controller in the page from q (default 0) and save the robot (at ``t_show``, with the
    reference ghost) and the plots (the panel scrolled by ``scroll`` pixels) as a PNG. A
    ``compare_with`` entry of ``settings`` (fields that differ) runs first and is kept for comparison."""
    settings = dict(settings)
    compare_with = settings.pop("compare_with", None)

    def setup(session):
        session.set_q(np.zeros(session.robot.n) if q is None else q)
        panel = session.open_panel("control")["panel"]
        if compare_with is not None:        # a first run kept for comparison: the same fields but these
            panel.configure(**{**settings, **compare_with})
            panel.run(wait=True)
            panel.keep_for_comparison()
        panel.configure(**settings)
        panel.run(wait=True)
        panel.show_time(t_show)

    def action(page):
        page.mouse.move(1070, 600)
        page.mouse.wheel(0, scroll)
        page.wait_for_timeout(800)
        page.mouse.move(5, 5)

    return capture(robot, out, panel="Control", setup=setup, action=action, height=height, lab=lab, browser=browser)


# ====================================================================== Exercises tab
#: (file, exercise ids to try in order, what to fall back on among the shipped exercises, title of
#: the step shown, camera zoom: mouse-wheel pixels)
EXERCISE_SHOTS = [
    ("exercise_planar_rp.png", ["2004-03-25#1"], "planar RP", "Kinematics of link2", 0),
    ("exercise_spatial_3r.png", ["2024-06-12#1", "2017-03-29-mid#1"], "spatial 3R", "Kinematics of link2", 1200),
    ("exercise_underactuated.png", ["2018-03-27#1"], "underactuated", "Reduced equation", 0),
    ("exercise_sns.png", ["2020-06-05#1", "2019-04-29-mid#6"], "sns", "SNS solution", 0),
]


def _matches(ex, robot, kind: str) -> bool:
    joints = "".join("R" if b.joint.type == "revolute" else "P" for b in robot.bodies if b.joint.type != "fixed")
    if kind == "planar RP":
        return robot.is_planar and joints == "RP"
    if kind == "spatial 3R":
        return not robot.is_planar and joints == "RRR"
    if kind == "underactuated":
        return not all(robot.actuated) or "underactuated" in ex.topics
    return kind in ex.topics


def doc_exercise(candidates: List[str], kind: str):
    """The first shipped exercise among ``candidates``, else the first one of that ``kind`` (None
    when there is none)."""
    from app.core.exercise import EXERCISES_DIR, load_exercise
    from app.core.robot import load_robot
    for ex_id in candidates:
        try:
            return load_exercise(ex_id)
        except Exception:      # not shipped (yet)
            continue
    for path in sorted(EXERCISES_DIR.glob("*.yaml")):
        if path.name.endswith(".expected.yaml"):
            continue
        try:
            ex = load_exercise(path)
        except Exception:
            continue
        if _matches(ex, load_robot(ex.robot_ref), kind):
            return ex
    return None


def exercise_picture(out, exercise_id: str, step_title: str, zoom: int = 0, lab=None, browser=None,
                     height: int = 960) -> Path:
    """A walkthrough mid-way: the exercise open at the first step called ``step_title`` (its 3D
    hints drawn), the side panel scrolled to that step, the camera moved closer by ``zoom``."""
    from app.core.exercise import load_exercise
    ex = load_exercise(exercise_id)
    shown = {}

    def setup(session):
        shown["session"] = session
        panel = session.open_panel("exercises")["panel"]
        panel.open(ex.id)
        deadline = 120
        while panel.solution is None and deadline > 0:
            threading.Event().wait(0.1)
            deadline -= 0.1
        if panel.solution is None:
            raise RuntimeError(f"{ex.id} was not solved in time")
        titles = [st.title for st in panel.solution.steps]
        panel.show(titles.index(step_title) if step_title in titles else len(titles) // 2)

    def action(page):
        page.evaluate("() => document.querySelector('.r2-step[data-step]').scrollIntoView({block: 'end'})")
        if zoom:                          # towards the middle of the robot
            session = shown["session"]
            centre = session.drawing.framing(session.q).center
            x, y = project(session.scene.camera, [centre])[0]
            page.mouse.move(float(x), float(y))
            page.mouse.wheel(0, -zoom)
        page.wait_for_timeout(600)
        page.mouse.move(5, 5)

    return capture(ex.robot_ref, out, panel="Exercises", setup=setup, action=action, height=height, lab=lab,
                   browser=browser)


# ====================================================================== Throw studio
#: file -> (throw, time shown [fraction of the swing + flight], what to show: "page" (the whole
#: page) or "phase" (the phase portrait only))
THROW_SHOTS = {
    "throw_studio.png": ("throw1", 0.55, "page"),
    "throw_phase_portrait.png": ("throw1", 0.0, "phase"),
}


def throw_picture(out: Path, name: str, fraction: float, what: str, lab, browser) -> Path:
    """The Throw studio showing the shipped throw ``name`` at ``fraction`` of its time."""
    from app.core.throw.config import load_throw_config
    lab.initial_robot = "throwing_arm"
    # the phase portrait alone at twice the pixel density, so that its lines are crisp
    page = browser.page(lab.url, 1280, 1000 if what == "page" else 720, 1 if what == "page" else 2)
    try:
        wait_ready(page, "throwing_arm")
        session = new_session(lab, page)
        hide_notifications(page)
        select_tab(page, "Throw studio")
        studio = session.open_panel("throw")["studio"]
        shown = studio.shown
        studio.load_config(load_throw_config(name), play=False)
        wait_until(lambda: studio.shown > shown, what="the Throw studio to show the throw")
        settle(page, 0.5)
        studio.frame()
        studio.show_time(fraction * studio.drawing.end_time())
        if what == "page":
            page.evaluate("() => document.querySelector('.r2-throw-badge')"
                          ".scrollIntoView({block: 'start', inline: 'nearest'})")
            settle(page, 2.0)
            page.screenshot(path=str(out))
        else:
            page.get_by_text("Phase portrait θ̇(θ)").first.scroll_into_view_if_needed()
            settle(page, 1.5)
            legend = page.locator(".r2-plot-legend", has_text="Phase portrait").first.bounding_box()
            plot = page.locator(".uplot").nth(list(studio.plots).index("phase")).bounding_box()
            left, top, right = plot["x"] - 4, legend["y"] - 6, plot["x"] + plot["width"] + 2
            page.screenshot(path=str(out), clip={"x": left, "y": top, "width": right - left,
                                                 "height": plot["y"] + plot["height"] - top + 8})
    finally:
        close_tab(page)
    return out


# ====================================================================== all of them
def save_all(lab, shoot, out_dir: Optional[Path] = None, browser: Optional[Browser] = None) -> List[Path]:
    """Every picture above into ``out_dir`` (docs/screenshots/), printing each; ``lab`` is a server
    with the panels, ``shoot(robot, out, tab, q, step, lab=, browser=)`` makes a ``PAGE_SHOTS``
    picture (app/commands/screenshot.py's ``shoot``). A picture whose robot or exercise is not
    shipped is skipped with a message."""
    from app.core.robot import list_robot_names
    out_dir = Path(out_dir or DOCS_DIR)
    out_dir.mkdir(parents=True, exist_ok=True)
    names = list_robot_names()
    paths = []
    own_browser = browser is None
    browser = browser or Browser()

    def done(path, what):
        print(f"{path}  ({what})", flush=True)
        paths.append(path)

    try:
        for filename, robot, tab, q, step in PAGE_SHOTS:
            if isinstance(robot, tuple):    # the first robot whose name starts with one of these
                robot = next((n for prefix in robot for n in names if n.startswith(prefix)), None)
                if robot is None:
                    print(f"skipped {filename}: no such robot yet")
                    continue
            done(shoot(robot, out_dir / filename, tab, q, step, lab=lab, browser=browser), robot)
        for filename, (robot, settings, t_show, scroll, height) in CONTROL_SHOTS.items():
            done(control_picture(out_dir / filename, robot, settings, t_show, scroll, lab, browser, height),
                 "Control")
        for filename, candidates, kind, step_title, zoom in EXERCISE_SHOTS:
            ex = doc_exercise(candidates, kind)
            if ex is None:
                print(f"skipped {filename}: no {kind} exercise shipped yet")
                continue
            done(exercise_picture(out_dir / filename, ex.id, step_title, zoom, lab, browser), ex.id)
        for filename, (name, fraction, what) in THROW_SHOTS.items():
            done(throw_picture(out_dir / filename, name, fraction, what, lab, browser), "Throw studio")
    finally:
        if own_browser:
            browser.close()
    return paths
