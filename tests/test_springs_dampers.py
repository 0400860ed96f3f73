"""Springs and dampers between any coordinates, nonlinear spring laws (issue 13), and the one rule for
parameter values owned by the robot module (issue 14)."""
import re

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import solve_ivp

from app.core.dynamics import derive
from app.core.exercise import ExerciseError, load_exercise, solve
from app.core.expressions import symbol
from app.core.numeric import NumericModel, ParameterError, cross_check
from app.core.robot import load_robot, parse_robot
from app.core.trig import equal
from app.viewer import parse_parameter

ROBOT = "elastic_pendulum_damped"


def test_nonlinear_spring_and_damper_terms():
    robot = load_robot(ROBOT)
    dyn = derive(robot)
    K, K3, D = (symbol(s) for s in ("K", "K3", "D"))
    q, th = robot.q
    dq, dth = robot.dq
    delta, rate = th - q, dth - dq
    assert equal(dyn.potential["joint"], K * delta ** 2 / 2 + K3 * delta ** 4 / 4)
    law = K * delta + K3 * delta ** 3
    for got, want in zip(dyn.spring, (-law, law)):          # k(q) = (d delta/dq)^T f(delta)
        assert equal(got, want)
    for got, want in zip(dyn.friction, (-D * rate, D * rate)):
        assert equal(got, want)
    assert str(dyn.spring[1]) == "K*(-q + theta) + K3*(-q + theta)**3", "the force law stays compact"
    assert {"K", "K3", "D"} <= {str(a) for a in dyn.parametrization.a}


def test_damper_dissipates_its_power_exactly():
    """Free motion (no torque): E(t) + integral of D delta'^2 stays constant; friction coefficient D only."""
    robot = load_robot(ROBOT)
    num = NumericModel(robot)
    D = num.values["D"]
    n = robot.n

    def f(t, x):
        q, dq = x[:n], x[n:2 * n]
        rate = dq[1] - dq[0]
        return np.concatenate([dq, num.forward_dynamics(q, dq, np.zeros(n)), [D * rate ** 2]])

    x0 = np.array([-0.5, 0.2, 1.0, -2.0, 0.0])
    sol = solve_ivp(f, (0.0, 2.0), x0, method="DOP853", rtol=1e-11, atol=1e-11)
    assert sol.success
    E = np.array([sum(num.energy(x[:n], x[n:2 * n])) for x in sol.y.T])
    dissipated = sol.y[-1]
    assert dissipated[-1] > 1.0, "the damper must dissipate a visible amount in 2 s"
    assert np.max(np.abs(E + dissipated - E[0])) < 1e-7 * abs(E[0] - E[-1])


def test_damper_between_two_link_coordinates_maps_to_both():
    """A damper on q2 - q1 of a 2R arm: tau_f = D [[1, -1], [-1, 1]] q'."""
    data = {"name": "damped2r", "coordinates": ["q1", "q2"], "plane": "horizontal",
            "parameters": {"m": {"value": 1, "kind": "mass"}, "l": {"value": 1, "kind": "length"},
                           "D": {"value": 0.3, "kind": "friction"}},
            "bodies": [{"name": "a", "joint": {"q": "q1"}, "mass": "m", "com": ["l", 0, 0]},
                       {"name": "b", "joint": {"q": "q2", "origin": ["l", 0, 0]}, "mass": "m", "com": ["l", 0, 0]}],
            "dampers": [{"coefficient": "D", "expr": "q2 - q1"}]}
    robot = parse_robot(data, "damped2r")
    dyn = derive(robot, use_cache=False)
    D = symbol("D")
    dq = sp.Matrix(robot.dq)
    assert (dyn.friction - D * sp.Matrix([[1, -1], [-1, 1]]) * dq).expand() == sp.zeros(2, 1)
    assert cross_check(robot, states=5).ok


def test_cross_check_compares_springs_and_friction():
    check = cross_check(load_robot(ROBOT), states=10)
    assert {"spring", "friction"} <= set(check.max_rel_error) and check.ok, check.summary()


def test_one_rule_for_parameter_values():
    """The page's field, the numeric model, an exercise variant and the robot file all refuse a
    negative mass with the robot module's message."""
    robot = load_robot("planar_2r")
    message = re.escape("m1: a mass must not be negative (got -1)")
    with pytest.raises(ParameterError, match=message):
        parse_parameter(robot, "m1", "-1")
    with pytest.raises(ParameterError, match=message):
        NumericModel(robot, {"m1": -1.0})
    with pytest.raises(ExerciseError, match=message):
        solve(load_exercise("2004-03-25#1"), {"m1": -1})
    assert robot.check_parameter_value("m1", 0) == 0


def test_force_law_spring_equals_the_two_spring_form(tmp_path):
    """An elastic joint written with a force law gives the same model and motor reference as the
    same spring written as 1/2 k delta^2 plus 1/2 (k_n/2) (delta^2)^2."""
    from tests.test_engine_bugs_13 import NONLINEAR_ROBOT, _exercise
    law = NONLINEAR_ROBOT.replace("  - {stiffness: k, expr: theta - q}\n  - {stiffness: k_n/2, expr: (theta - q)**2}\n",
                                  "  - {expr: theta - q, force: k*delta + k_n*delta**3}\n")
    assert law != NONLINEAR_ROBOT
    answers = []
    for i, text in enumerate((NONLINEAR_ROBOT, law)):
        folder = tmp_path / str(i)
        folder.mkdir()
        answers.append(solve(_exercise(folder, text, [{"kind": "elastic_joints"}])).answers)
    numbers = {symbol("m"): 2.0, symbol("k"): 100.0, symbol("k_n"): 50.0, symbol("g0"): 9.81, symbol("q_d"): 0.3}
    a, b = (complex(sp.N(ans["theta_d"][0].subs(numbers))) for ans in answers)
    assert abs(a - b) < 1e-9 and abs(a.imag) < 1e-9
    assert all(equal(x, y) for x, y in zip(answers[0]["link_equations"], answers[1]["link_equations"]))
