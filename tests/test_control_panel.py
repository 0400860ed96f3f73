"""The Control panel in the real page (headless Chromium): choose, type, Run, replay, plots, and a
clear message for bad input."""
import time

import numpy as np
import pytest

from app.panels.control import AUTO_RERUN_DELAY
from app.panels.control_plots import plot_groups, plots_png
from app.viewer import screenshot as shots


def open_control(lab, browser, robot="planar_2r"):
    return shots.open_tab(lab, browser, robot, tab="Control", height=900, hide=False)


def wait_until(condition, timeout=60.0, what="condition"):
    shots.wait_until(condition, timeout, what)


def typed(page, label, text, at_once=False):
    """Type ``text`` into a field key by key (or ``at_once``, as a paste: one change) and press Enter."""
    box = shots.field(page, label)
    box.click()
    box.press("Control+a")
    box.press("Backspace")
    if at_once:
        box.fill(text)
    else:
        page.keyboard.type(text)
    box.press("Enter")


@pytest.fixture(scope="module")
def control_page(lab, browser):
    """One Control tab shared by the tests of this module (each loads its robot anew or sets every
    field it uses): opening a page is most of a browser test's time."""
    page, session = open_control(lab, browser)
    yield page, session
    shots.close_tab(page)


def test_run_replay_and_plots(control_page):
    page, session = control_page
    shots.reload_robot(page, session, "planar_2r")
    panel = session.open_panel("control")["panel"]
    assert panel.controller.value == "Computed torque (feedback linearization)"
    assert page.locator("math").count() >= 1                       # the law, typeset
    session.set_q([0.1, 0.2])
    typed(page, "Reference values", "by=0.5,-0.3 T=1")
    wait_until(lambda: panel.ref_params.value == "by=0.5,-0.3 T=1", what="the typed reference")
    page.get_by_role("button", name="Run", exact=True).click()
    page.get_by_text("completed:").first.wait_for(timeout=60000)
    res = panel.result
    assert res.controller == "computed_torque" and res.completed
    assert np.allclose(res.q[0], [0.1, 0.2]) and np.allclose(res.ref[-1], [0.6, -0.1])
    assert abs(res.e[-1]).max() < 1e-6
    wait_until(lambda: page.locator(".uplot").count() >= 2, what="the uPlot charts")
    assert page.get_by_text("Tracking error e = q_d - q").count() == 1
    # replay: Play moves time forward and the robot with it
    page.get_by_role("button", name="▶ Play").click()
    wait_until(lambda: panel._replay["t"] > 0.3, what="the replay to advance")
    page.get_by_role("button", name="❚❚ Pause").click()
    wait_until(lambda: not panel._replay["playing"], what="the pause")
    t = panel._replay["t"]
    time.sleep(0.3)
    assert panel._replay["t"] == t
    k = min(len(res.t) - 1, int(np.searchsorted(res.t, t)))
    moving = np.abs(res.q - res.q[0]).max() > 0.1
    assert moving
    pose = session.scene.drawing.poses(res.q[k])["link2"]
    wait_until(lambda: np.allclose(session.scene._frames["link2"].position, pose[:3, 3], atol=1e-6),
               what="the robot drawn at the replayed time")
    assert "control_ref" in session.scene._ghosts                   # the reference ghost


def test_bad_gain_is_a_message_and_the_page_keeps_working(control_page):
    page, session = control_page
    shots.reload_robot(page, session, "planar_2r")
    panel = session.open_panel("control")["panel"]
    panel.configure("computed_torque")
    typed(page, "Gains", "Kq=3")
    wait_until(lambda: panel.gains.value == "Kq=3", what="the typed gain")
    page.get_by_role("button", name="Run", exact=True).click()
    page.get_by_text("unknown gain 'Kq'").first.wait_for(timeout=30000)
    assert panel.result is None
    wait_until(lambda: "not run: " in panel.status.content, what="the status line")
    typed(page, "Gains", "Kp=64, Kd=16")
    wait_until(lambda: panel.gains.value == "Kp=64, Kd=16", what="the corrected gains")
    page.get_by_role("button", name="Run", exact=True).click()
    page.get_by_text("completed:").first.wait_for(timeout=60000)
    assert panel.result.gains["Kp"] == pytest.approx([64.0, 64.0], abs=1e-12)


def test_adaptive_run_plots_estimates_against_true_values_and_png():
    from app.core.control import coefficient_values
    from app.core.robot import load_robot
    from app.core.sim import simulate
    robot = load_robot("planar_2r")
    res = simulate(robot, "adaptive", reference="sine amplitude=0.3 f=0.5", duration=0.2, model_params={"m2": 3},
                   observer=20)
    true = coefficient_values(robot, robot.parameter_values())
    groups = dict(plot_groups(res, true))
    estimates = groups["Estimates â (dashed: true values)"]
    assert [s[0] for s in estimates] == ["â1", "â2", "â3", "â4", "a1", "a2", "a3", "a4"]
    assert all(s[2] for s in estimates[4:]) and [s[3] for s in estimates[4:]] == [0, 1, 2, 3]
    assert np.allclose(estimates[4][1], true[0])
    png = plots_png(res, plot_groups(res, true))
    assert png.startswith(b"\x89PNG") and len(png) > 10000


def legend_labels(page):
    return page.evaluate("() => [...document.querySelectorAll('.u-legend .u-label')].map(e => e.innerText)")


def run_in_page(page, panel, controller, runs_before):
    page.get_by_role("button", name="Run", exact=True).click()
    wait_until(lambda: panel.result is not None and panel.result.controller == controller
               and panel._runs > runs_before, what=f"the {controller} run")


def fresh(control_page):
    page, session = control_page
    panel = session.open_panel("control")["panel"]
    panel.clear_comparison()
    session.set_q([0.1, 0.2])
    return page, session, panel


def test_a_kept_run_is_overlaid_on_the_next_runs_plots(control_page):
    """Issue 12: Keep this run for comparison, run another controller with the same mismatch,
    both runs' curves in every common plot (the kept one labelled with its controller); Clear."""
    page, session, panel = fresh(control_page)
    panel.configure("computed_torque", reference="quintic by=0.3 T=0.4", mismatch="m2=3", duration=0.5)
    run_in_page(page, panel, "computed_torque", panel._runs)
    kept = panel.result
    page.get_by_role("button", name="Keep this run for comparison").click()
    page.get_by_text("kept for comparison: ").first.wait_for(timeout=10000)
    assert not any("[computed_torque]" in label for label in legend_labels(page))   # nothing to compare yet
    panel.configure("pd_gravity", reference="quintic by=0.3 T=0.4", mismatch="m2=3", duration=0.8)
    run_in_page(page, panel, "pd_gravity", panel._runs)
    wait_until(lambda: "τ_q1 [computed_torque]" in legend_labels(page), what="the kept run in the legend")
    labels = legend_labels(page)
    assert "e_q2 [computed_torque]" in labels and "τ_q1" in labels
    torques = next(p for p in panel._plot_data if "τ_q1" in [s["label"] for s in p["handle"].series])
    names = [s["label"] for s in torques["handle"].series]
    x = np.asarray(torques["x"])
    assert np.all(np.diff(x) > 0) and x[-1] == pytest.approx(0.8, abs=1e-9)      # the longer run's end
    old = np.asarray(torques["columns"][names.index("τ_q1 [computed_torque]") - 1])
    at = x <= 0.5
    assert np.all(np.isnan(old[~at]))                                      # the kept run ended at 0.5 s
    assert np.interp(0.3, x[at], old[at]) == pytest.approx(np.interp(0.3, kept.t, kept.tau[:, 0]),
                                                           rel=1e-2, abs=1e-2)
    page.get_by_role("button", name="Clear comparison").click()
    wait_until(lambda: not any("[computed_torque]" in label for label in legend_labels(page)),
               what="the kept curves to go")
    assert panel.kept() is None and panel.result.controller == "pd_gravity"


def test_the_plots_time_marker_follows_the_time_slider_and_the_replay(control_page):
    """Issue 12: a vertical line in every plot at the replay's time, moved by the Time slider and
    by Play (viser reports no click on a uPlot chart, so the slider drives both)."""
    page, session, panel = fresh(control_page)
    panel.configure("computed_torque", reference="quintic by=0.3 T=0.8", duration=1.0)
    run_in_page(page, panel, "computed_torque", panel._runs)
    wait_until(lambda: page.locator(".uplot").count() >= 2, what="the charts")
    assert panel.marker_time() == pytest.approx(0.0, abs=1e-9)
    assert "replay" in legend_labels(page)
    thumb = shots.slider_thumb(page, "Time [s]")
    thumb.scroll_into_view_if_needed()
    track = page.locator("xpath=//label[normalize-space()='Time [s]']/ancestor::div"
                         "[contains(@class,'mantine-Flex-root')][1]//*[contains(@class,'Slider-track')]").first
    box = track.bounding_box()
    page.mouse.click(box["x"] + 0.4 * box["width"], box["y"] + box["height"] / 2)    # a click on the track
    wait_until(lambda: 0.3 < panel.time.value < 0.5, what="the slider to move")
    wait_until(lambda: abs(panel.marker_time() - panel.time.value) < 1e-9, what="the marker at the slider")
    t = panel.time.value
    res = panel.result
    k = min(len(res.t) - 1, int(np.searchsorted(res.t, t)))
    pose = session.scene.drawing.poses(res.q[k])["link2"]
    wait_until(lambda: np.allclose(session.scene._frames["link2"].position, pose[:3, 3], atol=1e-6),
               what="the robot at the slider's time")
    assert all(abs(panel.marker_time() - t) < 1e-9 for _ in panel._plot_data)
    page.get_by_role("button", name="▶ Play").click()
    wait_until(lambda: not panel._replay["playing"] and panel._replay["t"] > 0.99, what="the replay's end")
    wait_until(lambda: panel.marker_time() == pytest.approx(1.0, abs=1e-6), what="the marker at the end")


def test_a_short_run_reruns_by_itself_when_a_gain_changes(control_page):
    """Issue 12: a run of at most 2 s is run again after a gain is typed (debounced: one run for
    the whole typing, the older run replaced, never queued); a longer run is not."""
    page, session, panel = fresh(control_page)
    panel.configure("computed_torque", reference="quintic by=0.3 T=0.4", duration=0.5)
    run_in_page(page, panel, "computed_torque", panel._runs)
    runs = panel._runs
    typed(page, "Gains", "Kp=64", at_once=True)            # key by key, a busy machine may pause > 0.6 s
    wait_until(lambda: panel.result.gains["Kp"][0] == pytest.approx(64.0, abs=1e-12), what="the re-run")
    assert panel._runs == runs + 1                           # one run for the change
    assert "completed:" in panel.status.content
    panel.duration.value = 3.0                             # longer than AUTO_RERUN_MAX: no re-run
    typed(page, "Gains", "Kp=81")
    wait_until(lambda: panel.gains.value == "Kp=81", what="the typed gain")
    time.sleep(AUTO_RERUN_DELAY + 0.4)
    assert panel._runs == runs + 1 and panel.result.gains["Kp"][0] == pytest.approx(64.0, abs=1e-12)

