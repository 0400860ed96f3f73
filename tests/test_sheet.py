"""Exam sheets (python -m app sheet): five exercises with seeded variants, each variant's answers
equal to a fresh solve, the PDFs printed by headless Chromium with one exercise per page, and the
same seed giving the same sheet."""
import numpy as np
import pytest

from app.core.compare import same
from app.core.exercise import solve
from app.core.sheet import make_sheet
from app.viewer.sheets import answer_number_texts, exam_html, pdf_page_count, solutions_html, write_sheet

EXERCISES = ["2020-04-15-mid#Q3", "2009-09-10#2", "2020-06-05#1", "2007-04-19#1", "2022-07-08#3"]
SEED = 3
CDOT = r" \cdot"


@pytest.fixture(scope="module")
def sheet():
    return make_sheet(EXERCISES, seed=SEED)


def test_variants_are_valid_and_re_solved_by_the_engine(sheet):
    statuses = {e.exercise.id: e.status for e in sheet.entries}
    assert statuses["2007-04-19#1"] == "as is"          # symbolic answers: reprinted, and said so
    assert sum(s == "variant" for s in statuses.values()) >= 3, (f"seed {SEED}", statuses)
    for entry in sheet.entries:
        if entry.status != "variant":
            continue
        fresh = solve(entry.varied_exercise(), given=entry.given)
        for name, value in fresh.answers.items():
            plain = value.tolist() if isinstance(value, np.ndarray) else value
            assert same(plain, entry.solution.answers[name], tol=1e-9), (f"seed {SEED}", entry.exercise.id, name)
        robot = fresh.robot
        for name, value in entry.changes.items():
            p = robot.parameters.get(name)
            if p is not None and p.kind in ("mass", "length", "inertia", "com"):
                assert value > 0, (f"seed {SEED}", entry.exercise.id, name, value)


def test_the_solutions_sheet_prints_the_variants_answers(sheet):
    doc = solutions_html(sheet)
    assert doc.count('class="r2-sheet-exercise"') == 0 and doc.count("class='r2-sheet-exercise'") == len(EXERCISES)
    sections = doc.split("<section ")[1:]
    for entry, section in zip(sheet.entries, sections):
        assert f"data-exercise='{entry.exercise.id}'" in section
        for name, value in entry.solution.answers.items():
            if isinstance(value, (float, np.floating, np.ndarray, list)) and np.asarray(value, dtype=object).size < 20:
                try:
                    texts = answer_number_texts(value)
                except (TypeError, ValueError):
                    continue
                part = section.split(f"data-answer='{name}'")[1].split("</td>")[0]
                for t in texts:
                    mantissa = t.split(CDOT)[0].lstrip("-")
                    assert f"<mn>{mantissa}</mn>" in part, (entry.exercise.id, name, t)


def test_same_seed_same_sheet(sheet):
    again = make_sheet(EXERCISES, seed=SEED)
    assert exam_html(again) == exam_html(sheet) and solutions_html(again) == solutions_html(sheet)
    other = make_sheet(EXERCISES[:1], seed=SEED + 1)
    assert other.entries[0].changes != sheet.entries[0].changes


def test_pdfs_have_one_exercise_per_page(sheet, tmp_path, browser):
    paths = write_sheet(sheet, tmp_path, browser=browser)
    names = sorted(p.name for p in paths)
    assert names == ["exam.html", "exam.pdf", "solutions.html", "solutions.pdf"]
    assert pdf_page_count(tmp_path / "exam.pdf") == len(EXERCISES)
    assert pdf_page_count(tmp_path / "solutions.pdf") >= len(EXERCISES)
    assert (tmp_path / "exam.pdf").read_bytes().startswith(b"%PDF")


def test_sheet_files_for_the_exercises_tab(browser):
    """The Exercises tab's "Exam sheet" files (app/viewer/sheets.py sheet_files): the same sheet as
    the command line's, with PDFs when a Chromium is at hand; an unknown exercise is one clear error."""
    from app.core.errors import UserError
    from app.core.sheet import make_sheet
    from app.viewer.sheets import exam_html, sheet_files
    seen = []
    files, note = sheet_files(["2022-07-08#3"], seed=4, pdf=False, progress=lambda f, m: seen.append(f))
    assert sorted(files) == ["exam.html", "solutions.html"] and note == "PDF not asked for"
    assert files["exam.html"].decode("utf-8") == exam_html(make_sheet(["2022-07-08#3"], seed=4))
    assert seen and all(0.0 <= f <= 1.0 for f in seen)
    files, note = sheet_files(["2022-07-08#3"], seed=4, browser=browser)
    assert note == "" and files["solutions.pdf"].startswith(b"%PDF") and len(files["exam.pdf"]) > 1000
    with pytest.raises(UserError, match="nope#9"):
        sheet_files(["nope#9"])
    with pytest.raises(UserError, match="no exercise chosen"):
        sheet_files([])
