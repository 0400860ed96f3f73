"""static_equilibrium on a robot with a passive coordinate and a nonlinear spring (k delta +
k_n delta^3): the link equilibrium for a given motor position, and the motor position and
torque that hold a given link position; checked by substitution and by the weight balance."""
from app.core.exercise import parse_exercise, solve
from test_engine_bugs_13 import NONLINEAR_ROBOT

M, K, KN, G0 = 2.0, 100.0, 50.0, 9.81


def _solve(tmp_path, task):
    (tmp_path / "robot.yaml").write_text(NONLINEAR_ROBOT)
    return solve(parse_exercise({"id": "t", "robot": "robot.yaml", "question": "?", "tasks": [task]},
                                str(tmp_path / "ex.yaml"))).answers


def test_link_rest_position_for_a_given_motor_position(tmp_path):
    ans = _solve(tmp_path, {"kind": "static_equilibrium", "fixed": {"theta": 0.1}})
    q = float(ans["equilibrium_at"][0])
    d = 0.1 - q
    assert abs(K * d + KN * d ** 3 + M * G0) < 1e-9       # the spring carries the weight
    assert abs(ans["u_hold_at"][0] + M * G0) < 1e-9        # the motor holds the same force


def test_motor_position_that_holds_a_given_link_position(tmp_path):
    ans = _solve(tmp_path, {"kind": "static_equilibrium", "fixed": {"q": 0.25}, "solve_for": ["theta"]})
    d = float(ans["equilibrium_at"][0]) - 0.25
    assert abs(K * d + KN * d ** 3 + M * G0) < 1e-9
    # in closed form: q_d + the real root of the cubic, with the robot's symbols
    assert {s.name for s in ans["equilibrium"][0].free_symbols} == {"k", "k_n", "g0", "m"}
