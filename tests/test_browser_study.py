"""Study and class (issue 12) in the real page: "Check my answer" in the Model and Exercises tabs.

Every test opens its own tab on the suite's shared server and Chromium (tests/conftest.py)."""
import re

from app.viewer import screenshot as shots


def open_page(lab, browser, query, robot, width=shots.WIDTH, height=shots.HEIGHT, scale=None):
    """A new tab on ``/?query`` (and its server-side session), ready."""
    before = set(lab.sessions)
    if scale is None:
        page = browser.page(shots.page_url(lab, query), width, height)
    else:
        context = browser._browser.new_context(viewport={"width": width, "height": height}, device_scale_factor=scale)
        page = context.new_page()
        page.goto(shots.page_url(lab, query))
    errors = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    page.r2_errors = errors
    shots.wait_ready(page, robot)
    session = shots.new_session(lab, before)
    session.ready.wait(60)
    return page, session


SELECTED_TAB = "() => document.querySelector('[role=tab][aria-selected=true]').textContent.trim()"


def field(page, label):
    """The input of a labelled row in the open tab (other tabs have rows of the same name)."""
    return page.locator(f"xpath=//label[normalize-space()='{label}']"
                        "/ancestor::div[contains(@class,'mantine-Flex-root')][1]//input >> visible=true").first


def verdict(page):
    return page.locator(".r2-verdict >> visible=true").first


def choose(page, label, option):
    """Pick ``option`` of the dropdown ``label`` as a user does."""
    field(page, label).click()
    page.get_by_role("option", name=option, exact=True).click()


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
        page.context.close()


def test_check_my_answer_in_the_exercises_tab(lab, browser):
    page, session = open_page(lab, browser, "robot=rp_2004_03_25&exercise=2004-03-25_1&step=2&tab=exercises",
                              "rp_2004_03_25")
    try:
        panel = session.state["exercises"]["panel"]
        shots.wait_until(lambda: panel.solution is not None and panel.index == 1, 60, "step 2 of 2004-03-25#1")
        box = panel.check_box
        k = panel.solution.answer_step("M")
        assert "M[1,1]" not in box.entries()            # the inertia matrix is not revealed yet
        panel.show(k)
        shots.wait_until(lambda: "M[2,2]" in box.entries(), 10, "the entries of the step that shows M")
        assert all(panel.solution.answer_step(e.split("[")[0]) <= k for e in box.entries())
        m22 = panel.solution.answers["M"][1, 1]
        shots.select_tab(page, "Exercises")
        shots.wait_until(lambda: page.evaluate(SELECTED_TAB) == "Exercises", 10, "the Exercises tab")
        page.get_by_text("Check my answer", exact=True).locator("visible=true").first.click()    # open the folder
        choose(page, "Entry", f"M[2,2] · step {k + 1}")
        text = answer(page, str(m22).replace("**", "^"), "right")
        assert "right" in text
        text = answer(page, "2*(" + str(m22) + ")", "wrong")
        assert "not right" in text
        text = answer(page, "m2 +* 3", "unreadable")
        assert "cannot read" in text
        assert page.r2_errors == []
    finally:
        page.context.close()
