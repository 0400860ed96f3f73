"""The real page in headless Chromium (Debian's /usr/bin/chromium through Playwright).

One lab server and one browser serve the whole run (tests/conftest.py). The tests of one robot's page share a
tab (``module_tab``) and load their robot anew in it, as a user picking it again would (a new tab costs about
4 s of CPU in software WebGL); the test of two tabs opens its own second tab."""
import colorsys
import time

import numpy as np
import pytest

from app.scene import PALETTE
from app.viewer import screenshot as shots


def wait_until(condition, timeout=20.0, what="condition"):
    shots.wait_until(condition, timeout, what)


def hue_of(rgb):
    h, s, _v = colorsys.rgb_to_hsv(*(np.asarray(rgb, float) / 255))
    return h, s


def has_colour(img, center, color, half=4):
    """Whether a pixel of the link colour (same hue, saturated) lies within ``half`` px of center."""
    target, _ = hue_of(color)
    x, y = int(round(center[0])), int(round(center[1]))
    patch = img[max(0, y - half):y + half + 1, max(0, x - half):x + half + 1].reshape(-1, 3)
    for px in patch:
        h, s = hue_of(px)
        if s > 0.3 and min(abs(h - target), 1 - abs(h - target)) < 0.04:
            return True
    return False


def link_points(session, fractions=(0.2, 0.35, 0.65, 0.8)):
    """World points along every link bar of the drawn robot (away from its ends and middle, where
    joints and CoM markers sit), with the link colour: [(points, colour), ...]."""
    drawing = session.drawing
    poses = drawing.poses(session.q)
    out = []
    for part in drawing.parts:
        if part.role == "link":
            a, b = part.segment
            T = poses[part.attach]
            local = [a + f * (b - a) for f in fractions]
            out.append(([T[:3, :3] @ p + T[:3, 3] for p in local], part.color))
    return out


def assert_robot_drawn(page, session):
    """Every link (in view, not under the side panel) shows its colour where it projects."""
    img = shots.image(page)
    links = link_points(session)
    assert links
    camera = session.client.camera
    visible = 0
    for points, color in links:
        pixels = [px for px in shots.project(camera, points, (img.shape[1], img.shape[0]))
                  if 0 <= px[0] < img.shape[1] - 420 and 0 <= px[1] < img.shape[0]]
        if len(pixels) < 2:
            continue
        hits = sum(has_colour(img, px, color) for px in pixels)
        assert hits >= 2, f"link colour {color} missing near {pixels}"
        visible += 1
    assert visible >= 1
    # and the link colours are not everywhere: the bottom-left corner is background
    for color in PALETTE[:3]:
        assert not has_colour(img, (30, 690), color, half=10)
    return img


@pytest.mark.parametrize("robot", ["planar_2r", "rp_2004_03_25", "polar_2r_2016_06_06", "throwing_arm"])
def test_robot_drawn_and_follows_slider(module_tab, robot):
    page, session = module_tab(robot)
    shots.settle(page, 0.8)                        # the camera at rest before the first picture
    before = assert_robot_drawn(page, session)
    q_before = session.q.copy()
    thumb = shots.slider_thumb(page, session.robot.coordinates[0])
    thumb.focus()
    thumb.press("End")            # q1 to the top of its range, as a user would
    wait_until(lambda: session.q[0] != q_before[0], what="q1 to change")
    lo, hi = session.ranges[session.robot.coordinates[0]]
    assert session.q[0] == pytest.approx(hi, abs=1e-3)
    shots.settle(page, 1.0)
    after = assert_robot_drawn(page, session)
    canvas = np.s_[:, : after.shape[1] - 420]
    changed = np.mean(np.any(np.abs(after[canvas].astype(int) - before[canvas].astype(int)) > 30, axis=2))
    assert changed > 0.002, f"picture barely changed ({changed:.4f})"


def test_model_panel_shows_typeset_math_and_values(module_tab):
    page, session = module_tab("planar_2r")
    shots.select_tab(page, "Model")
    page.wait_for_selector(".r2-math math", state="visible")
    boxes = page.evaluate("""() => [...document.querySelectorAll('.r2-math math')]
        .map(m => m.getBoundingClientRect()).filter(r => r.width > 0 && r.height > 0).length""")
    assert boxes >= 4
    assert page.evaluate("() => document.fonts.check(\"16px 'STIX Two Math'\")")
    # the matrix of M(q) has stretchy brackets: its fence is taller than a line of text
    fence = page.evaluate("""() => { const mo = [...document.querySelectorAll('.r2-math mo[stretchy=true]')]
        .map(e => e.getBoundingClientRect().height); return Math.max(...mo); }""")
    assert fence > 30
    first = page.locator(".r2-num").first
    text_before = first.inner_text()
    thumb = shots.slider_thumb(page, "q2")
    thumb.focus()
    thumb.press("End")
    wait_until(lambda: first.inner_text() != text_before, what="numeric M to change with q2")
    M = session.numeric.M(session.q)
    assert f"{M[0, 0]:.4g}" in first.inner_text().replace("\n", " ")
    with page.expect_download() as download:          # the model as a LaTeX fragment
        page.get_by_role("button", name="Download the model (LaTeX)").click()
    tex = open(download.value.path(), encoding="utf-8").read()
    assert tex.startswith("% Dynamic model of Planar 2R") and "m_{22} = I_{2} + d_{2}^{2} m_{2}" in tex


def test_picking_another_robot_replaces_the_scene(module_tab):
    page, session = module_tab("planar_2r")
    nodes = shots.scene_node_names(page)
    assert any(n.endswith("/link2__joint/joint") for n in nodes) and not any("sleeve" in n for n in nodes)
    shots.choose(page, "Robot", "RP · Planar RP, prismatic axis across link 1 (exam 2004-03-25)")
    shots.wait_ready(page, "rp_2004_03_25")
    assert session.robot_name == "rp_2004_03_25"
    wait_until(lambda: any(n.endswith("/link2__joint/sleeve") for n in shots.scene_node_names(page)), what="the RP scene")
    nodes = shots.scene_node_names(page)
    assert not any(n.endswith("/link2__joint/joint") for n in nodes)   # the 2R's revolute joint 2 is gone
    assert page.get_by_role("tab", name="Model").count() == 1
    shots.settle(page, 1.0)
    assert_robot_drawn(page, session)
    shots.choose(page, "Group", "Throwing arm")              # a group narrows the list ...
    shots.choose(page, "Robot", "3R · Throwing arm (KUKA LWR 4+ joints 2, 3, 5; passive spring wrist)")   # ... a robot loads
    shots.wait_ready(page, "throwing_arm")
    assert [s.name for s in session.robot.bodies] == ["link1", "link2", "link3"]
    # the math font came once, after the page had reported its first robot drawn (the first panels
    # wait for that report, DRAWN_WAIT at most), and the page's formulas use it
    assert session.drawn.is_set()
    assert page.evaluate(MATH_FONT_STYLES) == 1
    wait_until(lambda: page.evaluate("() => document.fonts.check(\"16px 'STIX Two Math'\")"), 10, "the math font")


#: how many <style> elements of the page declare the math font
MATH_FONT_STYLES = ("() => [...document.querySelectorAll('style')]"
                    ".filter(e => e.textContent.includes(\"@font-face{font-family:'STIX Two Math'\")).length")


def test_two_tabs_keep_independent_state(lab, browser, module_tab):
    page_a, session_a = module_tab("planar_2r")
    page_b, session_b = shots.open_tab(lab, browser, "planar_2r")
    try:
        assert session_a is not session_b
        shots.choose(page_a, "Robot", "RP · Planar RP, prismatic axis across link 1 (exam 2004-03-25)")
        shots.wait_ready(page_a, "rp_2004_03_25")
        assert session_b.robot_name == "planar_2r"
        thumb = shots.slider_thumb(page_b, "q1")
        thumb.focus()
        thumb.press("End")
        wait_until(lambda: session_b.q[0] > 3.0, what="q1 of tab B")
        assert session_a.q[0] == pytest.approx(0.0, abs=1e-12)
        assert page_b.get_by_text("Planar 2R arm (vertical plane)").count() >= 1
        assert shots.field(page_a, "q1").input_value() == "0"
    finally:
        shots.close_tab(page_b)


@pytest.mark.parametrize("typed, message", [("-3", "must not be negative"), ("", "empty value"),
                                             ("heavy", "is not a number")])
def test_bad_parameter_is_refused_with_a_message(module_tab, typed, message):
    page, session = module_tab("planar_2r", hide=False)
    box = shots.field(page, "m1 [kg]")
    shots.open_folder(page, "Parameters")
    box.click()
    box.press("Control+a")
    box.press("Backspace")
    if typed:
        page.keyboard.type(typed)
    page.get_by_text(message).first.wait_for(timeout=10000)
    wait_until(lambda: box.input_value() == "10", what="the last good value back in the field")
    assert session.params["m1"] == pytest.approx(10, abs=1e-12) and session.numeric.values["m1"] == pytest.approx(10, abs=1e-12)
    # the page keeps working: a good value goes through to the model
    box.click()
    box.press("Control+a")
    page.keyboard.type("12")
    wait_until(lambda: session.numeric.values["m1"] == pytest.approx(12.0, abs=1e-12), what="m1 = 12 in the model")
    wait_until(lambda: "pinocchio agrees" in page.locator(".r2-badge").inner_text(), what="the check badge")
