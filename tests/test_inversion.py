"""Second-order and jerk-level inversion tasks: the commanded motion really produces the task."""
import numpy as np
import pytest

from app.core.exercise import ExerciseError, parse_exercise, solve
from app.core.jacobians import evaluate, task_function
from app.core.robot import load_robot

Q, DQ, DDQ = [0.3, 0.8, -0.5], [0.5, -0.2, 0.4], [0.7, 0.1, -0.3]


def _exercise(order, task, extra=None):
    spec = {"kind": "inversion", "name": "x", "jacobian": "J", "order": order, "task": task, "joint_velocity": DQ}
    spec.update(extra or {})
    if order == 3:
        spec["joint_acceleration"] = DDQ
    return parse_exercise({"id": "t", "robot": "planar_3r", "question": "q", "given": {},
                           "tasks": [{"kind": "jacobian", "name": "J", "point": "ee", "q": Q}, spec]})


def _task_derivatives(x, order, h=2e-3):
    """Derivatives of p(q(t)) at t = 0 for q(t) with the given q', q'' (and q''' = x or q'' = x),
    by central differences of the exact forward kinematics."""
    robot = load_robot("planar_3r")
    r = task_function(robot, "ee", ["x", "y"])
    coeffs = [np.array(Q), np.array(DQ)] + ([x] if order == 2 else [np.array(DDQ), x])
    fact = [1, 1, 2, 6]
    p = lambda t: evaluate(robot, r, sum(c * t ** k / fact[k] for k, c in enumerate(coeffs))).reshape(-1)
    if order == 2:
        return (p(h) - 2 * p(0) + p(-h)) / h ** 2
    return (p(2 * h) - 2 * p(h) + 2 * p(-h) - p(-2 * h)) / (2 * h ** 3)


@pytest.mark.parametrize("order, task", [(2, [1.0, -0.5]), (3, [2.0, 1.0])])
def test_commanded_motion_produces_the_task_derivative(order, task):
    sol = solve(_exercise(order, task, {"damping": 2.0}))
    x = np.asarray(sol.answers["x"])
    assert np.allclose(_task_derivatives(x, order), task, atol=1e-4)
    assert sol.answers["x_kkt_gap"] < 1e-10
    assert np.allclose(sol.answers["x_preferred"], -2.0 * np.array(DQ if order == 2 else DDQ))


def test_null_space_term_does_not_change_the_task_and_weights_change_the_solution():
    plain = solve(_exercise(2, [1.0, -0.5])).answers["x"]
    damped = solve(_exercise(2, [1.0, -0.5], {"damping": 5.0})).answers["x"]
    weighted = solve(_exercise(2, [1.0, -0.5], {"weights": [1, 10, 1]})).answers["x"]
    J = solve(_exercise(2, [1.0, -0.5])).answers["J_num"]
    assert np.allclose(J @ (damped - plain), 0, atol=1e-12) and not np.allclose(damped, plain)
    assert np.allclose(J @ (weighted - plain), 0, atol=1e-12) and abs(weighted[1]) < abs(plain[1])


def test_refuses_a_jacobian_without_symbolic_form():
    ex = parse_exercise({"id": "t", "robot": "planar_3r", "question": "q", "given": {},
                         "tasks": [{"kind": "jacobian", "name": "J", "matrix": [[1, 0, 0], [0, 1, 0]]},
                                   {"kind": "inversion", "jacobian": "J", "task": [1, 0], "joint_velocity": DQ}]})
    with pytest.raises(ExerciseError):
        solve(ex)
