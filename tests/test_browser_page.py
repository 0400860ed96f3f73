"""The page under real use (issue 11): robot switches, steps, runs, reloads, typed values, the
picker, the page's address, and a seeded walk that checks the page after every action.

Each of the ten defects of issue 11 has its test here (named after it); all share the suite's
server and Chromium (tests/conftest.py). The tests that start from a robot picked in the page share
one tab (``module_tab``, tests/conftest.py) and load their robot anew in it (a new tab costs about 4 s of CPU in
software WebGL); the tests of the page's address, of a reload, of the picker's list and the walk
open their own tabs."""
import threading
import time
import uuid

import numpy as np
import pytest

from app.viewer import screenshot as shots
from app.viewer import walk
from app.viewer.walk import header_violations, link_violations


def open_page(lab, browser, query, robot):
    """A new tab on ``/?query`` (server side session too), ready and without notifications."""
    page = browser.page(shots.page_url(lab, query))
    errors = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    page.r2_errors = errors
    shots.wait_ready(page, robot)
    session = shots.new_session(lab, page)
    return page, session


def pick(page, session, name):
    """Choose a robot with the picker, as a user would, and wait until its panels are built."""
    info = next(i for i in session.picker.catalog if i.name == name)
    shots.choose(page, "Robot", session.picker.option_of(info))
    shots.wait_ready(page, name)
    session.ready.wait(60)


def assert_drawn_right(page, session):
    """No link away from its joint in the browser, against pinocchio (a few frames of delay)."""
    problems = []
    for _ in range(30):
        problems = link_violations(page, session)
        if not problems:
            return
        time.sleep(0.1)
    raise AssertionError("; ".join(problems))


def notifications(page):
    return page.evaluate("() => [...document.querySelectorAll('.mantine-Notification-root')].map(e => e.innerText)")


# ====================================================================== the ten defects
def test_links_stay_on_their_joints_after_robot_switches(module_tab):
    """Defect 1: a robot drawn after another kept the previous robot's node poses in the browser."""
    page, session = module_tab("cartesian_pp_payload", hide=False)
    assert_drawn_right(page, session)
    for name in ("rp_2004_03_25", "throwing_arm", "catching_arm", "elastic_2r"):
        pick(page, session, name)
        assert_drawn_right(page, session)
    # the elastic 2R's ghost (the control reference) sits on the robot too
    session.scene.ghost(session.q, "check")
    root = session.scene._ghosts["check"][1][""].name
    expected = session.drawing.poses(session.q)["link1"]

    def ghost_pose():
        pose = page.evaluate(walk._FRAMES_JS, [f"{root}/link1"])[f"{root}/link1"]
        return None if pose is None else walk._matrix(pose)
    # the node comes first, its pose with the next frame the browser draws
    shots.wait_until(lambda: ghost_pose() is not None and np.allclose(ghost_pose(), expected, atol=1e-9), 5,
                     "the ghost on the robot")
    assert np.allclose(ghost_pose(), expected, atol=1e-9)


def test_steps_next_and_previous_work_before_a_step_is_picked(module_tab):
    """Defect 2: Next and Previous raised KeyError 'index' until a step was picked."""
    page, session = module_tab("planar_2r", "Steps", hide=False)
    with walk.ServerLog() as log:
        page.get_by_role("button", name="Next ▶").first.click()
        page.locator('.r2-step[data-step="1"]').wait_for(state="attached", timeout=5000)
        page.get_by_role("button", name="Next ▶").first.click()
        page.locator('.r2-step[data-step="2"]').wait_for(state="attached", timeout=5000)
        page.get_by_role("button", name="◀ Previous").first.click()
        page.locator('.r2-step[data-step="1"]').wait_for(state="attached", timeout=5000)
    assert log.errors() == []


def test_switching_robot_after_a_run_leaves_no_stale_pose(module_tab):
    """Defect 3: after a run drew the 2R bent, the next robot (at q = 0) was drawn with the 2R's
    link poses until a slider moved."""
    page, session = module_tab("planar_2r", "Control", hide=False)
    panel = session.open_panel("control")["panel"]
    panel.configure("pd_gravity", reference="setpoint by=1.2,-1.5", duration=1.0)
    panel.run(wait=True)
    panel.show_time(1.0)                          # the 2R drawn bent
    assert np.max(np.abs(session.scene.q)) > 0.5
    pick(page, session, "dh_twist_rr")
    assert np.allclose(session.scene.q, session.q)
    assert_drawn_right(page, session)
    pick(page, session, "planar_2r")
    assert np.allclose(session.q, 0.0) and np.allclose(session.scene.q, 0.0)
    assert_drawn_right(page, session)


def test_model_tab_never_shows_the_previous_robots_matrices(module_tab, monkeypatch):
    """Defect 4: while a new robot's model was derived, the Model tab kept the previous M(q)."""
    import app.viewer.session as session_module
    real = session_module.derive
    derived = threading.Event()

    def slow(robot, progress=None):
        derived.wait(60)                              # a derivation that lasts until the checks are done
        return real(robot, progress=progress)

    page, session = module_tab("planar_2r", "Model", hide=False)
    page.locator('.r2-model[data-robot="planar_2r"]').wait_for(state="attached")
    monkeypatch.setattr(session_module, "derive", slow)
    try:
        session.load_robot("rp_2004_03_25")
        page.locator('.r2-status[data-robot="rp_2004_03_25"]').wait_for(state="attached")
        page.get_by_text("Deriving the model of").first.wait_for()
        assert session.dynamics is None                      # still deriving, and meanwhile ...
        assert page.locator('.r2-model[data-robot="planar_2r"]').count() == 0   # no 2R matrices under the RP
    finally:
        derived.set()
    shots.wait_ready(page, "rp_2004_03_25")
    assert header_violations(page, session) == []
    assert page.locator('.r2-model[data-robot="rp_2004_03_25"]').count() == 1


def test_a_switch_to_a_warmed_robot_compiles_reads_and_typesets_nothing(module_tab, lab, monkeypatch, tmp_path):
    """Issue 16: the server warms robots at idle (``LabServer.warm_robot``): a first switch to one
    then reads nothing from the disk cache, compiles no function, draws and typesets nothing; a
    robot not warmed does all of that (which shows the counters see it). The robots are copies of
    shipped files with a comment of their own: contents no run has seen (not in the disk cache), so that the
    test needs to forget no cache that other tests share."""
    import app.core.model_cache as model_cache
    import app.core.numeric.model as numeric_model
    import app.scene as scene
    import app.viewer.mathml as mathml
    from app.core.dynamics import derive
    from app.core.robot import load_robot, robot_path
    page, session = module_tab("planar_2r", "Model", hide=False)
    copies = {}
    for name in ("spatial_3r_2017_03_29", "rp_2004_03_25"):
        copies[name] = tmp_path / f"{name}.yaml"
        copies[name].write_text(robot_path(name).read_text(encoding="utf-8") + f"\n# a copy ({uuid.uuid4().hex})\n",
                                encoding="utf-8")
        derive(load_robot(copies[name]))                 # in the disk cache, as for a restarted server
    warmed, cold = str(copies["spatial_3r_2017_03_29"]), str(copies["rp_2004_03_25"])
    assert lab.warm_robot(warmed)
    work = {"disk": 0, "compiled": 0, "drawn": 0, "typeset": 0}

    def counted(kind, fn):
        def wrapper(*args, **kwargs):
            work[kind] += 1
            return fn(*args, **kwargs)
        return wrapper

    monkeypatch.setattr(model_cache, "read_entry", counted("disk", model_cache.read_entry))
    monkeypatch.setattr(numeric_model, "numeric_function", counted("compiled", numeric_model.numeric_function))
    monkeypatch.setattr(scene.RobotDrawing, "_build", counted("drawn", scene.RobotDrawing._build))
    monkeypatch.setattr(mathml, "blocks_html", counted("typeset", mathml.blocks_html))
    shots.reload_robot(page, session, warmed)
    assert page.locator('.r2-model[data-robot="spatial_3r_2017_03_29"]').count() == 1
    assert work == {"disk": 0, "compiled": 0, "drawn": 0, "typeset": 0}
    shots.reload_robot(page, session, cold)
    assert page.locator('.r2-model[data-robot="rp_2004_03_25"]').count() == 1
    assert work["disk"] > 0 and work["compiled"] > 0 and work["drawn"] == 1 and work["typeset"] > 0, work


def built_panels(page) -> dict:
    """Panel name -> generation of every panel built in the page (its end marker)."""
    return page.evaluate("() => Object.fromEntries([...document.querySelectorAll('.r2-panel')]"
                         ".map(e => [e.dataset.panel, Number(e.dataset.generation)]))")


def test_a_switch_builds_the_tab_on_display_and_a_click_builds_another(module_tab):
    """A robot switch builds only the panel on display (and the Exercises panel, kept across robots);
    the other tabs say they are opening and are built for the robot shown when first clicked."""
    page, session = module_tab("planar_2r", "Steps", hide=False)
    pick(page, session, "rp_2004_03_25")
    generation = session.generation
    built = built_panels(page)
    assert built.get("steps") == generation
    assert {"model", "control", "robot"}.isdisjoint(built), built     # not built for the new robot
    assert page.get_by_text("Opening the Model tab ...").count() == 1
    shots.select_tab(page, "Model")                                   # waits for the Model panel
    assert built_panels(page)["model"] == generation
    assert page.locator('.r2-model[data-robot="rp_2004_03_25"]').count() == 1
    assert page.get_by_text("Opening the Model tab ...").count() == 0
    shots.select_tab(page, "Steps")                                   # built once: not again
    page.wait_for_timeout(300)
    assert built_panels(page) == {**built, "model": generation}
    assert header_violations(page, session) == []


def test_switching_controller_clears_the_previous_run(module_tab):
    """Defect 5: the previous controller's plots and status stayed after switching controller."""
    page, session = module_tab("planar_2r", "Control", hide=False)
    panel = session.open_panel("control")["panel"]
    panel.configure("computed_torque", reference="quintic by=0.3 T=0.5", mismatch="m2=3", duration=0.5)
    panel.run(wait=True)
    page.get_by_text("completed").first.wait_for()
    assert page.locator(".uplot").count() >= 2
    shots.choose(page, "Controller", "PD + on-line gravity compensation g(q)")
    shots.wait_until(lambda: panel.result is None, 5, "the run to be cleared")
    page.wait_for_function("() => document.querySelectorAll('.uplot').length === 0", timeout=5000)
    assert "completed" not in page.inner_text("body") and "m2=3" not in page.inner_text("body")


def test_reload_cancels_the_run_and_restores_the_page(lab, browser):
    """Defect 6: a reload left the simulation running on the server and came back as planar 2R."""
    page, session = open_page(lab, browser, "robot=rp_2004_03_25&tab=control", "rp_2004_03_25")
    try:
        page.get_by_role("tab", name="Control", exact=True).wait_for()
        page.wait_for_function("() => document.querySelector('[role=tab][aria-selected=true]')"
                               ".textContent.trim() === 'Control'", timeout=10000)
        panel = session.open_panel("control")["panel"]
        panel.configure("pd_gravity", reference="sine amplitude=0.3 f=0.5", duration=120.0)
        panel.rate.value = 20000.0
        future = panel.run()
        shots.wait_until(lambda: page.get_by_text("Simulating").count() > 0, 10, "the run to start")
        page.reload()
        shots.wait_ready(page, "rp_2004_03_25")                  # the robot of the address
        new = shots.new_session(lab, page)
        shots.wait_until(future.done, 10, "the orphaned run to stop")
        result = future.result()                      # stopped early, far from its 120 s
        assert session.closed and (result is None or (not result.completed and result.t[-1] < 60.0))
        page.wait_for_function("() => document.querySelector('[role=tab][aria-selected=true]')"
                               ".textContent.trim() === 'Control'", timeout=10000)
        assert new.robot_name == "rp_2004_03_25"
    finally:
        shots.close_tab(page)


def test_pinocchio_badge_compares_relatively(module_tab):
    """Defect 7: at m1 = 1e9 the badge said "disagrees" for a round-off of 4.5e-7 (absolute)."""
    page, session = module_tab("planar_2r", hide=False)
    page.locator('.r2-badge[data-state="ok"]').wait_for(state="attached", timeout=60000)
    walk.type_text(walk.parameter_box(page, session, "m1"), "1e9")
    shots.wait_until(lambda: session.params["m1"] == pytest.approx(1e9, rel=1e-12), 5, "m1 = 1e9")
    shots.wait_until(lambda: session.numeric.values["m1"] == pytest.approx(1e9, rel=1e-12), 5, "the model")
    # the badge of a cross-check of m1 = 1e9 (the one before the change may still be shown)
    shots.wait_until(lambda: session.checked_values.get("m1") == pytest.approx(1e9, rel=1e-12), 30,
                     "a cross-check of m1 = 1e9")
    page.wait_for_function("(n) => { const b = document.querySelector('.r2-badge');"
                           " return +b.dataset.check >= n && b.dataset.state !== 'pending'; }",
                           arg=session.checks, timeout=60000)
    assert page.locator('.r2-badge[data-state="ok"]').count() == 1, page.locator(".r2-badge").inner_text()


def test_elastic_2r_control_opens_on_a_controller_that_runs(module_tab):
    """Defect 8: the elastic 2R's Control tab opened on computed torque (kept from the previous
    robot), which refused to run with a command-line hint."""
    page, session = module_tab("planar_2r", "Control", hide=False)
    session.open_panel("control")["panel"].configure("computed_torque")    # the rigid 2R's controller before the switch
    assert session.open_panel("control")["panel"]._name() == "computed_torque"
    pick(page, session, "elastic_2r")
    panel = session.open_panel("control")["panel"]
    assert panel._name().startswith("elastic")
    panel.duration.value = 0.3
    panel.run(wait=True)
    assert panel.result is not None and panel.result.completed
    assert "--passive" not in page.inner_text("body")


def test_number_fields_take_the_value_when_typing_pauses(module_tab):
    """Defect 9: '1e9' typed into the throw studio's spring became 19, with a notification per
    key; negative lengths were accepted in Parameters and exercise variants."""
    page, session = module_tab("planar_2r", hide=False)
    seen = []
    session.on_parameters_change(lambda values: seen.append(values["l1"]))
    box = walk.parameter_box(page, session, "l1")
    walk.type_text(box, "1e1")                    # "1", "1e" and "1e1" reach the server
    shots.wait_until(lambda: session.params["l1"] == pytest.approx(10.0, rel=1e-12), 5, "l1 = 10")
    shots.wait_until(lambda: seen, 5, "the model to follow")
    time.sleep(0.3)
    assert all(v == pytest.approx(10.0, rel=1e-12) for v in seen), seen        # never 1, never refused
    assert not any("Parameter" in n for n in notifications(page))
    walk.type_text(box, "-0.5")
    page.get_by_text("a length must not be negative").first.wait_for(timeout=5000)
    assert session.params["l1"] == pytest.approx(10.0, rel=1e-12) 
    assert box.input_value() == "1e1"                # the last good text is back
    pick(page, session, "throwing_arm")
    shots.select_tab(page, "Throw studio")
    studio = session.open_panel("throw")["studio"]
    page.get_by_role("tab", name="Edit", exact=True).click()
    spring = shots.field(page, "Spring k [N m/rad]")
    walk.type_text(spring, "1e9")
    shots.wait_until(lambda: studio.draft.k == pytest.approx(1e9, rel=1e-12), 5, "k = 1e9")
    assert len([n for n in notifications(page) if "Spring" in n]) <= 1


def test_picker_is_sorted_searchable_and_a_group_loads_nothing(lab, browser):
    """Defect 10: 61 unsorted entries, typing matched nothing, a group choice loaded a robot."""
    page, session = open_page(lab, browser, "robot=planar_2r", "planar_2r")
    try:
        catalog = session.picker.catalog
        assert [i.sort_key() for i in catalog] == sorted(i.sort_key() for i in catalog)
        assert list(session.picker.robots.options[1:]) == [session.picker.option_of(i) for i in catalog]
        generation = session.generation
        shots.choose(page, "Group", "Catching arm")
        shots.wait_until(lambda: len(session.picker.robots.options) == 2, 5, "the group's list")
        time.sleep(0.5)
        assert session.generation == generation and session.robot_name == "planar_2r"
        for query, expected in (("2004-03-25", "rp_2004_03_25"), ("3R 2019", "rrr_2019_04_29"),
                                ("rp 2020-06", "rp_2020_06_05")):
            shots.choose(page, "Group", "All robots")
            shots.field(page, "Find robot").fill(query)
            matching = [session.picker.option_of(i) for i in catalog if i.matches(query)]
            shots.wait_until(lambda: list(session.picker.robots.options[1:]) == matching, 5, query)
            assert session.picker.option_of(next(i for i in catalog if i.name == expected)) in matching
            assert len(matching) < len(catalog) / 4
        assert session.robot_name == "planar_2r"
        pick(page, session, "rp_2020_06_05")
    finally:
        shots.close_tab(page)


# ====================================================================== the page's address
def test_address_opens_that_page_and_follows_it(lab, browser, tmp_path):
    """``/?robot=catching_arm&tab=catch`` in a fresh tab: that robot and tab, drawn right; the
    address follows the page; unknown values give a notice and the default page."""
    page, session = open_page(lab, browser, "robot=catching_arm&tab=catch", "catching_arm")
    try:
        page.wait_for_function("() => document.querySelector('[role=tab][aria-selected=true]')"
                               ".textContent.trim() === 'Catch'", timeout=10000)
        assert_drawn_right(page, session)
        assert page.r2_errors == []
        shots.select_tab(page, "Model")
        page.wait_for_function("() => location.search === '?robot=catching_arm&tab=model'", timeout=5000)
        pick(page, session, "rp_2004_03_25")
        page.wait_for_function("() => location.search === '?robot=rp_2004_03_25&tab=model'", timeout=5000)
    finally:
        shots.close_tab(page)
    page, session = open_page(lab, browser, "robot=no_such_robot&tab=model", lab.initial_robot)
    try:
        page.get_by_text("was not understood").first.wait_for(timeout=5000)
        assert session.robot_name == lab.initial_robot
    finally:
        shots.close_tab(page)
    page, session = open_page(lab, browser, "robot=rp_2004_03_25&exercise=2004-03-25_1&step=2", "rp_2004_03_25")
    try:
        panel = session.open_panel("exercises")["panel"]
        shots.wait_until(lambda: panel.exercise is not None and panel.index == 1, 60, "step 2 of 2004-03-25#1")
        page.wait_for_function("() => location.search.includes('step=2')", timeout=5000)
    finally:
        shots.close_tab(page)


def test_changed_parameters_are_in_the_address_and_come_back_after_a_reload(lab, browser):
    """A link with ``p.m1=12.5`` opens the robot with that mass, and bad parameters in it are named
    in a notice; a typed value joins the address, a reload keeps them all, a value typed back to
    the file's leaves the address, and another robot starts from its own file's values."""
    page, session = open_page(lab, browser, "robot=planar_2r&tab=model&p.m1=12.5&p.l1=-2&p.nosuch=1", "planar_2r")
    try:
        shots.wait_until(lambda: session.numeric.values["m1"] == pytest.approx(12.5, abs=1e-12), 10, "m1 = 12.5")
        notice = next(n for n in notifications(page) if "address was not understood" in n)
        assert "p.l1=-2" in notice and "must not be negative" in notice and "p.nosuch=1" in notice
        assert session.params["l1"] == pytest.approx(session.robot.parameters["l1"].value, abs=1e-12)
        page.wait_for_function("() => location.search === '?robot=planar_2r&tab=model&p.m1=12.5'", timeout=5000)
        shots.hide_notifications(page)
        walk.type_text(walk.parameter_box(page, session, "m2"), "7")
        page.wait_for_function("() => location.search === '?robot=planar_2r&tab=model&p.m1=12.5&p.m2=7'",
                               timeout=5000)
        old = session
        page.reload()
        shots.wait_ready(page, "planar_2r")
        session = shots.new_session(lab, page)
        shots.wait_until(lambda: old.closed, 10, "the old tab's session to close")
        shots.wait_until(lambda: session.numeric.values["m2"] == pytest.approx(7, abs=1e-12), 10, "m2 = 7")
        assert session.numeric.values["m1"] == pytest.approx(12.5, abs=1e-12)
        assert walk.parameter_box(page, session, "m1").input_value() == "12.5"
        assert shots.selected_tab(page) == "Model"
        assert_drawn_right(page, session)
        walk.type_text(walk.parameter_box(page, session, "m1"), "10")          # the file's value again
        page.wait_for_function("() => location.search === '?robot=planar_2r&tab=model&p.m2=7'", timeout=5000)
        pick(page, session, "rp_2004_03_25")
        page.wait_for_function("() => location.search === '?robot=rp_2004_03_25&tab=model'", timeout=5000)
        assert session.params == session.robot.parameter_values()
        assert page.r2_errors == []
    finally:
        shots.close_tab(page)


def test_screenshot_sets_parameters_and_the_next_picture_resets_them(module_tab, lab, browser, tmp_path):
    """``python -m app screenshot --set l1=1.6``: the picture shows the robot with that link
    (drawn right, against pinocchio); the next picture, of another robot, in the same kept tab,
    has that robot's own parameters. (The module's tab stands in for a tab an earlier picture
    kept: a new tab costs seconds in software WebGL.)"""
    from app.commands.screenshot import shoot
    page, session = module_tab("planar_2r")
    key = (id(lab), 960, 540)
    browser.kept_tabs[key] = (page, session)
    try:
        first = shoot("planar_2r", tmp_path / "a.png", "model", q=[0.3, -0.6], params={"l1": 1.6},
                      width=960, height=540, lab=lab, browser=browser)
        assert first.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert browser.kept_tabs[key] == (page, session)
        assert session.numeric.values["l1"] == pytest.approx(1.6, abs=1e-12)
        assert session.q == pytest.approx([0.3, -0.6], abs=1e-12)
        assert_drawn_right(page, session)
        second = shoot("rp_2004_03_25", tmp_path / "b.png", "model", width=960, height=540, lab=lab,
                       browser=browser)
        assert second.read_bytes() != first.read_bytes()
        assert browser.kept_tabs[key] == (page, session) and session.robot_name == "rp_2004_03_25"
        assert session.params == session.robot.parameter_values()
        assert_drawn_right(page, session)
    finally:
        browser.kept_tabs.pop(key, None)           # the module's tab: closed by its fixture


def test_a_clicked_tab_stays_when_a_panel_writes_the_address(module_tab):
    """Found by the walk: a tab clicked by the student jumped back to the previous one when a
    panel wrote the address (a step revealed) before the page had told the server of the click."""
    page, session = module_tab("planar_2r", "Model", hide=False)
    for title in ("Steps", "Control", "Robot"):
        shots.select_tab(page, title)
        session.remember(step=None)              # at once: the click's report is still on its way
        page.wait_for_timeout(400)
        assert shots.selected_tab(page) == title
        shots.wait_until(lambda: session.url.get("tab") == title.lower(), 5, f"tab={title.lower()} in the address")
    pick(page, session, "rp_2004_03_25")        # same tabs: the choice stays across a switch
    assert shots.selected_tab(page) == "Robot"
    pick(page, session, "throwing_arm")          # other tabs: rebuilt, and the address's tab selected again
    shots.wait_until(lambda: shots.selected_tab(page) == "Robot", 10, "the Robot tab selected again")


# ====================================================================== the walk
WALK_SEED = 11


def test_walk_through_the_page_breaks_no_invariant(lab, browser):
    """A seeded walk of 60 random user actions, the page checked after each (app/viewer/walk.py)."""
    report = walk.Walk(lab, browser, WALK_SEED).run(60, walk.Walk.SHORT)
    print(report.line())
    assert report.violations == [], f"seed {WALK_SEED}: " + "\n".join(report.violations[:10])
    assert report.actions == 60
