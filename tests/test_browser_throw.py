"""The Throw studio in the real page (headless Chromium): a thesis throw flies to its landing
marker, throw three and edits that break the throw are flagged with a message while the last good
throw stays, and a control point can be dragged with the mouse."""
import colorsys
import time
from dataclasses import replace

import numpy as np
import pytest

from app.core.vhc import ThrowingArm, load_throw_config, thesis_throw
from app.panels.throw import format_points
from app.viewer import screenshot as shots
from app.viewer.server import LabServer


@pytest.fixture(scope="module")
def lab():
    server = LabServer(port=0, verbose=False)
    yield server
    server.stop()


@pytest.fixture(scope="module")
def browser():
    with shots.Browser() as b:
        yield b


@pytest.fixture(scope="module")
def arm():
    return ThrowingArm()


def open_studio(lab, browser, hide=True):
    """A new tab on the throwing arm with the Throw studio open; returns (page, session, studio)."""
    before = set(lab.sessions)
    lab.initial_robot = "throwing_arm"
    page = browser.page(lab.url, height=900)
    shots.wait_ready(page, "throwing_arm")
    session = shots._new_session(lab, before)
    if hide:
        shots.hide_notifications(page)
    shots.select_tab(page, "Throw studio")
    return page, session, session.state["throw"]["studio"]


def wait_until(condition, timeout=30.0, what="condition"):
    deadline = time.time() + timeout
    while time.time() < deadline:
        if condition():
            return
        time.sleep(0.05)
    raise AssertionError(f"timed out waiting for {what}")


def badge(page, state, *texts, timeout=30.0):
    """The feasibility badge once it is in ``state`` and shows every one of ``texts``; its text.
    (A value typed key by key is solved on the way: the badge may first show another throw.)"""
    locator = page.locator(f'.r2-throw-badge[data-state="{state}"]')
    deadline = time.time() + timeout
    while True:
        if locator.count():
            text = locator.first.inner_text()
            if all(t in text for t in texts):
                return text
        if time.time() > deadline:
            raise AssertionError(f"the badge never showed {state} with {texts}")
        time.sleep(0.1)


def typed(page, label, text):
    """Type into a labelled text field, or into the number box of a labelled slider."""
    box = page.locator(f"xpath=//label[normalize-space()='{label}']/ancestor::div[contains(@class,'mantine-Flex-root')]"
                       "[1]//input[not(@type='hidden')]").first
    box.click()
    box.press("Control+a")
    box.press("Backspace")
    page.keyboard.type(text)
    box.press("Enter")


def reddish_near(img, center, half=6):
    x, y = int(round(center[0])), int(round(center[1]))
    patch = img[max(0, y - half):y + half + 1, max(0, x - half):x + half + 1].reshape(-1, 3) / 255.0
    for r, g, b in patch:
        h, s, v = colorsys.rgb_to_hsv(r, g, b)
        if s > 0.5 and v > 0.4 and min(h, 1 - h) < 0.04:
            return True
    return False


def test_throw_one_lands_at_its_marker_and_throw_three_is_refused(lab, browser, arm):
    page, session, studio = open_studio(lab, browser, hide=False)
    try:
        expected = arm.solve(thesis_throw("throw1"))
        rel = expected.release
        shown = studio.shown
        studio.speed.value = "1x (true speed)"
        page.get_by_role("button", name="Throw 1", exact=True).click()
        wait_until(lambda: studio.shown > shown and studio.config.title.startswith("Thesis throw one"),
                   what="throw one to be shown")
        # the limit check of the engine, as a red badge listing the exceeded speeds
        badge(page, "infeasible", "speed of q2", "speed of q3")
        # both distances in the summary and at the landing markers, the markers where the ball lands
        table = page.locator(".r2-throw-distances").inner_text()
        for d in (rel.distance_from_base, rel.distance_from_release, rel.distance_from_base_thesis,
                  rel.distance_from_release_thesis):
            assert f"{d:.3f} m" in table
        nodes = shots.scene_node_names(page)
        assert {"/throw/land_true", "/throw/land_true_label", "/throw/land_thesis", "/throw/flight_true"} <= set(nodes)
        assert studio.nodes.get("land_true_label").text == (f"J q̇: {rel.distance_from_base:.3f} m from the base, "
                                                            f"{rel.distance_from_release:.3f} m from the release")
        marker = studio.nodes.get("land_true")
        assert np.allclose(marker.position, (rel.distance_from_base, 0.0, 0.0), atol=1e-9)
        assert np.allclose(studio.nodes.get("land_thesis").position, (rel.distance_from_base_thesis, 0.0, 0.0))
        # loading plays the throw: the ball leaves the hand and lands on the marker
        wait_until(lambda: studio._anim["t"] > expected.duration, what="the ball to be released")
        wait_until(lambda: not studio._anim["playing"], timeout=30, what="the ball to land")
        ball = studio.nodes.get("ball").position
        assert ball[0] == pytest.approx(rel.distance_from_base, abs=1e-9) and ball[1] == 0.0
        # the marker is drawn where it projects on the canvas (the camera frames the whole throw)
        shots.settle(page, 1.0)
        px = shots.project(session.client.camera, [marker.position])[0]
        assert 0 <= px[0] < session.client.camera.image_width - 420
        assert reddish_near(shots.image(page), px)
        # throw three cannot be reached as printed: a clear message, and throw one stays on display
        page.get_by_role("button", name="Throw 3", exact=True).click()
        badge(page, "error", "cannot be reached", "2.7 mm beyond the reach of link 3")
        page.get_by_text("The throw cannot be carried out").first.wait_for()   # the notification
        assert np.allclose(studio.nodes.get("land_true").position, marker.position)
        assert studio.view.spec == thesis_throw("throw1")
        # the page keeps working: throw two can be carried out (over its limits in this model)
        page.get_by_role("button", name="Throw 2", exact=True).click()
        badge(page, "infeasible", "torque of q1")
        assert studio.error is None and studio.view.spec == thesis_throw("throw2")
    finally:
        page.context.close()


def test_breaking_edits_are_flagged_and_the_last_good_throw_stays(lab, browser, arm):
    page, session, studio = open_studio(lab, browser)
    try:
        page.get_by_role("button", name="θ̇ along ψ (thesis)", exact=True).click()
        badge(page, "feasible")
        page.get_by_role("tab", name="Edit", exact=True).click()
        # a stiffer wrist spring: still a throw, but too fast for joints 1 and 2
        typed(page, "Spring k [N m/rad]", "40")
        badge(page, "infeasible", "speed of q1", "speed of q2")
        wait_until(lambda: studio.view is not None and studio.view.spec.k == 40.0, what="the k = 40 throw")
        good = arm.solve(replace(load_throw_config("optimized_thesis").spec, k=40.0))
        assert studio.view.release.distance_from_base == pytest.approx(good.release.distance_from_base, rel=1e-12)
        # the speed plot fills the part over the limit: its "beyond" series leaves the limit line
        _legend, chart = studio.plots["speeds"]
        assert np.max(chart.data[5]) > 1.2 and np.allclose(chart.data[4], 1.0)
        # the first control point of phi1 lowered by 0.5 rad: the ball can no longer be reached
        a = list(studio.values["a"])
        a[0] -= 0.5
        typed(page, "φ1 points a [rad]", format_points(a))
        badge(page, "error", "cannot be reached", "beyond the reach of link 3", "keep the last throw")
        # ... and the 3D view and the plots keep the k = 40 throw
        assert studio.view.spec.k == 40.0 and studio.error
        assert studio.nodes.get("land_true").position[0] == pytest.approx(good.release.distance_from_base)
        # raised instead by 0.5 rad: alpha of the reduced dynamics changes sign
        a[0] += 1.0
        typed(page, "φ1 points a [rad]", format_points(a))
        wait_until(lambda: "alpha" in (studio.error or ""), what="the singular throw to be refused")
        badge(page, "error", "changes sign")
        # nonsense typed is refused with a message and the last good list comes back
        typed(page, "φ1 points a [rad]", "1.2, nan")
        wait_until(lambda: studio.a_text.value == format_points(a), timeout=10, what="the list to come back")
        # back to a good list: a throw again
        a[0] -= 0.5
        typed(page, "φ1 points a [rad]", format_points(a))
        badge(page, "infeasible")
        assert studio.error is None
    finally:
        page.context.close()


def test_a_control_point_is_dragged_with_the_mouse(lab, browser):
    page, session, studio = open_studio(lab, browser)
    try:
        shown = studio.shown
        page.get_by_role("button", name="θ̇ along ψ (thesis)", exact=True).click()
        wait_until(lambda: studio.shown > shown and studio.config.title.startswith("Optimized"), what="the load")
        badge(page, "feasible")
        studio.show_time(0.0)
        shots.settle(page, 1.5)
        before = list(studio.values["b"])
        point = np.array(studio.nodes.get("chart_point_b3").position)
        x, y = shots.project(session.client.camera, [point])[0]
        page.mouse.move(x, y)
        page.mouse.down()
        for k in range(1, 9):
            page.mouse.move(x, y + 2 * k)
            time.sleep(0.05)
        page.mouse.up()
        wait_until(lambda: studio.values["b"][3] < before[3] - 0.05, what="b3 to follow the mouse")
        assert studio.values["b"][:3] == before[:3] and studio.values["b"][4:] == before[4:]
        assert studio.selected == ("b", 3)
        wait_until(lambda: abs(studio.point_value.value - studio.values["b"][3]) < 1e-9, what="the point slider")
        # the chart's scale: the pointer moved 16 px down, the point moved by as much on the chart
        g = studio.chart.geometry
        px_per_m = abs(shots.project(session.client.camera, [point + [0, 1.0, 0]])[0][1] - y)
        moved = (before[3] - studio.values["b"][3]) * g.height / (g.hi - g.lo) * px_per_m
        assert 8 < moved < 24
        wait_until(lambda: studio.view is not None and studio.view.spec.b[3] == studio.values["b"][3],
                   what="the dragged throw to be solved")
        assert badge(page, "infeasible")       # b3 lowered: joint 1 too fast
    finally:
        page.context.close()
