"""The three engine bugs of issue 13, each on an exercise written in the documented format:
1. elastic joints with a nonlinear spring (k delta + k_n delta^3) got the linear theta_d;
2. steady_rotation crashed when the equation to solve was not trigonometric;
3. an earlier task's answer silently shadowed a `given` entry of the same name."""
import numpy as np
import pytest
import sympy as sp

from app.core.exercise import ExerciseError, parse_exercise, solve
from app.core.expressions import symbol

# a hanging mass (prismatic, pointing down) driven by a motor theta through a joint spring
# with a linear and a cubic force: U_K = k/2 (theta - q)^2 + k_n/4 (theta - q)^4
NONLINEAR_ROBOT = """
name: nl_elastic_mass
title: Hanging mass driven through a nonlinear spring (test only)
coordinates: [q, theta]
parameters:
  m: {value: 2.0, kind: mass}
  k: {value: 100.0, kind: stiffness}
  k_n: {value: 50.0, kind: stiffness}
  B_m: {value: 0.1, kind: inertia}
  g0: {value: 9.81, kind: gravity}
gravity: [0, 0, -g0]
bodies:
  - name: slider
    joint: {type: prismatic, axis: -z, q: q}
    mass: m
    inertia: 0
motors:
  theta: B_m
springs:
  - {stiffness: k, expr: theta - q}
  - {stiffness: k_n/2, expr: (theta - q)**2}
actuated: [theta]
"""


def _exercise(tmp_path, robot_text, tasks, given=None):
    (tmp_path / "robot.yaml").write_text(robot_text)
    data = {"id": "bug", "robot": "robot.yaml", "question": "?", "tasks": tasks, "given": given or {}}
    return parse_exercise(data, str(tmp_path / "exercise.yaml"))


def test_elastic_joint_with_nonlinear_spring_solves_the_cubic(tmp_path):
    sol = solve(_exercise(tmp_path, NONLINEAR_ROBOT, [{"kind": "elastic_joints"}]))
    theta_d = sol.answers["theta_d"][0]
    q_d = symbol("q_d")
    numbers = {symbol("m"): 2.0, symbol("k"): 100.0, symbol("k_n"): 50.0, symbol("g0"): 9.81}
    delta = complex(sp.N((theta_d - q_d).subs(numbers)))
    assert abs(delta.imag) < 1e-9
    d = delta.real
    # the link at rest: the spring force k d + k_n d^3 (d = theta - q) carries the weight m g0,
    # here pulling up against gravity along the downward axis: k d + k_n d^3 = -m g0
    assert abs(100.0 * d + 50.0 * d ** 3 + 2.0 * 9.81) < 1e-9
    # the linear answer q_d - m g0 / k (the bug) is far from it
    assert abs(d - (-2.0 * 9.81 / 100.0)) > 1e-3
    # the link equation at rest vanishes at (q_d, theta_d) for any q_d
    link = sol.answers["link_equations"][0]
    rest = {symbol("ddq"): 0, symbol("q"): q_d, symbol("theta"): theta_d}
    for qv in (-0.4, 0.0, 0.7):
        assert abs(complex(sp.N(link.subs(rest).subs(numbers).subs(q_d, qv)))) < 1e-8


def test_elastic_joint_with_linear_spring_keeps_the_closed_form(tmp_path):
    robot = NONLINEAR_ROBOT.replace("  - {stiffness: k_n/2, expr: (theta - q)**2}\n", "")
    sol = solve(_exercise(tmp_path, robot, [{"kind": "elastic_joints"}]))
    expected = symbol("q_d") - symbol("g0") * symbol("m") / symbol("k")
    assert sp.simplify(sol.answers["theta_d"][0] - expected) == 0


def test_steady_rotation_with_a_prismatic_free_coordinate(tmp_path):
    from app.core.robot import robot_path
    robot = robot_path("rp_radial_horizontal").read_text()
    sol = solve(_exercise(tmp_path, robot, [{"kind": "steady_rotation", "spin": {"q1": "Omega"},
                                                 "zero": ["q2"]}]))
    # -m2 (q2 - d) Omega^2 = 0: the CoM of link 2 on the axis, q2 = d
    rows = sol.answers["equilibria"]
    assert rows.shape == (1, 1)
    assert sp.simplify(rows[0, 0] - symbol("d")) == 0


def test_an_answer_may_not_shadow_a_given_entry(tmp_path):
    from app.core.robot import robot_path
    robot = robot_path("planar_2r").read_text()
    ex = _exercise(tmp_path, robot, [{"kind": "dynamics"}], given={"U": [1.0, 2.0]})
    with pytest.raises(ExerciseError, match=r"tasks\[0\] \(dynamics\).*'U'.*given entry 'U'"):
        solve(ex)
