"""Study and class (issue 12) in the real page: "Check my answer" in the Model and Exercises tabs.

Every test opens its own tab on the suite's shared server and Chromium (tests/conftest.py)."""
import re

import numpy as np
import pytest

from app.viewer import screenshot as shots


def open_page(lab, browser, query, robot, width=None, height=None, scale=None):
    """A new tab on ``/?query`` (and its server-side session), ready."""
    page = browser.page(shots.page_url(lab, query), width, height, scale or 1.0)
    errors = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    page.r2_errors = errors
    shots.wait_ready(page, robot)
    session = shots.new_session(lab, page)
    session.ready.wait(60)
    return page, session


def field(page, label):
    """The input of a labelled row in the open tab (other tabs have rows of the same name)."""
    return page.locator(f"xpath=//label[normalize-space()='{label}']"
                        "/ancestor::div[contains(@class,'mantine-Flex-root')][1]//input >> visible=true").first


def verdict(page):
    return page.locator(".r2-verdict >> visible=true").first


def choose(page, label, option):
    """Pick ``option`` of the dropdown ``label`` as a user does; for the answer's Entry, wait until
    the answer box shows it was emptied for the new entry (a user sees that before typing; an answer
    typed earlier is emptied with it)."""
    before = verdict_seq(page) if label == "Entry" else None
    field(page, label).click()
    page.get_by_role("option", name=option, exact=True).click()
    if before is not None:
        shots.wait_until(lambda: verdict_seq(page) > before, 15.0, f"the answer box emptied for {option!r}")


def verdict_seq(page):
    return int(verdict(page).get_attribute("data-seq"))


def answer(page, text, state, timeout=15.0):
    """Type an answer, wait for its verdict (a newer check than the one shown) and return its text."""
    before = verdict_seq(page)
    field(page, "Your answer").fill(text)
    shots.wait_until(lambda: verdict_seq(page) > before and
                     verdict(page).get_attribute("data-state") not in ("checking", "idle"),
                     timeout, f"the verdict on {text!r}")
    line = verdict(page)
    assert line.get_attribute("data-state") == state, line.inner_text()
    return line.inner_text()


def test_check_my_answer_in_the_model_tab(lab, browser):
    page, session = open_page(lab, browser, "robot=planar_2r&tab=model", "planar_2r")
    try:
        page.locator('.r2-model[data-robot="planar_2r"]').wait_for(state="attached")
        box = session.state["model_answer"]
        assert {"m11", "m12", "m22", "c1", "g2", "C12", "c1_22", "a1", "Ycol1"} <= set(box.entries())
        # a right answer in another form (factored, shorthand c2, Unicode square) is accepted
        choose(page, "Entry", "m12 · inertia matrix M(q)")
        text = answer(page, "m2 (d2² + l1 d2 c2) + I2", "right")
        assert "right" in text
        # a sign error on the coupling term: the diagnosis names the sign, not the answer
        text = answer(page, "I2 + m2*(d2^2 - l1*d2*cos(q2))", "wrong")
        assert "sign" in text and "wrong" in text
        # the missing Steiner term of m22
        choose(page, "Entry", "m22 · inertia matrix M(q)")
        shots.wait_until(lambda: verdict(page).get_attribute("data-state") == "idle", 10,
                         "the old verdict to go")
        assert field(page, "Your answer").input_value() == ""
        text = answer(page, "I2", "wrong")
        assert "missing" in text and "Steiner" in text
        assert "d2^2" not in text
        # a typo: one clear line, the text stays for fixing, and the page keeps working
        text = answer(page, "I2 + m2*d2^^2", "unreadable")
        assert re.search(r"cannot read", text) and len(text.strip().splitlines()) == 1
        assert field(page, "Your answer").input_value() == "I2 + m2*d2^^2"
        text = answer(page, "I2 + m2*d2^2", "right")
        # hint level 2 shows the step to recheck
        before = verdict_seq(page)
        page.get_by_text("Show the step to recheck").click()
        shots.wait_until(lambda: verdict_seq(page) > before and verdict(page).get_attribute("data-state") == "right",
                         10, "the right answer checked again")
        text = answer(page, "I2 + m2*d2", "wrong")
        assert "Recheck this step" in text
        assert page.r2_errors == []
    finally:
        shots.close_tab(page)


def test_check_my_answer_in_the_exercises_tab(lab, browser):
    page, session = open_page(lab, browser, "robot=rp_2004_03_25&exercise=2004-03-25_1&step=2&tab=exercises",
                              "rp_2004_03_25")
    try:
        panel = session.open_panel("exercises")["panel"]
        shots.wait_until(lambda: panel.solution is not None and panel.index == 1, 60, "step 2 of 2004-03-25#1")
        box = panel.check_box
        k = panel.solution.answer_step("M")
        assert "M[1,1]" not in box.entries()            # the inertia matrix is not revealed yet
        panel.show(k)
        shots.wait_until(lambda: "M[2,2]" in box.entries(), 10, "the entries of the step that shows M")
        assert all(panel.solution.answer_step(e.split("[")[0]) <= k for e in box.entries())
        m22 = panel.solution.answers["M"][1, 1]
        shots.select_tab(page, "Exercises")
        shots.wait_until(lambda: shots.selected_tab(page) == "Exercises", 10, "the Exercises tab")
        shots.open_folder(page, "Check my answer")
        choose(page, "Entry", f"M[2,2] · step {k + 1}")
        text = answer(page, str(m22).replace("**", "^"), "right")
        assert "right" in text
        text = answer(page, "2*(" + str(m22) + ")", "wrong")
        assert "not right" in text
        text = answer(page, "m2 +* 3", "unreadable")
        assert "cannot read" in text
        assert page.r2_errors == []
    finally:
        shots.close_tab(page)


# ====================================================================== presenter mode
# font size and height of the first visible formula in CSS px ([0, 0] while none is on display)
MATH_PX = "() => { const e = [...document.querySelectorAll('.r2-math math')].find(m => m.offsetParent !== null);" \
          " if (!e) return [0, 0];" \
          " return [parseFloat(getComputedStyle(e).fontSize), e.getBoundingClientRect().height]; }"
LABEL_PX = "() => parseFloat(getComputedStyle([...document.querySelectorAll('label')].find(l => l.offsetParent !== null))" \
           ".fontSize)"
OVERFLOWING = "() => [...document.querySelectorAll('.r2-math')].filter(m => m.offsetParent !== null" \
              " && m.scrollWidth > m.clientWidth + 1).map(m => m.textContent.slice(0, 30))"
PRESENTER_MATH_PX = 24.0      # CSS px: 36 screen pixels at 150 %, a row of M(q) readable from the back of a room


def robot_in_view(session, free):
    """Every link's points project inside the part ``free`` (0..1 of the width) of the canvas."""
    from test_browser import link_points
    camera = session.client.camera
    if camera.image_width <= 0:
        return False
    for points, _ in link_points(session):
        px = shots.project(camera, points)
        if not (np.all(px[:, 0] >= 0) and np.all(px[:, 0] <= free * camera.image_width)
                and np.all(px[:, 1] >= 0) and np.all(px[:, 1] <= camera.image_height)):
            return False
    return True


def test_presenter_mode_at_150_percent(lab, browser, tmp_path):
    """A 1280 x 800 screen with the browser at 150 %: 853 x 533 CSS px, 1.5 device pixels per px."""
    page, session = open_page(lab, browser, "robot=planar_3r&tab=model", "planar_3r", width=853, height=533, scale=1.5)
    try:
        page.locator('.r2-model[data-robot="planar_3r"]').wait_for(state="attached")
        shots.hide_notifications(page)
        shots.wait_until(lambda: page.evaluate(MATH_PX)[0] > 0, 10, "the math on display")
        math_off, height_off = page.evaluate(MATH_PX)
        label_off = page.evaluate(LABEL_PX)
        assert math_off < 18.0
        shots.open_folder(page, "Display")
        # the box is verified ticked after the click (a click lost while the panel's layout still
        # moves is made again; it would otherwise go unnoticed until the timeout below)
        shots.set_checkbox(page.get_by_role("checkbox", name="Presenter mode"))
        shots.wait_until(lambda: session.presenter.on, 10, "the server to switch presenter mode on")
        page.locator(".r2-presenter").wait_for(state="attached", timeout=10000)
        shots.wait_until(lambda: page.evaluate(MATH_PX)[0] >= PRESENTER_MATH_PX, 5, "the larger math")
        math_on, height_on = page.evaluate(MATH_PX)
        assert math_on >= PRESENTER_MATH_PX and math_on >= 1.5 * math_off and height_on >= 1.5 * height_off
        assert page.evaluate(LABEL_PX) >= 1.2 * label_off
        panel = page.evaluate("() => { let e = document.querySelector('.r2-presenter');"
                              " while (e && getComputedStyle(e).position !== 'absolute') e = e.parentElement;"
                              " const r = e.getBoundingClientRect(); return [r.left, r.width]; }")
        assert panel[1] == pytest.approx(853 / 2, abs=2) and panel[0] + panel[1] <= 853 + 1
        assert session.scene.line_scale > 1.5
        # M(q), c and g laid out again for the larger math: no formula scrolls sideways
        shots.wait_until(lambda: page.evaluate(OVERFLOWING) == [], 10, "the formulas laid out for presenter mode")
        # the robot is framed in the half of the view the panel leaves free
        shots.wait_until(lambda: robot_in_view(session, 0.5), 10, "the 3R in view left of the panel")
        page.evaluate("() => { const m = [...document.querySelectorAll('.r2-math')].find(e => e.offsetParent !== null);"
                      " let v = m.parentElement; while (v && !(v.scrollHeight > v.clientHeight + 1 &&"
                      " /auto|scroll/.test(getComputedStyle(v).overflowY))) v = v.parentElement;"
                      " v.scrollTop += m.getBoundingClientRect().top - v.getBoundingClientRect().top - 120; }")
        shots.settle(page, 1.0)
        page.screenshot(path=str(tmp_path / "presenter_mode.png"))
        print(f"math {math_off:.2f} -> {math_on:.2f} CSS px, height {height_off:.1f} -> {height_on:.1f}, "
              f"labels {label_off:.2f} -> {page.evaluate(LABEL_PX):.2f}, panel {panel}")
        # off again: everything back
        shots.set_checkbox(page.get_by_role("checkbox", name="Presenter mode"), False)
        shots.wait_until(lambda: page.evaluate(MATH_PX)[0] == pytest.approx(math_off, abs=0.1), 5, "the normal math")
        assert session.scene.panel_fraction is None
        assert page.r2_errors == []
    finally:
        shots.close_tab(page)


def test_presenter_mode_stays_on_through_a_robot_switch_in_its_own_tab_only(lab, browser):
    page, session = open_page(lab, browser, "robot=planar_3r&tab=model", "planar_3r", width=853, height=533, scale=1.5)
    try:
        page.locator('.r2-model[data-robot="planar_3r"]').wait_for(state="attached")
        shots.wait_until(lambda: page.evaluate(MATH_PX)[0] > 0, 10, "the math on display")
        math_off = page.evaluate(MATH_PX)[0]
        session.presenter.set(True)
        assert session.presenter.switch.value is True
        # the Model tab is rebuilt after a switch, laid out for presenter mode
        session.load_robot("planar_2r")
        page.locator('.r2-model[data-robot="planar_2r"]').wait_for(state="attached", timeout=20000)
        shots.wait_until(lambda: page.evaluate(MATH_PX)[0] >= PRESENTER_MATH_PX and page.evaluate(OVERFLOWING) == [],
                         10, "presenter mode after a robot switch")
        shots.wait_until(lambda: robot_in_view(session, 0.5), 10, "the 2R in view left of the panel")
        # ... and belongs to this tab only
        other, other_session = open_page(lab, browser, "robot=planar_3r&tab=model", "planar_3r", width=853,
                                         height=533, scale=1.5)
        try:
            other.locator('.r2-model[data-robot="planar_3r"]').wait_for(state="attached")
            shots.wait_until(lambda: other.evaluate(MATH_PX)[0] > 0, 10, "the math on display in the other tab")
            assert other.evaluate(MATH_PX)[0] == pytest.approx(math_off, abs=0.1)
            assert other.locator(".r2-presenter").count() == 0 and not other_session.presenter.on
        finally:
            shots.close_tab(other)
        assert page.r2_errors == []
    finally:
        shots.close_tab(page)
