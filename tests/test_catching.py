"""The catching arm of the 4M20 coursework: Table 1, the interception of the 45-degree throw, the
reachable region, the trapezoidal plan (Table 2) and the catch of a throwing-arm release."""
import math

import numpy as np
import pytest

from app.core.catching import BallFlight, CatchingArm, WEIGHTED_RATIO, catch_scene, plan_catch

START = np.radians([30.0, 120.0, 80.0])      # the coursework's start configuration
TABLE_1 = [  # theta1, theta2, theta3 [deg], x, y [m] (coursework Table 1)
    (2.377, 102.5, 137.9, 0.4999, 0.4998),
    (43.49, 127.9, 37.63, 0.4999, 0.4992),
    (42.58, 148.3, -40.99, 0.5001, 0.5004),
    (-0.1004, 103.6, 144.8, 0.4995, 0.5006),
]


@pytest.fixture(scope="module")
def arm():
    return CatchingArm()


@pytest.mark.parametrize("row", TABLE_1)
def test_table_1_forward_kinematics(arm, row):
    q = np.radians(row[:3])
    assert np.allclose(arm.forward(q), row[3:], atol=5e-5)


@pytest.mark.parametrize("row", TABLE_1)
def test_table_1_rows_belong_to_the_ik_family(arm, row):
    """Each printed row is the family member at its own hand orientation, to the print's rounding."""
    q = np.radians(row[:3])
    phi = q[1] + q[2] - q[0]
    sol = arm.ik([0.5, 0.5], phi, elbow=1 if q[1] > 0 else -1)
    assert sol is not None and arm.within_limits(sol)
    assert np.allclose(np.degrees(sol), row[:3], atol=0.08)
    assert np.allclose(arm.forward(sol), [0.5, 0.5], atol=1e-12)
    family = arm.ik_family([0.5, 0.5])
    dist = min(np.abs(np.degrees(b[1:]) - np.array(row[:3])[:, None]).max(axis=0).min() for b in family)
    assert dist < 0.5


def test_every_family_member_reaches_the_point_within_limits(arm):
    for branch in arm.ik_family([0.5, 0.5], samples=361):
        assert arm.within_limits(branch[1:]).all()
        assert np.allclose(arm.forward(branch[1:]), [[0.5], [0.5]], atol=1e-10)


def test_reachable_region_is_the_upper_half_disk_of_radius_1_9(arm):
    """Coursework: a semicircle of radius L1 + L2 + L3 = 1.9 m above the floor."""
    lines = arm.reachable_region(resolution=0.02)
    assert len(lines) == 1
    b = lines[0]
    r = np.hypot(b[:, 0], b[:, 1])
    assert abs(r.max() - 1.9) < 0.02 and b[:, 1].min() >= 0.0
    assert np.allclose(b[0], b[-1], atol=1e-9)                     # closed
    area = 0.5 * abs(np.dot(b[:-1, 0], b[1:, 1]) - np.dot(b[1:, 0], b[:-1, 1]))
    assert abs(area - math.pi * 1.9 ** 2 / 2) < 0.03 * math.pi * 1.9 ** 2 / 2


def test_interception_time_of_the_45_degree_throw(arm):
    """Eq. (2) at the coursework's catch point [0.956, 1.634]: 0.289 s."""
    ball = BallFlight.coursework(u=10, alpha_deg=45, x0=3, y0=0)
    t = ball.time_at_height(1.634)[0]
    assert t == pytest.approx(0.289, abs=5e-4)
    assert np.allclose(ball.position(t), [0.956, 1.634], atol=5e-4)
    plan = plan_catch(arm, ball, START)                             # middle of the reachable stretch
    t0, t1 = plan.window
    assert 0.26 < t0 < 0.27 and 0.30 < t1 < 0.31                    # print reads [1.09, 1.55]..[0.85, 1.69] off its plot
    assert abs(plan.time - 0.289) < 0.004


def test_catch_configuration_and_table_2(arm):
    """At the coursework's catch point: least l1 motion from (30, 120, 80) deg gives
    (-25.65, 5.85, 8.256) deg (phi sampled every 0.25 deg there), and the weighted trapezoids give
    Table 2's first rows; constant speed and ramp rows follow from the same displacements."""
    ball = BallFlight.coursework(alpha_deg=45)
    plan = plan_catch(arm, ball, START, time=ball.time_at_height(1.634)[0])
    assert np.allclose(np.degrees(plan.q_catch), [-25.65, 5.85, 8.256], atol=0.35)
    assert np.allclose(np.abs(np.degrees(plan.joint_speed_max)), [303.9, 623.5, 391.8], rtol=6e-3)
    assert np.allclose(np.abs(np.degrees(plan.joint_acceleration_max)), [2870, 5888, 3700], rtol=6e-3)
    delta = np.abs(np.degrees(plan.q_catch - START))
    assert np.allclose(delta / plan.time, [192.6, 395, 248.2], rtol=6e-3)            # step profile
    assert np.allclose(2 * delta / plan.time, [385, 790, 496], rtol=6e-3)            # ramp: speed
    assert np.allclose(2 * delta / plan.time ** 2, [1333, 2733, 1718], rtol=6e-3)    # ramp: acceleration
    q_end = plan.joint_motion([plan.time])[:, 0]
    assert np.allclose(arm.forward(q_end), plan.point, atol=1e-9)
    assert abs(WEIGHTED_RATIO - 0.3660) < 1e-4


def test_78_degree_throw_enters_late_and_60_degree_throw_is_never_reachable(arm):
    b78 = BallFlight.coursework(alpha_deg=78)
    plan = plan_catch(arm, b78, START, method="closest")
    assert plan.window[0] == pytest.approx(1.8, abs=0.05) and b78.landing_time() == pytest.approx(2.0, abs=0.05)
    assert abs(plan.time - 1.92) < 0.005                           # print samples time every 0.01 s
    assert np.allclose(plan.point, [-0.9919, 0.6986], atol=0.035)
    with pytest.raises(Exception, match="never enters"):
        plan_catch(arm, BallFlight.coursework(alpha_deg=60), START)


def test_catch_scene_of_a_release(arm):
    scene = catch_scene([0.2, 1.5], [4.0, 3.0], arm=arm)
    tc = scene["catch_time"]
    ball = BallFlight.from_release([0.2, 1.5], [4.0, 3.0])
    assert np.allclose(ball.position(tc), scene["catch_point"], atol=1e-9)
    q_end = np.array(scene["q"][-1])
    hand = arm.forward(q_end) + np.array(scene["base"])
    assert np.allclose(hand, scene["catch_point"], atol=1e-9)
    assert arm.within_limits(q_end)


def test_a_throw_of_the_throwing_arm_is_caught(arm):
    """The thesis's throw one, solved by the VHC engine, flies into the catching arm's reach."""
    from app.core.catching import catch_thesis_throw
    scene = catch_thesis_throw("throw1", arm=arm)
    ball = BallFlight.from_release(scene["release"], scene["velocity"], scene["g"])
    tc = scene["catch_time"]
    assert 0 < tc < ball.landing_time()
    assert np.allclose(ball.position(tc), scene["catch_point"], atol=1e-9)
    hand = arm.forward(np.array(scene["q"][-1])) + np.array(scene["base"])
    assert np.allclose(hand, scene["catch_point"], atol=1e-9)
    assert scene["base"][0] > scene["release"][0]
