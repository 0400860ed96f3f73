"""The Control panel in the real page (headless Chromium): choose, type, Run, replay, plots, and a
clear message for bad input."""
import time

import numpy as np
import pytest

from app.panels.control import plot_groups, plots_png
from app.viewer import screenshot as shots


def open_control(lab, browser, robot="planar_2r"):
    return shots.open_tab(lab, browser, robot, tab="Control", height=900, hide=False)


def wait_until(condition, timeout=60.0, what="condition"):
    shots.wait_until(condition, timeout, what)


def typed(page, label, text):
    box = shots.field(page, label)
    box.click()
    box.press("Control+a")
    box.press("Backspace")
    page.keyboard.type(text)
    box.press("Enter")


def test_run_replay_and_plots(lab, browser):
    page, session = open_control(lab, browser)
    try:
        panel = session.state["control"]["panel"]
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
    finally:
        page.context.close()


def test_bad_gain_is_a_message_and_the_page_keeps_working(lab, browser):
    page, session = open_control(lab, browser)
    try:
        panel = session.state["control"]["panel"]
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
    finally:
        page.context.close()


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
