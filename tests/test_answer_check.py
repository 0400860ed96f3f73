"""Check my answer (app/core/answer_check.py): right answers written in other valid forms are
accepted, typical mistakes are refused with the right diagnosis, over several robots and
exercises; the command line gives exit codes 0 / 1 / 2."""
import functools
import json

import pytest

from app.core.answer_check import check_exercise_answer, check_model_entry
from app.core.answer_reading import AnswerError
from app.core.dynamics import derive
from app.core.exercise import load_exercise, solve
from app.core.robot import load_robot


@functools.lru_cache(maxsize=None)
def model(name):
    robot = load_robot(name)
    return robot, derive(robot)


@functools.lru_cache(maxsize=None)
def solution(exercise_id):
    return solve(load_exercise(exercise_id))


def check(target, entry, answer, **kw):
    if "#" in target:
        return check_exercise_answer(solution(target), entry, answer, **kw)
    robot, dyn = model(target)
    return check_model_entry(robot, dyn, entry, answer, **kw)


P2 = "planar_2r"
RIGHT = [
    # planar 2R: expanded, factored, course shorthand, products of sines and cosines, Unicode
    (P2, "m11", "I1 + I2 + m1*d1**2 + m2*l1**2 + m2*d2**2 + 2*m2*l1*d2*cos(q2)"),
    (P2, "m11", "I1 + I2 + m1 d1^2 + m2 (l1^2 + d2^2) + 2 m2 l1 d2 (c12 c1 + s12 s1)"),
    (P2, "m12", "I2 + m2 (d2^2 + l1 d2 c2)"),
    (P2, "m12", "I2 + m2·d2² + m2·l1·d2·c2"),
    (P2, "m22", "m2 d2 d2 + I2"),
    (P2, "m21", "I2 + m2*d2^2 + m2*l1*d2*cos(q2)"),
    (P2, "c1", "-m2 l1 d2 s2 q2' (2 q1' + q2')"),
    (P2, "c1", "-2*m2*l1*d2*sin(q2)*dq1*dq2 - m2*l1*d2*sin(q2)*dq2**2"),
    (P2, "c2", "m2 l1 d2 s2 q1'^2"),
    (P2, "g1", "g0 (m1 d1 + m2 l1) c1 + g0 m2 d2 cos(q1+q2)"),
    (P2, "g1", "g0 m1 d1 c1 + g0 m2 (l1 c1 + d2 (c1 c2 - s1 s2))"),
    (P2, "g2", "m2*g0*d2*c12"),
    (P2, "c1_12", "-m2 l1 d2 s2"),
    (P2, "c122", "-m2*l1*d2*sin(q2)"),
    (P2, "C", "[[-m2 l1 d2 s2 q2', -m2 l1 d2 s2 (q1' + q2')], [m2 l1 d2 s2 q1', 0]]"),
    (P2, "C", "[-2 m2 l1 d2 s2 q2', -m2 l1 d2 s2 q2'; m2 l1 d2 s2 q1', 0]"),
    (P2, "a", "[I1 + d1^2 m1 + l1^2 m2 + I2 + d2^2 m2, d1 m1 + l1 m2, I2 + d2^2 m2, d2 m2]"),
    (P2, "a", "[d2 m2 l1, I2 + d2^2 m2, d1 m1 + l1 m2, I1 + d1^2 m1 + l1^2 m2]"),
    (P2, "M", "[[I1 + I2 + m1 d1^2 + m2 (l1^2 + d2^2 + 2 l1 d2 c2), I2 + m2 (d2^2 + l1 d2 c2)], "
              "[I2 + m2 (d2^2 + l1 d2 c2), I2 + m2 d2^2]]"),
    # planar RP of 2004-03-25 (prismatic coordinate inside the inertia)
    ("rp_2004_03_25", "m11", "I1 + I2 + m1 d1^2 + m2 l1^2 + m2 q2^2"),
    ("rp_2004_03_25", "g1", "g0 m2 q2 c1 + g0 (m1 d1 + m2 l1) s1"),
    ("rp_2004_03_25", "c1", "2 m2 q2 q1' q2'"),
    ("rp_2004_03_25", "c2", "-m2 q2 q1'^2"),
    # planar 3R: sums of three angles
    ("planar_3r", "m33", "I3 + m3 d3^2"),
    ("planar_3r", "m13", "I3 + d3^2 m3 + d3 l1 m3 c23 + d3 l2 m3 c3"),
    ("planar_3r", "g3", "d3 g0 m3 (c1 c23 - s1 s23)"),
    # spatial 3R of 2024-06-12: squares of cosines written with the double angle
    ("spatial_3r_2024_06_12", "m22", "I_c2z + I_c3z + m2 d_c2^2 + m3 (a2^2 + d_c3^2 + 2 a2 d_c3 c3)"),
    ("spatial_3r_2024_06_12", "m11", "I_c1y + I_c2x + I_c3x + 2 a2 d_c3 m3 c2 c23 + (I_c3z - I_c3x + m3 d_c3^2) c23^2"
                                     " + (I_c2z - I_c2x + m2 d_c2^2 + m3 a2^2) (1 + cos(2 q2))/2"),
    # PRP of 2009-06-10
    ("prp_2009_06_10", "m12", "(m2 d_c2 + m3 q3 - m3 d_c3) c2"),
    ("prp_2009_06_10", "m13", "m3 s2"),
    # exercise answers: symbolic, fractions, numbers to the printed digits
    ("2009-06-10#1", "T_link2", "I2 q2'^2/2 + m2 (q1'^2 + d_c2^2 q2'^2)/2 + m2 d_c2 c2 q1' q2'"),
    ("2020-04-15-mid#Q3", "dq", "[3/7, 1/7, 2/7]"),
    ("2020-04-15-mid#Q3", "dq_norm", "0.5345"),
    ("2020-04-15-mid#Q3", "dq_norm", "0.535"),
    ("2020-04-15-mid#Q3", "dq[2]", "0.142857"),
    ("2004-03-25#1", "closed_loop_nc[1]", "(q2 q1'^2 - g0 s1 - a2)/l1"),
]

WRONG = [
    # (target, entry, answer, the finding expected among the diagnosis)
    (P2, "m22", "I2", "missing_term"),                                            # a missing Steiner term
    (P2, "m11", "I1 + I2 + m2 (l1^2 + d2^2 + 2 l1 d2 c2)", "missing_term"),       # Steiner term of link 1
    (P2, "c1", "m2 l1 d2 s2 (2 q1' q2' + q2'^2)", "sign"),                        # sign of the Coriolis terms
    (P2, "c1", "-2 m2 l1 d2 s2 q1' q2' + m2 l1 d2 s2 q2'^2", "sign"),             # sign of the centrifugal term
    (P2, "m11", "I1 + I2 + m1 d1^2 + m2 (l1^2 + d2^2 + 2 l1 d2 s2)", "sin_cos"),  # sin for cos
    (P2, "m11", "I1 + I2 + m1 d1^2 + m2 (l1^2 + d2^2 + l1 d2 c2)", "factor"),     # a wrong factor 2
    (P2, "m12", "I2 + m2 d2^2", "missing_term"),                                  # a forgotten coupling
    (P2, "g2", "g0 m2 d2 c2", "function"),                                        # cos q2 for cos(q1 + q2)
    (P2, "m22", "I2 + m2 d2^2 + m2 l1 d2 c2", "dependence"),                       # depends on q2, should not
    (P2, "c2", "m2 l1 d2 s2 q2'^2", "dependence"),                                # q2' for q1'
    (P2, "m11", "2 I1 + I2 + m1 d1^2 + m2 (l1^2 + d2^2 + 2 l1 d2 c2)", "factor"),
    (P2, "g1", "(m1 d1 + m2 l1) c1 + g0 m2 d2 c12", "units"),                     # g0 forgotten: not a torque
    (P2, "m22", "I2 + m2 d2", "units"),
    (P2, "c1_12", "m2 l1 d2 s2", "sign"),
    (P2, "C", "[[0, 0], [0, 0]]", "factorization"),
    (P2, "a", "[I1 + d1^2 m1 + l1^2 m2, d1 m1 + l1 m2, I2 + d2^2 m2]", "count"),
    (P2, "a", "[I1 + d1^2 m1 + l1^2 m2, d1 m1 + l1 m2, I2 + d2^2 m2, I2 + d2^2 m2]", "span"),
    (P2, "a", "[m1, d1 m1 + l1 m2, I2 + d2^2 m2, d2 m2]", "span"),
    (P2, "m12", "[I2, 0]", "shape"),
    ("rp_2004_03_25", "m11", "I1 + I2 + m1 d1^2 + m2 l1^2", "missing_term"),
    ("rp_2004_03_25", "g1", "g0 m2 q2 s1 + g0 (m1 d1 + m2 l1) c1", "sin_cos"),
    ("rp_2004_03_25", "c1", "m2 q2 q1' q2'", "factor"),
    ("rp_2004_03_25", "m12", "m2 q2", "dependence"),
    ("planar_3r", "m13", "I3 + d3^2 m3 + d3 l1 m3 c2 + d3 l2 m3 c3", "function"),
    ("planar_3r", "g3", "d3 g0 m3 c3", "function"),
    ("spatial_3r_2024_06_12", "m22", "I_c2z + m2 d_c2^2 + m3 (a2^2 + d_c3^2 + 2 a2 d_c3 c3)", "missing_term"),
    ("prp_2009_06_10", "m13", "m3 c2", "sin_cos"),
    ("2009-06-10#1", "T_link2", "I2 q2'^2/2 + m2 (q1'^2 + d_c2^2 q2'^2)/2", "missing_term"),
    ("2020-04-15-mid#Q3", "dq_norm", "0.5", "digits"),
    ("2020-04-15-mid#Q3", "dq_norm", "0.545", "value"),
    ("2020-04-15-mid#Q3", "dq_norm", "-0.5345", "sign"),
    ("2020-04-15-mid#Q3", "dq_norm", "5.345", "factor"),
    ("2020-04-15-mid#Q3", "dq", "[3/7, 2/7, 2/7]", "value"),
    ("2004-03-25#1", "closed_loop_nc[1]", "(q2 q1'^2 - g0 s1 + a2)/l1", "sign"),
]


@pytest.mark.parametrize("target, entry, answer", RIGHT, ids=[f"{t}:{e}:{k}" for k, (t, e, _) in enumerate(RIGHT)])
def test_equivalent_forms_are_accepted(target, entry, answer):
    verdict = check(target, entry, answer)
    assert verdict.correct, (answer, verdict.text())


@pytest.mark.parametrize("target, entry, answer, kind", WRONG, ids=[f"{t}:{e}:{k}" for t, e, _, k in WRONG])
def test_mistakes_are_refused_with_the_right_diagnosis(target, entry, answer, kind):
    verdict = check(target, entry, answer)
    assert not verdict.correct, (answer, verdict.text())
    kinds = [f.kind for f in verdict.findings]
    assert kind in kinds, (answer, kinds, verdict.text())


def test_counts():
    assert len(RIGHT) >= 30 and len(WRONG) >= 30


def test_the_diagnosis_does_not_give_the_answer_away():
    verdict = check(P2, "m22", "I2")
    missing = next(f for f in verdict.findings if f.kind == "missing_term")
    assert "d_{2}^{2} m_{2}" in missing.message and "Steiner" in missing.message
    value = next(f for f in verdict.findings if f.kind == "value")
    assert value.data["expected"] == pytest.approx(0.15 + 1.5 * 0.4 ** 2, rel=1e-9) or value.data["expected"] > 0


def test_a_non_skew_factorization_is_refused_when_skew_symmetry_is_asked():
    non_skew = "[-2 m2 l1 d2 s2 q2', -m2 l1 d2 s2 q2'; m2 l1 d2 s2 q1', 0]"
    assert check(P2, "C", non_skew).remarks
    verdict = check(P2, "C", non_skew, skew=True)
    assert not verdict.correct and verdict.findings[0].kind == "skew"
    assert check(P2, "C", "[[-m2 l1 d2 s2 q2', -m2 l1 d2 s2 (q1' + q2')], [m2 l1 d2 s2 q1', 0]]", skew=True).correct


def test_hint_level_two_points_at_the_step_to_recheck():
    verdict = check(P2, "m22", "I2", hint=2)
    assert verdict.step is not None and verdict.step.title == "Kinematics of link2"
    assert check(P2, "m22", "I2").step is None


def test_unreadable_answers_and_unknown_entries():
    for entry, answer in (("m22", "I2 + m2 d2^"), ("m22", "__import__('os')"), ("m99", "1"), ("x7", "1"),
                          ("m22", "I2 + m7")):
        with pytest.raises(AnswerError):
            check(P2, entry, answer)


def test_command_line_exit_codes_and_json(capsys):
    from app.cli import main
    assert main(["check-answer", P2, "--entry", "m22", "--answer", "I2 + m2 d2^2"]) == 0
    assert main(["check-answer", P2, "--entry", "m22", "--answer", "I2", "--json", "--hint", "2"]) == 1
    out = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert out["correct"] is False and out["entry"] == "m22" and out["step"]["title"] == "Kinematics of link2"
    assert {"kind", "message", "term"} <= set(out["findings"][0])
    assert main(["check-answer", P2, "--entry", "m22", "--answer", "I2 +"]) == 2
