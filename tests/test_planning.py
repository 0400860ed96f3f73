"""Timing laws, minimum time and time scaling."""
import math

import numpy as np
import pytest

from app.core.planning import (PlanningError, TimingLaw, bang_bang_min_time, jerk_inversion, minimum_time,
                               sample_times, second_order_inversion, trapezoid_min_time, uniform_time_scaling)


@pytest.mark.parametrize("law", [
    TimingLaw.polynomial("cubic", 2.0, 1.5), TimingLaw.polynomial("quintic", -1.0, 0.7),
    TimingLaw.bang_bang(3.0, T=2.0), TimingLaw.trapezoidal(5.0, T=2.0, V=3.0),
    TimingLaw.trapezoidal(1.0, T=1.0, ratio=0.25), bang_bang_min_time(0.4, 3.5, 23.1)])
def test_rest_to_rest_and_consistent_derivatives(law):
    t = np.linspace(0, law.T, 20001)
    p, v, a = law(t)
    assert abs(p[0]) < 1e-12 and abs(p[-1] - law.delta) < 1e-9 and abs(v[0]) < 1e-12 and abs(v[-1]) < 1e-9
    assert np.allclose(np.gradient(p, t), v, atol=2e-3 * max(1, abs(law.V)))
    assert abs(np.max(np.abs(v)) - abs(law.V)) < 1e-3 * abs(law.V) + 1e-9
    assert abs(np.max(np.abs(a)) - max(abs(law.A), abs(law.A_dec or 0))) < 1e-9 + 1e-6 * abs(law.A)


def test_bang_coast_bang_of_2022_09_09():
    law = TimingLaw.trapezoidal(5.0, T=2.0, V=3.0)
    assert abs(law.A - 9.0) < 1e-12              # A = V^2 / (T V - L)


def test_minimum_time_with_velocity_and_acceleration_bounds():
    assert trapezoid_min_time(5, V=3, A=9).kind == "trapezoidal"
    law = trapezoid_min_time(0.5, V=3, A=9)
    assert law.kind == "bang_bang" and abs(law.T - 2 * math.sqrt(0.5 / 9)) < 1e-12


def test_minimum_time_of_a_pendulum_equals_a_direct_search():
    I, mgd, U = 13.333333333333334, 98.1, 200.0

    def torque(p, v, a):
        th = math.pi * np.asarray(p)
        return (I * math.pi * np.asarray(a) + mgd * np.sin(th))[:, None]

    def gravity(p):
        return (mgd * np.sin(math.pi * np.asarray(p)))[:, None]

    make = lambda T: TimingLaw.trapezoidal(1.0, T=T, ratio=0.25)
    res = minimum_time(make, torque, gravity, [U])
    assert abs(res.T - 1.2165) < 1e-4            # 2019-07-11#3
    for T, feasible in ((res.T * 1.001, True), (res.T * 0.999, False)):
        t = sample_times(make(T), 20001)
        assert (np.abs(torque(*make(T)(t))).max() <= U + 1e-9) == feasible


def test_time_scaling_brings_the_worst_torque_to_the_bound():
    rng = np.random.default_rng(1)
    tau, g = rng.normal(size=(50, 2)) * 30, rng.normal(size=(50, 2)) * 5
    ts = uniform_time_scaling(tau, g, [20.0, 25.0])
    scaled = (tau - g) / ts.k ** 2 + g
    assert np.all(np.abs(scaled) <= np.array([20.0, 25.0]) + 1e-9)
    assert np.isclose(np.max(np.abs(scaled) / [20.0, 25.0]), 1.0)
    with pytest.raises(PlanningError):
        uniform_time_scaling([[40.0]], [[30.0]], [20.0])


def test_second_order_and_jerk_inversion_reproduce_the_task():
    J = np.array([[1.0, 2.0, 0.0], [0.0, 1.0, 1.0]])
    dJ, ddJ = np.eye(2, 3) * 0.3, np.eye(2, 3) * -0.2
    dq, ddq = np.array([0.1, -0.2, 0.3]), np.array([1.0, 0.0, -1.0])
    ddp = np.array([1.0, 2.0])
    qdd = second_order_inversion(J, dJ @ dq, ddp)
    assert np.allclose(J @ qdd + dJ @ dq, ddp)
    dddp = np.array([-1.0, 0.5])
    qddd = jerk_inversion(J, dJ, ddJ, dq, ddq, dddp)
    assert np.allclose(J @ qddd + 2 * dJ @ ddq + ddJ @ dq, dddp)
