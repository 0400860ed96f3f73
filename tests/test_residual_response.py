"""Momentum residual after a collision, simulated, against its first-order response."""
import numpy as np

from app.core.exercise import parse_exercise, solve


def test_collision_force_on_a_moving_arm_is_filtered_at_first_order():
    ex = parse_exercise({"id": "t", "robot": "planar_2r", "question": "q", "given": {},
                         "tasks": [{"kind": "residual_response", "q": [0.3, 0.6], "velocity": [0.5, -0.4],
                                    "force": [3.0, -2.0], "point": "ee", "t_c": 0.2, "gains": [20, 10],
                                    "duration": 0.8, "at": [0.1, 0.25, 0.8]}]})
    a = solve(ex).answers
    assert a["r_deviation"] < 1e-7                      # residual = filter of J(q(t))^T F along the motion
    assert np.allclose(a["r_at"][0], 0, atol=1e-8)      # nothing before the collision
    assert not np.allclose(a["r_at"][1], 0, atol=1e-2)
    # the arm moves, so J^T F changes: the closed form for the initial J^T F is only approximate
    assert np.allclose(a["r_at"], a["r_filter_at"], atol=1e-7)
    assert not np.allclose(a["r_at"][2], a["r_closed_form_at"][2], atol=1e-6)


def test_held_arm_follows_the_closed_form():
    ex = parse_exercise({"id": "t", "robot": "planar_2r", "question": "q", "given": {},
                         "tasks": [{"kind": "residual_response", "q": [0.3, 0.6], "torque": [4.0, -1.0],
                                    "gains": 8, "duration": 1.0, "at": [0.05, 0.3, 1.0]}]})
    a = solve(ex).answers
    assert np.allclose(a["r_at"], a["r_closed_form_at"], atol=1e-8)   # constant tau_d: exact first order
    assert np.allclose(a["r_steady"], [4.0, -1.0])
