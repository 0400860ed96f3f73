"""LaTeX out (issue 18, part 4): `derive ROBOT --latex` and `solve ID --latex` write amsmath
fragments whose every formula goes through the page's LaTeX -> MathML route and whose environments
and braces are balanced."""
import pytest

from app.cli import main
from app.core.dynamics import derive
from app.core.exercise import load_exercise
from app.core.robot import load_robot, load_robot_text
from app.core.tex import formulas, model_tex, solution_tex, text_tex, unbalanced
from app.viewer.mathml import latex_to_mathml


def assert_sound(tex: str, least: int) -> None:
    """Balanced environments and braces, at least ``least`` formulas, each converted to MathML."""
    assert unbalanced(tex) == []
    found = formulas(tex)
    assert len(found) >= least, len(found)
    for formula in found:
        markup = latex_to_mathml(formula)
        assert markup.startswith("<math") and "<merror" not in markup, formula


@pytest.mark.parametrize("name, least", [("planar_2r", 20), ("contact_mass_2018_06_11", 8),
                                         ("spatial_3r_2017_03_29", 30)])
def test_model_fragment(name, least):
    """About 1 s each with a warm derivation cache (the spatial arm: 3 s cold). The robots: the
    2R (shorthand c_12), a mass with a spring and viscous friction, a spatial arm whose matrices
    are written entry by entry."""
    robot = load_robot(name)
    dyn = derive(robot)
    tex = model_tex(robot, dyn, steps=True)
    assert_sound(tex, least)
    assert r"\begin{enumerate}" in tex and tex.count(r"\item ") == len(dyn.steps)
    if name == "planar_2r":
        # the compact forms of the page: m_22 = I2 + d2^2 m2, gravity with c_12
        assert "m_{22} = I_{2} + d_{2}^{2} m_{2}" in tex
        assert r"d_{2} g_{0} m_{2} c_{12}" in tex
    if name == "contact_mass_2018_06_11":
        assert r"\paragraph{Springs $k(q)$}" in tex and r"\paragraph{Friction}" in tex


@pytest.mark.parametrize("exercise", ["2004-03-25#1", "2016-07-11#2", "2016-07-11#3", "2019-06-17#5", "2012-06-11#1"])
def test_solution_fragment(exercise, solved):
    """Between 0.5 and 3 s each (one solve, shared with the other tests of the session):
    model and adaptive control, hybrid force/velocity control, a force loop with an integral (its
    equilibrium once wrote a double subscript), redundancy, trajectory timing."""
    sol = solved(load_exercise(exercise))
    tex = solution_tex(sol)
    assert_sound(tex, len([s for s in sol.steps if s.latex]))
    assert tex.count(r"\item \textbf{") == len(sol.steps)
    assert text_tex(sol.exercise.title) in tex


def test_sentences_are_escaped_and_math_kept():
    """Cheap: LaTeX's special characters outside $...$ are escaped, formulas inside are kept."""
    robot = load_robot_text("""
name: odd_text
title: "A & B: 50% of #1 ~ x_1 {y} \\\\ ^"
description: "Mass on a line, $m \\\\ddot x = u$ — says $F = m a$"
coordinates: [x]
parameters: {m: {value: 1, kind: mass}}
gravity: [0, 0, 0]
bodies:
  - {name: cart, joint: {type: prismatic, axis: x, q: x}, mass: m}
""", "odd_text.yaml")
    tex = model_tex(robot, derive(robot, use_cache=False))
    assert r"\subsection*{A \& B: 50\% of \#1 \textasciitilde{} x\_1 \{y\} \textbackslash{} \textasciicircum{}}" in tex
    assert r"Mass on a line, $m \ddot x = u$ --- says $F = m a$" in tex
    assert_sound(tex, 6)


def test_command_line_writes_the_fragments(tmp_path, capsys):
    """About 1 s (in-process command line: derive, a variant of an exercise to standard output,
    a file that cannot be written)."""
    out = tmp_path / "model.tex"
    assert main(["derive", "planar_2r", "--latex", str(out)]) == 0
    assert capsys.readouterr().out.strip() == f"wrote {out}"
    assert_sound(out.read_text(encoding="utf-8"), 20)
    assert main(["solve", "2004-03-25#1", "--latex", "-", "--set", "l1=0.7"]) == 0
    printed = capsys.readouterr().out
    assert r"\paragraph{Numbers of this variant}" in printed and r"\item l1 $=$ 0.7" in printed
    assert_sound(printed, 10)
    assert main(["derive", "planar_2r", "--latex", str(tmp_path / "no" / "x.tex")]) == 2
    error = capsys.readouterr().err
    assert error.count("\n") == 1 and error.startswith("error: --latex ")
