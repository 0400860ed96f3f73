"""configurations on robots other than its exam: the singular configurations of a planar 2R
(sin q2 = 0) and of the PR's task Jacobian of 2022-04-13-mid#5 (cos q2 = 0), and a term that
vanishes (the gravity torque of link 2 of a vertical 2R), each checked by substitution."""
import sympy as sp

from app.core.exercise import parse_exercise, solve
from app.core.expressions import symbol


def _solve(robot, tasks):
    return solve(parse_exercise({"id": "t", "robot": robot, "question": "?", "tasks": tasks,
                                 "configuration": {"q1": 0.3, "q2": 0.4}})).answers


def test_singular_configurations_of_a_2r_and_of_a_task_jacobian():
    ans = _solve("planar_2r", [{"kind": "jacobian", "point": "ee"}, {"kind": "configurations", "matrix": "J"}])
    assert ans["configurations_solutions"] == sp.Matrix([[symbol("q2"), 0], [symbol("q2"), sp.pi]])
    # the end effector of the PR (q1 vertical, link 2 of length L): det J = L sin q2
    ans = _solve("pr_vertical_guide", [{"kind": "jacobian", "point": "ee"}, {"kind": "configurations", "matrix": "J"}])
    q2 = symbol("q2")
    assert ans["configurations_solutions"] == sp.Matrix([[q2, 0], [q2, sp.pi]])
    # a wide matrix that never loses rank: (1, L cos q2), A A^T = 1 + L^2 cos^2 q2 > 0 has no real root
    ans = _solve("pr_vertical_guide", [{"kind": "configurations", "matrix": [["1", "L*cos(q2)"]]}])
    assert ans["configurations_solutions"].rows == 0


def test_configurations_where_the_gravity_torque_of_link_2_vanishes():
    ans = _solve("planar_2r", [{"kind": "dynamics"}, {"kind": "configurations", "equation": "d2*m2*g0*cos(q1 + q2)"}])
    g2 = ans["g"][1]
    for coord, value in ans["configurations_solutions"].tolist():
        assert sp.simplify(g2.subs(coord, value)) == 0
