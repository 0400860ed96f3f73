"""The entries the page offers to "Check my answer" (app/core/answer_check.py model_entries and
exercise_entries): every one of them is accepted by the checker with the engine's own answer."""
import sympy as sp

from app.core.answer_check import (check_exercise_answer, check_model_entry, exercise_entries, model_entries)
from app.core.dynamics import derive
from app.core.exercise import load_exercise, solve
from app.core.robot import load_robot


def _text(value):
    if isinstance(value, sp.MatrixBase):
        rows = value.tolist()
        if value.cols == 1:
            return "[" + ", ".join(str(r[0]) for r in rows) + "]"
        return "[" + "; ".join(", ".join(str(x) for x in r) for r in rows) + "]"
    return str(value)


def test_every_offered_model_entry_of_a_3r_is_checkable():
    robot = load_robot("planar_3r")
    dyn = derive(robot)
    entries = model_entries(robot, dyn)
    names = [e for e, _ in entries]
    assert len(names) == len(set(names))
    assert names.count("m11") == 1 and "m21" not in names          # M once (upper triangle)
    assert sum(n.startswith("c") and "_" in n for n in names) == 3 * 6
    M = dyn.M
    for entry in ("m11", "m23", "c1_23", "g3", "a1", "Ycol2", "C21"):
        assert entry in names
    for i in range(3):
        for j in range(i, 3):
            assert check_model_entry(robot, dyn, f"m{i + 1}{j + 1}", str(M[i, j])).correct
    wrong = check_model_entry(robot, dyn, "g3", "0")
    assert not wrong.correct


def test_exercise_entries_follow_the_revealed_steps():
    solution = solve(load_exercise("2004-03-25#1"))
    everything = exercise_entries(solution)
    first_m = solution.answer_step("M")
    assert ("M", f"step {first_m + 1}") in everything
    early = [e for e, _ in exercise_entries(solution, upto_step=first_m - 1)]
    assert "M" not in early and "M[1,1]" not in early
    now = [e for e, _ in exercise_entries(solution, upto_step=first_m)]
    assert "M" in now and "M[2,2]" in now
    value = solution.answers["M"][1, 1]
    assert check_exercise_answer(solution, "M[2,2]", str(value)).correct
