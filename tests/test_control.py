"""The properties the course proves for its controllers, checked in closed-loop simulation on the
exam robots (issue 4 acceptance)."""
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import fsolve

from app.core.control import CONTROLLERS, make_controller
from app.core.controller_base import GainError, parse_gains
from app.core.numeric import ModelTerms, NumericModel, TaskPoint
from app.core.robot import load_robot
from app.core.sim import PointForce, Surface, simulate

FIXTURES = Path(__file__).parent / "fixtures"


def second_order_error(e0, de0, kp, kd, t):
    """Exact solution of e'' + kd e' + kp e = 0 (any damping)."""
    disc = kd * kd - 4 * kp
    if abs(disc) < 1e-12:
        w = kd / 2
        return (e0 + (de0 + w * e0) * t) * np.exp(-w * t)
    if disc > 0:
        r1, r2 = (-kd + np.sqrt(disc)) / 2, (-kd - np.sqrt(disc)) / 2
        c2 = (de0 - r1 * e0) / (r2 - r1)
        return (e0 - c2) * np.exp(r1 * t) + c2 * np.exp(r2 * t)
    sig, wd = -kd / 2, np.sqrt(-disc) / 2
    return np.exp(sig * t) * (e0 * np.cos(wd * t) + (de0 - sig * e0) / wd * np.sin(wd * t))


# ---------------------------------------------------------------------- computed torque
@pytest.mark.parametrize("robot_name,reference", [
    ("planar_2r", "quintic from=0,0 goal=1.0,-0.5 T=1.5"),
    ("rp_2004_03_25", "sine center=0,0.2 amplitude=0.4,0.1 f=0.5"),
])
def test_computed_torque_error_follows_the_linear_closed_loop(robot_name, reference):
    """e'' + K_D e' + K_P e = 0 per joint: critically damped on joint 1 (w = 10), underdamped
    (zeta = 0.3, w = 8) on joint 2; the error matches the exact exponential solution."""
    robot = load_robot(robot_name)
    kp = np.array([100.0, 64.0])
    kd = np.array([20.0, 2 * 0.3 * 8.0])
    q0 = np.array([0.3, 0.15]) if robot_name == "planar_2r" else np.array([0.2, 0.05])
    res = simulate(robot, "computed_torque", reference=reference, q0=q0, duration=3.0,
                   gains={"Kp1": kp[0], "Kp2": kp[1], "Kd1": kd[0], "Kd2": kd[1]})
    assert res.completed
    for j in range(2):
        exact = second_order_error(res.e[0, j], res.de[0, j], kp[j], kd[j], res.t)
        assert abs(res.e[0, j]) > 0.05
        # up to the zero-order hold of the torque over 1 ms
        assert np.max(np.abs(res.e[:, j] - exact)) < 1e-2 * abs(res.e[0, j]), robot_name
    # after 20 time constants of joint 1 only the zero-order-hold floor is left
    k = np.searchsorted(res.t, 2.0)
    assert abs(res.e[k, 0]) < 1e-3 * abs(res.e[0, 0])


def test_computed_torque_with_model_mismatch_leaves_an_error_that_adaptive_removes():
    """Journey 3: a wrong mass in the model spoils computed torque; adaptive control recovers."""
    ref = "sine amplitude=0.6,0.8 f=0.5,0.35"
    mismatch = {"m2": 3.0, "I2": 0.15}
    ct = simulate("planar_2r", "computed_torque", reference=ref, q0=[0, 0], duration=10.0, model_params=mismatch)
    ad = simulate("planar_2r", "adaptive", reference=ref, q0=[0, 0], duration=10.0, model_params=mismatch,
                  gains={"Gamma": 3.0})
    late = ct.t > 8.0
    err_ct = np.abs(ct.e[late]).max()
    err_ad = np.abs(ad.e[late]).max()
    assert err_ct > 0.01
    assert err_ad < err_ct / 5


# ---------------------------------------------------------------------- regulation
@pytest.mark.parametrize("name", ["pd_gravity", "pd_gravity_const"])
@pytest.mark.parametrize("robot_name,goal", [("planar_2r", [0.8, -0.6]), ("rp_2004_03_25", [0.5, 0.2])])
def test_pd_with_gravity_compensation_regulates(name, robot_name, goal):
    res = simulate(robot_name, name, reference=f"setpoint goal={goal[0]},{goal[1]}", q0=[0.0, 0.0],
                   duration=12.0, gains={"Kp": 400, "Kd": 80})
    assert res.completed
    assert np.max(np.abs(res.e[-1])) < 1e-4
    assert np.max(np.abs(res.dq[-1])) < 1e-3


@pytest.mark.parametrize("robot_name,goal", [("planar_2r", [0.8, -0.6]), ("rp_2004_03_25", [0.5, 0.2])])
def test_pd_without_compensation_stops_where_the_model_says(robot_name, goal):
    """At rest K_P (q_d - q_ss) = g(q_ss): solve it from the model and compare."""
    robot = load_robot(robot_name)
    kp = np.array([400.0, 300.0])
    res = simulate(robot, "pd", reference=f"setpoint goal={goal[0]},{goal[1]}", q0=[0.0, 0.0], duration=15.0,
                   gains={"Kp1": kp[0], "Kp2": kp[1], "Kd": 80})
    num = NumericModel(robot)
    qd = np.array(goal)
    q_ss = fsolve(lambda q: kp * (qd - q) - num.g(q), qd, xtol=1e-13)
    assert np.max(np.abs(kp * (qd - q_ss) - num.g(q_ss))) < 1e-9
    assert np.max(np.abs(qd - q_ss)) > 0.01                 # a real steady-state error
    assert np.max(np.abs(res.q[-1] - q_ss)) < 1e-6


def test_iterative_learning_reproduces_exam_2018_02_05():
    """Pendulum of 2018-02-05#3: k_p = 500, k_d = 45, theta_d = pi/3 from theta_0 = 0; the
    iterates of the printed Table 1 (theta_i, u_i) and i_min = 4 for |e| < 0.01 rad."""
    T = 8.0
    res = simulate(FIXTURES / "pendulum_2018_02_05.yaml", "learning", reference="setpoint goal=pi/3",
                   q0=[0.0], duration=4 * T + 0.5, gains={"Kp": 500, "Kd": 45, "T": T})
    assert res.completed
    table_theta = [0.8942, 1.0318, 1.0458, 1.0471]
    table_u = [76.4904, 84.1916, 84.8886, 84.9510]
    for i, (theta, u) in enumerate(zip(table_theta, table_u), start=1):
        k_end = int(round(i * T * res.rate)) - 1              # last sample of iteration i
        assert res.q[k_end, 0] == pytest.approx(theta, abs=1e-4)
        assert res.internals["u_q1"][k_end + 2] == pytest.approx(u, abs=2e-3)
        assert res.internals["iteration"][k_end + 2] == i
    # the contraction bound of (33)-(35): |e_i| < 0.25^i |e_0|, below 0.01 rad from i = 4 on
    bounds = [0.25 ** i * np.pi / 3 for i in range(1, 5)]
    errors = [abs(np.pi / 3 - res.q[int(round(i * T * res.rate)) - 1, 0]) for i in range(1, 5)]
    assert all(e < b for e, b in zip(errors, bounds))
    assert bounds[2] > 0.01 > bounds[3]


# ---------------------------------------------------------------------- adaptive control
@pytest.mark.parametrize("robot_name,reference,mismatch", [
    ("planar_2r", "sine amplitude=0.5,0.8 f=0.4,0.3", {"m2": 3.0, "I2": 0.2, "m1": 8.0}),
    ("rp_2004_03_25", "sine amplitude=0.5,0.15 f=0.4,0.3 center=0.2,0.3", {"m2": 2.5, "m1": 10.0, "I1": 0.3}),
])
def test_adaptive_control_lyapunov_function_never_increases(robot_name, reference, mismatch):
    """V = 1/2 s^T M(q) s + 1/2 a~^T Gamma^-1 a~ (true M and a of the plant) is non-increasing up
    to integration error; the estimates stay in the ball allowed by V(0); the error shrinks."""
    robot = load_robot(robot_name)
    ctrl = make_controller("adaptive", {"Gamma": 2.0, "Kd": 20, "Lambda": 5})
    res = simulate(robot, ctrl, reference=reference, q0=[0.2, 0.1] if robot_name == "planar_2r" else [0.0, 0.2],
                   duration=8.0, model_params=mismatch)
    assert res.completed
    plant = ModelTerms(robot)
    a_true = ctrl.coefficients(plant.values)
    a_hat = np.column_stack([res.internals[f"a_hat{i + 1}"] for i in range(ctrl.count)])
    assert np.max(np.abs(a_hat[0] - a_true)) > 0.1            # the model was really wrong
    s = res.de + ctrl.Lambda * res.e
    kinetic = np.array([0.5 * s[k] @ plant.M(res.q[k]) @ s[k] for k in range(len(res.t))])
    estimate = 0.5 * np.sum((a_hat - a_true) ** 2 / ctrl.Gamma, axis=1)
    V = kinetic + estimate
    assert np.max(np.diff(V)) < 1e-5 * V[0]
    assert V[-1] < 0.2 * V[0]
    assert np.all(estimate <= V[0] * (1 + 1e-6))              # bounded estimates
    early = np.abs(res.e[res.t < 1.0]).max()
    late = np.abs(res.e[res.t > 7.0]).max()
    assert late < early / 4


# ---------------------------------------------------------------------- collision detection
def test_momentum_residual_is_zero_without_contact_and_tracks_the_contact_torque():
    """r' = K_I (J^T F - r): ~0 before the hit, then the filtered contact torque (compared with the
    same first-order filter applied to J^T F computed from the recorded states)."""
    robot = load_robot("planar_2r")
    KI = 50.0
    hit = PointForce(("link2", [0.4, 0, 0]), force=[-10.0, 5.0], start=1.0)
    res = simulate(robot, "pd_gravity", reference="sine amplitude=0.4,0.5 f=0.5", q0=[0.0, 0.3], duration=3.0,
                   gains={"Kp": 300, "Kd": 60}, contacts=[hit], observer=KI)
    assert res.completed
    r = np.column_stack([res.internals["r_q1"], res.internals["r_q2"]])
    before = res.t < 1.0
    assert np.max(np.abs(r[before])) < 1e-4
    point = TaskPoint(robot, ("link2", [0.4, 0, 0]))
    tau_ext = np.array([point.jacobian(q).T @ np.array([-10.0, 5.0]) if t >= 1.0 else np.zeros(2)
                        for q, t in zip(res.q, res.t)])
    assert np.max(np.abs(tau_ext)) > 5
    assert np.allclose(res.tau_ext, tau_ext, atol=1e-9)          # recorded by the simulation
    dt = 1.0 / res.rate
    filt = np.zeros_like(tau_ext)
    for k in range(1, len(res.t)):       # exact discretization of r' = K (tau_ext - r), tau_ext held
        filt[k] = tau_ext[k - 1] + (filt[k - 1] - tau_ext[k - 1]) * np.exp(-KI * dt)
    assert np.max(np.abs(r - filt)) < 0.02 * np.max(np.abs(tau_ext))
    settled = res.t > 1.2
    assert np.max(np.abs(r[settled] - tau_ext[settled])) < 0.05 * np.max(np.abs(tau_ext))


# ---------------------------------------------------------------------- underactuated: PFL (2004-03-25#1)
def _rp_values():
    return load_robot("rp_2004_03_25").parameter_values()


def test_collocated_pfl_on_the_rp_robot_gives_ddq1_equal_a1_and_the_exam_law():
    v = _rp_values()
    res = simulate("rp_2004_03_25", "pfl_collocated", reference="quintic goal=0.8 T=1.5", passive=["q2"],
                   q0=[0.0, 0.1], duration=1.5, gains={"Kp": 100, "Kd": 20})
    assert res.completed and res.reference_names == ["q1"]
    assert np.abs(res.tau[:, 1]).max() < 1e-12          # the passive joint
    a1 = res.internals["a_q1"]
    assert np.max(np.abs(res.ddq[:, 0] - a1)) < 1e-9 * max(1.0, np.abs(a1).max())
    q1, q2 = res.q[:, 0], res.q[:, 1]
    dq1, dq2 = res.dq[:, 0], res.dq[:, 1]
    I0p = v["I1"] + v["m1"] * v["d1"] ** 2 + v["I2"]              # I'_0 of L107
    u1 = ((I0p + v["m2"] * q2 ** 2) * a1 + v["m2"] * q2 * (2 * dq1 * dq2 + v["l1"] * dq1 ** 2)
          + v["g0"] * (v["m1"] * v["d1"] * np.sin(q1) + v["m2"] * q2 * np.cos(q1)))   # L111
    assert np.max(np.abs(res.tau[:, 0] - u1)) < 1e-9 * np.abs(u1).max()
    # the passive joint obeys the closed loop of L115
    ddq2 = -v["l1"] * a1 + q2 * dq1 ** 2 - v["g0"] * np.sin(q1)
    assert np.max(np.abs(res.ddq[:, 1] - ddq2)) < 1e-9 * max(1.0, np.abs(ddq2).max())


def test_noncollocated_pfl_on_the_rp_robot_gives_ddq2_equal_a2_and_the_exam_law():
    v = _rp_values()
    res = simulate("rp_2004_03_25", "pfl_noncollocated", reference="quintic goal=0.25 T=1.0", passive=["q2"],
                   q0=[0.0, 0.1], duration=0.6, gains={"Kp": 25, "Kd": 10})
    assert res.reference_names == ["q2"]
    a2 = res.internals["a_q2"]
    assert np.max(np.abs(res.ddq[:, 1] - a2)) < 1e-9 * max(1.0, np.abs(a2).max())
    q1, q2 = res.q[:, 0], res.q[:, 1]
    dq1, dq2 = res.dq[:, 0], res.dq[:, 1]
    I0 = v["I1"] + v["m1"] * v["d1"] ** 2 + v["I2"] + v["m2"] * v["l1"] ** 2
    md3 = v["m1"] * v["d1"] + v["m2"] * v["l1"]
    B = I0 + v["m2"] * q2 ** 2
    l1, g0, m2 = v["l1"], v["g0"], v["m2"]
    u1 = ((m2 * l1 - B / l1) * a2 + 2 * m2 * q2 * dq1 * dq2 + B * q2 / l1 * dq1 ** 2
          + g0 * (md3 * np.sin(q1) + m2 * q2 * np.cos(q1)) - B * g0 / l1 * np.sin(q1))   # L121
    assert np.max(np.abs(res.tau[:, 0] - u1)) < 1e-9 * np.abs(u1).max()
    assert np.abs(res.tau[:, 1]).max() < 1e-12          # the passive joint


def test_pfl_needs_a_passive_joint():
    with pytest.raises(GainError, match="passive"):
        simulate("rp_2004_03_25", "pfl_collocated", duration=0.1)


# ---------------------------------------------------------------------- elastic joints
def test_elastic_joint_pd_with_gravity_compensation_regulates_links_and_motors():
    robot = load_robot(FIXTURES / "elastic_2r.yaml")
    qd = np.array([0.5, 0.3])
    res = simulate(robot, "elastic_pd", reference="setpoint goal=0.5,0.3", q0=[0, 0, 0, 0], duration=25.0,
                   gains={"Kp": 400, "Kd": 40})
    assert res.completed and res.reference_names == ["q1", "q2"]
    num = NumericModel(robot)
    g_link = num.g([qd[0], qd[1], 0.0, 0.0])[:2]
    theta_d = qd + g_link / np.array([800.0, 500.0])               # q_d + K^-1 g(q_d)
    assert res.internals["theta_d_theta1"][0] == pytest.approx(theta_d[0], abs=1e-10)
    assert res.internals["theta_d_theta2"][0] == pytest.approx(theta_d[1], abs=1e-10)
    assert np.max(np.abs(res.q[-1, :2] - qd)) < 1e-5
    assert np.max(np.abs(res.q[-1, 2:] - theta_d)) < 1e-5
    assert np.abs(res.tau[:, :2]).max() < 1e-12


def test_elastic_joint_motor_pd_without_gravity_lyapunov_2024_06_12():
    """Exam 2024-06-12#3: no gravity, u = K_P (theta_d - theta) - K_D theta'. V = 1/2 q'^T M q' +
    1/2 theta'^T B theta' + 1/2 (q - theta)^T K (q - theta) + 1/2 (theta_d - theta)^T K_P
    (theta_d - theta) has V' = -theta'^T K_D theta' <= 0 and the robot comes to rest at q = theta = theta_d."""
    robot = load_robot(FIXTURES / "elastic_2r.yaml")
    no_gravity = {"g0": 0.0}
    kp = np.array([300.0, 200.0])
    res = simulate(robot, "elastic_pd", reference="setpoint goal=0.7,-0.4", q0=[0, 0, 0, 0], duration=20.0,
                   gains={"Kp1": kp[0], "Kp2": kp[1], "Kd": 40}, plant_params=no_gravity, model_params=no_gravity)
    assert res.completed
    theta_d = np.array([0.7, -0.4])
    assert np.allclose(res.internals["theta_d_theta1"][0], 0.7) and np.allclose(res.internals["theta_d_theta2"][0], -0.4)
    num = NumericModel(robot, no_gravity)
    V = np.array([sum(num.energy(q, dq)) + 0.5 * np.sum(kp * (theta_d - q[2:]) ** 2) for q, dq in zip(res.q, res.dq)])
    assert np.max(np.diff(V)) < 1e-6 * V[0]
    dissipated = np.sum(40 * res.dq[:-1, 2:] ** 2) / res.rate      # integral of theta'^T K_D theta'
    assert V[0] - V[-1] == pytest.approx(dissipated, rel=2e-2)
    assert np.allclose(res.q[-1], [0.7, -0.4, 0.7, -0.4], atol=1e-4)


def test_elastic_joint_online_gravity_compensation_reaches_the_same_equilibrium():
    robot = load_robot(FIXTURES / "elastic_2r.yaml")
    res = simulate(robot, "elastic_pd_online", reference="setpoint goal=0.5,0.3", q0=[0, 0, 0, 0], duration=25.0,
                   gains={"Kp": 400, "Kd": 40})
    const = simulate(robot, "elastic_pd", reference="setpoint goal=0.5,0.3", q0=[0, 0, 0, 0], duration=0.01)
    theta_d = [const.internals["theta_d_theta1"][0], const.internals["theta_d_theta2"][0]]
    assert np.allclose(res.q[-1], [0.5, 0.3] + theta_d, atol=1e-5)
    assert np.abs(res.tau[:, :2]).max() < 1e-12


# ---------------------------------------------------------------------- interaction control
def test_impedance_against_a_compliant_wall_settles_where_the_impedance_balances_the_force():
    """A set point 5 cm behind a wall (k = 5000 N/m): at rest K_m (p - p_d) = F."""
    robot = load_robot("planar_2r")
    q0 = np.array([0.3, 1.2])
    p0 = TaskPoint(robot, "ee").position(q0)
    wall = Surface("ee", normal=[-1, 0], offset=-(p0[0] + 0.02), stiffness=5000.0, damping=50.0)
    goal = p0 + np.array([0.07, 0.0])
    Km = np.array([400.0, 600.0])
    res = simulate(robot, "impedance", reference=f"setpoint goal={goal[0]},{goal[1]}", q0=q0, duration=4.0,
                   contacts=[wall], gains={"Km1": Km[0], "Km2": Km[1]})
    assert res.completed and res.reference_names == ["x", "y"]
    F = res.forces["ee"][-1]
    assert F[0] < -15                                          # the wall pushes back
    p = res.actual[-1]
    assert np.allclose(Km * (p - goal), F, atol=1e-3 * abs(F[0]))
    # and the measured force the controller used is the wall's force
    assert np.allclose(res.internals["F_x"][-1], F[0], rtol=1e-3)
    assert res.task_point == "ee" and np.allclose(res.ref_points[-1], [goal[0], goal[1], 0.0])
    assert np.allclose(res.actual_points[-1, :2], p)


def test_admittance_against_a_compliant_wall_bends_its_reference():
    robot = load_robot("planar_2r")
    q0 = np.array([0.3, 1.2])
    p0 = TaskPoint(robot, "ee").position(q0)
    wall = Surface("ee", normal=[-1, 0], offset=-(p0[0] + 0.02), stiffness=5000.0, damping=50.0)
    goal = p0 + np.array([0.07, 0.0])
    res = simulate(robot, "admittance", reference=f"setpoint goal={goal[0]},{goal[1]}", q0=q0, duration=4.0,
                   contacts=[wall], gains={"Km": 400})
    assert res.completed
    F = res.forces["ee"][-1]
    pr = np.array([res.internals["p_r_x"][-1], res.internals["p_r_y"][-1]])
    assert F[0] < -15
    assert np.allclose(400 * (pr - goal), F, atol=1e-2 * abs(F[0]))
    assert np.allclose(res.actual[-1], pr, atol=5e-3)          # up to the inner loop's stiffness


@pytest.mark.parametrize("mismatch", [None, {"m2": 5.0, "m1": 11.0}])
def test_hybrid_force_velocity_control_on_a_rigid_surface(mismatch):
    """Slide along a horizontal rigid surface pushing 15 N into it: with an exact model the contact
    force is f_d from the first sample on and the tangential error follows its linear dynamics
    (zero here); with a wrong model the integral force loop brings the force back to f_d."""
    robot = load_robot("planar_2r")
    q0 = np.array([-0.4, 1.6])
    floor = Surface("ee", normal=[0, 1])                        # through the initial point
    ee = TaskPoint(robot, "ee")
    p0 = ee.position(q0)
    res = simulate(robot, "hybrid", reference=f"quintic goal={p0[0] + 0.3} T=2", q0=q0, duration=3.0,
                   contacts=[floor], gains={"Fd": 15.0, "KF": 0.0 if mismatch is None else 20.0},
                   model_params=mismatch)
    assert res.completed and res.reference_names == ["s"]
    force = res.forces["ee"]                                   # on the robot, world frame
    ys = np.array([ee.position(q)[1] for q in res.q])
    assert np.max(np.abs(ys - p0[1])) < 1e-6                   # the point stays on the surface
    assert np.max(np.abs(force[:, 0])) < 1e-12                  # frictionless: normal force only
    sensed = res.internals["lambda"]
    assert sensed[0] > 40                                      # before control: the arm's weight
    if mismatch is None:
        assert np.max(np.abs(force[:, 1] - 15.0)) < 1e-4
        assert np.max(np.abs(res.e)) < 1e-3 and abs(res.e[-1, 0]) < 1e-5
        assert np.max(np.abs(sensed[1:] - 15.0)) < 1.0         # read just before each new torque
    else:
        assert abs(force[-1, 1] - 15.0) < 0.05
        assert np.max(np.abs(force[:, 1] - 15.0)) > 0.5        # the integral action had work to do
        assert np.abs(res.e[res.t > 2.5]).max() < 0.01


def test_robust_correction_reduces_the_tracking_error_under_mismatch():
    ref = "sine amplitude=0.6,0.8 f=0.5,0.35"
    mismatch = {"m2": 3.0, "I2": 0.15}
    ct = simulate("planar_2r", "computed_torque", reference=ref, q0=[0, 0], duration=6.0, model_params=mismatch)
    rb = simulate("planar_2r", "robust", reference=ref, q0=[0, 0], duration=6.0, model_params=mismatch,
                  gains={"rho": 30, "eps": 0.02})
    late = ct.t > 3.0
    assert np.abs(rb.e[late]).max() < np.abs(ct.e[late]).max() / 3


# ---------------------------------------------------------------------- gains and descriptions
def test_gain_errors_are_clear():
    with pytest.raises(GainError, match="unknown gain 'Kx'"):
        make_controller("pd", {"Kx": 1})
    with pytest.raises(GainError, match="Kd must be positive"):
        make_controller("pd", {"Kd": 0})
    with pytest.raises(GainError, match="Kp3: Kp has 2 entries"):
        simulate("planar_2r", "pd", gains={"Kp3": 10}, duration=0.01)
    with pytest.raises(GainError, match="expected name=value"):
        parse_gains("Kp 100")


def test_every_controller_documents_its_law_and_gains():
    for name, cls in CONTROLLERS.items():
        assert cls.law_latex and ("\\tau" in cls.law_latex or "u_a" in cls.law_latex), name
        assert cls.title and cls.closed_loop, name
        assert cls.gain_specs and all(g.doc for g in cls.gain_specs), name
