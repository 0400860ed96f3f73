"""The Exercises panel: its pieces without a browser (variants, units, 3D hints), then the real
page in headless Chromium (open an exercise, reveal steps, solve a variant, refuse a bad one)."""
import time
from contextlib import contextmanager

import numpy as np
import pytest

from app.core.errors import UserError
from app.core.exercise import load_exercise, solve
from app.core.robot import load_robot
from app.panels.exercise_scene import HintDrawer, joint_geometry, tip_position
from app.panels.exercise_variant import SOLUTIONS, fields, parse_field
from app.panels.exercise_view import answer_unit, answers_html, paragraphs, profile_svg
from app.panels.exercises import option_label, shipped_exercises
from app.scene import RobotDrawing
from app.viewer import screenshot as shots


# ====================================================================== without a browser
def test_every_shipped_exercise_is_listed_once():
    exercises, errors = shipped_exercises()
    assert not errors
    assert len(exercises) >= 40
    labels = [option_label(ex) for ex in exercises]
    assert len(set(labels)) == len(labels)


def test_variant_fields_parse_numbers_expressions_and_lists():
    ex = load_exercise("2013-07-15#1")
    robot = load_robot(ex.robot_ref)
    f = {x.name: x for x in fields(ex, robot)}
    assert f["l1"].unit == "m" and f["q1"].text == "pi/4" and f["tau_a"].text == "[-0.25, -0.75, 0]"
    assert "m1" in f and f["m1"].section == "parameter"          # a robot parameter not given
    assert parse_field(f["q1"], "pi/3") == pytest.approx(np.pi / 3)
    assert parse_field(f["tau_a"], "[0.1, -1/2, 0]") == pytest.approx([0.1, -0.5, 0.0], abs=1e-15)
    for name, bad, message in (("m1", "-0.5", "must not be negative"), ("l1", "abc", "not a number"),
                               ("l1", "", "empty value"), ("q1", "1/0", "division by zero")):
        with pytest.raises(UserError, match=message):
            parse_field(f[name], bad, robot)
    with pytest.raises(UserError, match="list of 3 entries"):
        parse_field(f["tau_a"], "[1, 2]", robot)
    with pytest.raises(UserError, match="not a number"):
        parse_field(f["tau_a"], "[1, __import__, 2]", robot)


def test_solution_cache_solves_variants_separately():
    ex = load_exercise("2020-06-05#1")
    exam = SOLUTIONS.solve(ex, {})
    assert SOLUTIONS.solve(ex, {}) is exam
    variant = SOLUTIONS.solve(ex, {"given:V": [1.0, 1.0, 1.0]})
    direct = solve(ex, given={"V": [1.0, 1.0, 1.0]})
    assert np.allclose(variant.answers["dq"], direct.answers["dq"])
    assert not np.allclose(variant.answers["dq"], exam.answers["dq"])
    assert np.all(np.abs(variant.answers["dq"]) <= 1 + 1e-9)


def test_units_of_answers_and_profile_sketch():
    assert answer_unit("tau", [1.0, 2.0], ["revolute", "prismatic"]) == ["N m", "N"]
    assert answer_unit("ddq", [1.0, 2.0, 3.0], ["revolute"] * 3) == ["rad/s²"] * 3
    assert answer_unit("dq_error", [1.0, 2.0], ["revolute"] * 2) == ""        # a task-space error
    assert answer_unit("dq_scale", 0.5, ["revolute"] * 3) == ""
    assert answer_unit("T_min", 2.0, ["revolute"]) == "s"
    assert answer_unit("F_a", [1.0, 2.0], ["revolute"] * 3) == "N"
    html = answers_html({"tau": np.array([1.5, -2.0]), "M": load_robot("planar_2r").q[0]}, ["revolute", "prismatic"])
    assert "N</mi>" in html or "N</mtext>" in html or ">N<" in html
    assert html.count("<math") == 1                                            # the symbolic one is left out
    svg = profile_svg({"kind": "trapezoidal", "T": 2.0, "Ts": 0.5, "V": 1.0, "A": 2.0})
    assert svg.startswith("<svg") and "T = 2 s" in svg and svg.count("stroke-dasharray") == 2
    assert paragraphs("a\nb\n(b) c\n") == ["a b", "(b) c"]


class FakeScene:
    """Records the overlays a HintDrawer adds (the session's scene API of docs/panels.md)."""

    def __init__(self):
        self.items, self.highlighted = {}, None

    def highlight(self, bodies=(), joints=()):
        self.highlighted = (list(bodies), list(joints))

    def add_arrow(self, name, start, vector, color=None, label=None):
        self.items[name] = ("arrow", np.asarray(start, float), np.asarray(vector, float), color)

    def add_line(self, name, points, color=None, width=3.0):
        self.items[name] = ("line", np.asarray(points, float), color)

    def add_marker(self, name, position, color=None, radius=None, label=None):
        self.items[name] = ("marker", np.asarray(position, float), color)

    def add_label(self, name, text, position):
        self.items[name] = ("label", text, np.asarray(position, float))

    def remove_overlay(self, name):
        self.items.pop(name, None)


class FakeSession:
    def __init__(self, robot_name, values=None):
        self.scene = FakeScene()
        self.drawing = RobotDrawing(load_robot(robot_name), values)

    @staticmethod
    @contextmanager
    def atomic():
        yield


def _step(solution, title):
    return next(st for st in solution.steps if st.title == title)


def test_sns_hints_bounds_at_the_joints_and_task_at_the_end_effector():
    ex = load_exercise("2020-06-05#1")
    sol = solve(ex)
    session = FakeSession(ex.robot_ref)
    drawer = HintDrawer(session)
    q = np.array([0.4, 0.5, 0.4])
    drawer.draw(_step(sol, "SNS solution").highlight, q)
    items = session.scene.items
    arcs = [k for k, v in items.items() if k.startswith("exercise_arc")]
    bounds = [k for k, v in items.items() if k.startswith("exercise_bound")]
    assert len(arcs) == 3 and len(bounds) == 3
    joints = joint_geometry(session.drawing, q)
    dq = sol.answers["dq"]
    for i, joint in enumerate(joints):    # each arc sweeps about its joint, by the angle of its value
        pts = items[f"exercise_arc{i}"][1]
        centre = joint["position"] + np.array([0, 0, 2 * session.drawing.radius])
        radii = np.linalg.norm(pts - centre, axis=1)
        assert np.allclose(radii, radii[0])
        a0, a1 = pts[0] - centre, pts[-1] - centre
        turn = np.arctan2(np.cross(a0, a1) @ joint["axis"], a0 @ a1)
        assert np.sign(turn) == np.sign(dq[i])
    # joint 1 sits on its bound (|dq1| = V1 = 1): drawn in the "saturated" colour, the others not
    assert abs(abs(dq[0]) - 1) < 1e-9
    assert items["exercise_arc0"][2] != items["exercise_arc1"][2] == items["exercise_arc2"][2]
    # the task (executed exactly) is one arrow at the end effector along v = (2, 1)
    arrows = [v for v in items.values() if v[0] == "arrow" and v[3] != items["exercise_arc0"][2] and v[3] != items["exercise_arc1"][2]]
    assert len(arrows) == 1
    _, start, vector, _ = arrows[0]
    assert np.allclose(start, tip_position(session.drawing, q))
    assert np.allclose(vector[:2] / np.linalg.norm(vector[:2]), np.array([2, 1]) / np.sqrt(5))
    assert "task = executed" in [v[1] for v in items.values() if v[0] == "label"]
    drawer.clear()
    assert not session.scene.items


def test_force_hints_start_at_the_contact_point():
    ex = load_exercise("2013-07-15#1")
    sol = solve(ex)
    session = FakeSession(ex.robot_ref, {k: v for k, v in ex.given.items() if k in ("l1", "l2", "l3")})
    drawer = HintDrawer(session)
    steps = [st for st in sol.steps if st.highlight.get("vectors")]
    assert steps
    for st in steps:
        hint = st.highlight["vectors"][0]
        drawer.draw(st.highlight, np.zeros(3))
        arrow = next(v for k, v in session.scene.items.items() if k.startswith("exercise_vector") and v[0] == "arrow")
        assert np.allclose(arrow[1][:2], hint["origin"][:2])
        direction = np.asarray(hint["vector"], float)[:2]
        assert np.allclose(arrow[2][:2] / np.linalg.norm(arrow[2][:2]), direction / np.linalg.norm(direction))
        assert session.scene.highlighted[0] == st.highlight.get("bodies", [])


# ====================================================================== in the browser
def wait_until(condition, timeout=60.0, what="condition"):
    shots.wait_until(condition, timeout, what)


def open_exercise(lab, browser, exercise_id, hide=True):
    """A new tab; the student opens the Exercises tab and picks the exercise in the dropdown."""
    page, session = shots.open_tab(lab, browser, "planar_2r", tab="Exercises", height=900, hide=hide)
    ex = load_exercise(exercise_id)
    shots.choose(page, "Exercise", option_label(ex))
    shots.wait_ready(page, ex.robot_ref)
    panel = session.open_panel("exercises")["panel"]
    wait_until(lambda: panel.solution is not None, what="the solution")
    page.get_by_text("steps revealed").first.wait_for(timeout=30000)
    return page, session, panel, ex


def math_boxes(page, selector):
    return page.evaluate(f"""() => [...document.querySelectorAll('{selector} math')]
        .map(m => m.getBoundingClientRect()).filter(r => r.width > 0 && r.height > 0).length""")


def click(page, name):
    page.get_by_role("button", name=name, exact=True).click()


def test_open_an_exercise_and_reveal_its_steps(lab, browser):
    page, session, panel, ex = open_exercise(lab, browser, "2004-03-25#1")
    try:
        assert session.robot_name == "rp_2004_03_25"
        assert np.allclose(session.q, [ex.configuration["q1"], ex.configuration["q2"]])
        wait_until(lambda: any(n.endswith("/link2__joint/sleeve") for n in shots.scene_node_names(page)), what="the RP robot")
        assert page.locator(".r2-question").inner_text().startswith("A planar RP robot moves in a vertical plane.")
        assert page.locator(".r2-notes").count() == 0            # no note gives a part away before its step
        count = len(panel.solution.steps)
        assert page.get_by_text(f"0 of {count} steps revealed").count() == 1
        click(page, "Next ▶")
        click(page, "Next ▶")
        page.locator('.r2-step[data-step="1"]').first.wait_for()
        step = panel.solution.steps[1]
        assert step.title == "Kinematics of link1"
        assert page.locator('.r2-step[data-step="1"]').first.inner_text().count("Kinematics of link1") == 1
        wait_until(lambda: math_boxes(page, '.r2-step[data-step="1"]') >= 1, what="typeset math of step 2")
        assert session.scene.highlighted["bodies"] == ["link1"]               # the link of the step, lit
        assert page.get_by_text("Steps revealed so far").count() == 1         # step 1 is kept above
        click(page, "◀ Previous")
        wait_until(lambda: panel.index == 0, what="one step back")
        click(page, "Show all")
        page.get_by_text(f"{count} of {count} steps revealed").first.wait_for()
        step_last = panel.solution.steps[-1]
        page.get_by_text("Numeric answers").first.wait_for()
        k = panel.solution.answer_step("closed_loop_nc")                      # the note on the print's error
        assert "printed solution" in page.locator(f'.r2-step[data-step="{k}"] .r2-notes').first.inner_text()
        with page.expect_download() as download:
            click(page, "Download the solution (Markdown)")
        text = open(download.value.path(), encoding="utf-8").read()
        assert text.startswith("# 2004-03-25#1") and "$$" in text and "Kinematics of link1" in text
        with page.expect_download() as download:
            click(page, "Download the solution (LaTeX)")
        tex = open(download.value.path(), encoding="utf-8").read()
        assert tex.startswith("% Exercise 2004-03-25#1") and r"\item \textbf{Kinematics of link1}" in tex
        # another robot picked by hand: the exercise waits, a button brings its robot back
        shots.choose(page, "Robot", "2R · Planar 2R arm (vertical plane)")
        shots.wait_ready(page, "planar_2r")
        back = page.get_by_role("button", name="Show the exercise's robot")
        back.wait_for()
        assert session.robot_name == "planar_2r" and not session.scene.highlighted["bodies"]
        back.click()
        shots.wait_ready(page, "rp_2004_03_25")
        wait_until(lambda: session.scene.highlighted["bodies"] == list(step_last.highlight.get("bodies", [])),
                   what="the last step lit again")
    finally:
        shots.close_tab(page)


def typed(page, label, text):
    box = shots.field(page, label)
    box.click()
    box.press("Control+a")
    box.press("Backspace")
    page.keyboard.type(text)


def test_a_variant_is_solved_and_a_bad_value_is_refused(lab, browser):
    page, session, panel, ex = open_exercise(lab, browser, "2020-06-05#1", hide=False)
    try:
        exam = panel.solution
        shots.open_folder(page, "Change the numbers (variant)")
        # a bad value: a clear message, nothing solved, the page keeps working
        typed(page, "V", "[1, fast, 2]")
        wait_until(lambda: dict((f.name, h.value) for f, h in panel._fields)["V"] == "[1, fast, 2]", what="typing")
        click(page, "Solve this variant")
        page.get_by_text("V: 'fast' is not a number").first.wait_for(timeout=10000)
        assert panel.solution is exam
        click(page, "Show all")
        wait_until(lambda: panel.index == len(exam.steps) - 1, what="the steps of the last good solution")
        # a value the engine refuses (lower bound above the upper one): a message, the last good solution stays
        typed(page, "V", "[-1, 1.5, 2]")
        wait_until(lambda: dict((f.name, h.value) for f, h in panel._fields)["V"] == "[-1, 1.5, 2]", what="typing")
        click(page, "Solve this variant")
        page.get_by_text("Could not solve").first.wait_for(timeout=30000)
        assert panel.solution is exam
        # a good variant: recomputed, the steps show its numbers
        typed(page, "V", "[1, 1, 1]")
        wait_until(lambda: dict((f.name, h.value) for f, h in panel._fields)["V"] == "[1, 1, 1]", what="typing")
        click(page, "Solve this variant")
        wait_until(lambda: panel.solution is not exam and panel.state.get("solved_values"), what="the variant")
        expected = solve(ex, given={"V": [1, 1, 1]}).answers["dq"]
        assert np.allclose(panel.solution.answers["dq"], expected)
        assert not np.allclose(expected, exam.answers["dq"])
        page.get_by_text("Variant: V = [1, 1, 1]").first.wait_for()
        card = page.locator(".r2-step").first
        wait_until(lambda: "SNS solution" in card.inner_text(), what="the last step of the variant")
        from app.core.latex import num
        assert f"<mn>{num(abs(expected[2]))}</mn>" in card.inner_html()
    finally:
        shots.close_tab(page)


def test_exam_sheet_button_offers_the_sheet_as_downloads(lab, browser):
    """Issue 12: "Exam sheet" makes the sheet of the typed exercises (or of the one shown) in the
    background and offers exam.html and solutions.html (the PDFs, which start a Chromium in the
    server, are left to tests/test_sheet.py); nothing chosen or an unknown id is refused."""
    page, session = shots.open_tab(lab, browser, "planar_2r", tab="Exercises", height=900, hide=False)
    try:
        shots.open_folder(page, "Printable exam sheet")
        page.get_by_role("button", name="Exam sheet", exact=True).wait_for(state="visible")
        click(page, "Exam sheet")                                       # no exercise shown, none typed
        page.get_by_text("open an exercise or type exercise ids first").first.wait_for(timeout=10000)
        panel = session.open_panel("exercises")["panel"]
        typed(page, "Exercises", "2022-07-08#3, nope#9")
        wait_until(lambda: panel.sheet_ids.value == "2022-07-08#3, nope#9", what="the typed ids")
        click(page, "Exam sheet")
        page.get_by_text("unknown exercise(s): nope#9").first.wait_for(timeout=10000)
        assert panel.state.get("sheet_files") is None and not panel.sheet_button.disabled
        typed(page, "Exercises", "2022-07-08#3")
        panel.sheet_pdf.value = False
        wait_until(lambda: panel.sheet_ids.value == "2022-07-08#3", what="the typed id")
        click(page, "Exam sheet")
        page.get_by_role("button", name="exam.html", exact=True).wait_for(timeout=60000)
        files = panel.state["sheet_files"]
        assert sorted(files) == ["exam.html", "solutions.html"]
        page.get_by_text("(PDF not asked for)").first.wait_for(timeout=5000)
        with page.expect_download() as download:
            click(page, "exam.html")
        assert download.value.suggested_filename == "sheet_2022-07-08-3_exam.html"
        text = open(download.value.path(), encoding="utf-8").read()
        assert "2022-07-08#3" in text and text.count("class='r2-sheet-exercise'") == 1
        assert not panel.sheet_button.disabled and panel.exercise is None
    finally:
        shots.close_tab(page)
