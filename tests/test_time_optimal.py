"""Minimum time along a given path (phase plane): analytic cases, bounds along the motion."""
import math

import numpy as np
import pytest
import sympy as sp

from app.core.numeric import NumericModel
from app.core.planning import PlanningError, TimingLaw, bang_bang_min_time, minimum_time, trapezoid_min_time
from app.core.robot import load_robot
from app.core.time_optimal import JointPath, joint_motion, minimum_time_along_path, pendulum_bang_bang_shooting


def _ratios(res, path, num, torque=None, velocity=None, count=3001):
    """max_i |tau_i| / bound_i (and |q'_i| / V_i) at sampled instants of the optimal motion."""
    t = np.linspace(0.0, res.T, count)
    q, dq, ddq = joint_motion(res, path, t)
    cols = []
    if torque is not None:
        tau = np.array([num.inverse_dynamics(q[k], dq[k], ddq[k]) for k in range(t.size)])
        cols.append(np.abs(tau) / torque)
    if velocity is not None:
        cols.append(np.abs(dq) / velocity)
    return np.hstack(cols)


def test_cartesian_robot_under_gravity_is_an_exact_asymmetric_bang_bang():
    num = NumericModel(load_robot("kin_cartesian_pp"))
    m1, m2, g0 = (num.values[k] for k in ("m1", "m2", "g0"))
    U = np.array([60.0, 80.0])
    delta = np.array([0.5, 0.8])              # x and y (up, against gravity) move together
    path = JointPath.line([0.0, 0.0], delta)
    res, _ = minimum_time_along_path(path, num, torque=(-U, U), nodes=137)
    # along the line s'' is bounded by every joint: (m_i delta_i) s'' + g_i within +-U_i
    mass, g = np.array([m1 + m2, m2]), np.array([0.0, m2 * g0])
    up = min((U - g) / (mass * delta))
    down = min((U + g) / (mass * delta))
    law = bang_bang_min_time(1.0, up, down)
    assert abs(res.T - law.T) < 1e-12 * law.T
    assert [a.kind for a in res.arcs] == ["accelerate", "decelerate"]
    assert abs(res.switch_points[0][1] - law.Ts) < 1e-12
    r = _ratios(res, path, num, torque=U)
    assert r.max() <= 1 + 1e-9 and r.max(axis=1).min() >= 1 - 1e-9   # a bound is active at every instant


def test_velocity_and_acceleration_bounds_give_bang_coast_bang_and_bang_bang():
    V, A = np.array([1.0, 2.0]), np.array([3.0, 5.0])
    for goal in ([2.0, -1.0], [0.3, 0.2]):
        path = JointPath.line([0.0, 0.0], goal)
        res, _ = minimum_time_along_path(path, velocity=V, acceleration=A, nodes=101)
        d = np.abs(goal)
        law = trapezoid_min_time(1.0, min(V / d), min(A / d))
        assert abs(res.T - law.T) < 1e-12 * law.T
        assert [a.kind for a in res.arcs] == (["accelerate", "limit", "decelerate"] if law.kind == "trapezoidal"
                                               else ["accelerate", "decelerate"])
        t = np.linspace(0, res.T, 2001)
        _, dq, ddq = joint_motion(res, path, t)
        assert np.all(np.abs(dq) <= V + 1e-9) and np.all(np.abs(ddq) <= A + 1e-9)


def test_pendulum_minimum_time_equals_bang_bang_shooting():
    num = NumericModel(load_robot("kin_pendulum"))
    inertia, mgd, U, goal = num.M([0.0])[0, 0], num.g([math.pi / 2])[0], 20.0, 2.0
    T_shoot, ts = pendulum_bang_bang_shooting(inertia, mgd, U, goal)
    path = JointPath.line([0.0], [goal])
    res, _ = minimum_time_along_path(path, num, torque=([-U], [U]), nodes=1000)
    assert abs(res.T - T_shoot) < 1e-5 * T_shoot
    assert abs(res.switch_points[0][1] - ts) < 1e-3
    r = _ratios(res, path, num, torque=[U])
    assert r.max() <= 1 + 1e-3 and r.min() >= 1 - 1e-3      # |tau| = U throughout (to the grid's accuracy)


def test_rp_robot_on_a_circle_slides_on_the_velocity_limit_of_its_second_joint():
    num = NumericModel(load_robot("rp_radial_horizontal"))
    I1, I2, m2, d = (num.values[k] for k in ("I1", "I2", "m2", "d"))
    R, alpha, U = 1.0, math.pi / 2, np.array([10.0, 6.0])
    s = sp.Symbol("s")
    path = JointPath.from_expressions([alpha * s, R], s)
    res, _ = minimum_time_along_path(path, num, torque=(-U, U), nodes=300)
    A, V = U[0] / (I1 + I2 + m2 * (R - d) ** 2), math.sqrt(U[1] / (m2 * (R - d)))
    assert abs(res.T - (alpha / V + V / A)) < 1e-12
    assert [t for _, t in res.switch_points] == pytest.approx([V / A, alpha / V], abs=1e-12)
    r = _ratios(res, path, num, torque=U)
    assert r.max() <= 1 + 1e-9 and r.max(axis=1).min() >= 1 - 1e-9


def test_two_link_arm_respects_torque_and_velocity_bounds_with_one_active_at_every_instant():
    num = NumericModel(load_robot("planar_2r"))
    U, V = np.array([200.0, 60.0]), np.array([2.0, 3.0])
    path = JointPath.line([0.0, 0.0], [1.5, -1.0])
    res, _ = minimum_time_along_path(path, num, torque=(-U, U), velocity=V, nodes=600)
    r = _ratios(res, path, num, torque=U, velocity=V)
    assert r.max() <= 1 + 2e-3
    assert r.max(axis=1).min() >= 1 - 2e-3
    # no timing law of a fixed shape along the same path is faster
    law_class = minimum_time(lambda T: TimingLaw.trapezoidal(1.0, T=T, ratio=0.3),
                             lambda p, v, a: np.array([num.inverse_dynamics(path.q(x)[0], path.q_s(x)[0] * w, path.q_s(x)[0] * y)
                                                       for x, w, y in zip(np.atleast_1d(p), np.atleast_1d(v), np.atleast_1d(a))]),
                             lambda p: np.array([num.g(path.q(x)[0]) for x in np.atleast_1d(p)]), U, samples=401)
    assert res.T < law_class.T


def test_refuses_paths_that_the_bounds_cannot_hold():
    num = NumericModel(load_robot("kin_pendulum"))
    with pytest.raises(PlanningError):
        minimum_time_along_path(JointPath.line([0.0], [2.0]), num, torque=([-5.0], [5.0]), nodes=50)   # m g d = 14.7
    with pytest.raises(PlanningError):
        minimum_time_along_path(JointPath.line([0.0], [1.0]), nodes=50)
