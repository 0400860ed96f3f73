"""Every step and note a user sees is readable: plain sentences with the math between $...$ as
LaTeX (the convention of app/core/mathtext.py), no Python structures, rounded numbers; each note
tied to a step names a step or answer that exists; the terminal and Markdown outputs carry every
step's formulas."""
import pytest

from app.core.exercise import list_exercises
from app.core.mathtext import RULE, latex_to_unicode, problems, to_unicode

EXERCISES = list_exercises()


@pytest.mark.parametrize("exercise", EXERCISES, ids=[e.id for e in EXERCISES])
def test_steps_and_notes_are_readable(exercise, solved):
    solution = solved(exercise)
    found = []
    for k, step in enumerate(solution.steps, 1):
        found += [f"step {k} title: {p}" for p in problems(step.title)]
        found += [f"step {k} text: {p}" for p in problems(step.text)]
        found += [f"step {k} latex: {p}" for p in problems(step.latex, "latex")]
        if "$" in step.latex:
            found.append(f"step {k} latex: a formula has no $...$ inside")
    for i, note in enumerate(solution.notes):
        found += [f"note {i + 1}: {p}" for p in problems(note)]
    assert not found, f"{exercise.id}: unreadable text shown to users.\nRULE: {RULE}\n" + "\n".join(found)
    assert len(solution.note_steps) == len(solution.notes)


def test_the_rule_catches_what_the_issue_saw():
    seen = ["V = 1/2 s^T M(q) s", "then T = 1/2 m |v_c|^2", "Rows x, y of {'body': 'link1', 'at': ['lc1', 0, 0]}.",
            r"Bounds \begin{pmatrix} 10 \\ 6 \end{pmatrix}.", "singular values below 1e-09", "q'' = a on q1"]
    for text in seen:
        assert problems(text), text
    fixed = [r"$V = \frac{1}{2} s^T M(q)\, s$", r"Rows $x$, $y$ of the point at $(l_{c1}, 0, 0)$ of link1.",
             "the robot's joints, in rad/s and m/s", r"with $\dot q_2^2$ and $\ddot q = a$ on $q_1$"]
    for text in fixed:
        assert not problems(text), (text, problems(text))


def test_terminal_text_is_unicode_math():
    assert to_unicode(r"Collect $T = \frac{1}{2} \dot q^T M(q) \dot q$.") == "Collect T = ½ q̇ᵀ M(q) q̇."
    block = latex_to_unicode(r"M(q) = \left(\begin{matrix}a + b & c\\c & d\end{matrix}\right)", display=True)
    assert block.splitlines() == ["M(q) = ⎛ a + b  c ⎞", "       ⎝ c      d ⎠"]


def test_notes_go_with_their_step():
    from app.core.exercise import parse_exercise, solve
    ex = parse_exercise({"id": "t", "robot": "planar_2r", "question": "?", "tasks": ["dynamics"],
                         "notes": ["about everything", {"note": "the print's $g_2$ is wrong", "answer": "g"},
                                   {"note": "look at $C_1$", "step": "Christoffel matrix"}]})
    sol = solve(ex)
    g_step = next(k for k, s in enumerate(sol.steps) if s.title == "Gravity vector")
    c_step = next(k for k, s in enumerate(sol.steps) if s.title.startswith("Christoffel matrix"))
    assert sol.step_notes(g_step) == ["the print's $g_2$ is wrong"]
    assert sol.step_notes(c_step) == ["look at $C_1$"]
    assert sol.general_notes() == ["about everything"]
    md = sol.markdown()
    for note, k in (("the print's $g_2$ is wrong", g_step), ("look at $C_1$", c_step)):
        assert md.index(f"### {k + 1}.") < md.index(note) < md.index(f"### {k + 2}."), note
    assert md.index("about everything") > md.index(f"### {len(sol.steps)}.")
