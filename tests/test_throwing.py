"""The throwing arm (issue 5): thesis numbers that can be reproduced, the reference model B, three
independent computations of theta_dot(theta), infeasible throws, the optimizer verified in full
dynamics, and the `throw` command line. Reference values: shared/catalog/thesis-notes.md."""
import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from app.core.ballistics import angle_table, best_angle
from app.core.errors import UserError
from app.core.numeric import NumericModel, cross_check
from app.core.robot import load_robot
from app.core.throw.arm import ThrowingArm
from app.core.throw.config import ThrowSpec, VHCError, load_throw_config, parse_throw_config, thesis_throw
from app.core.throw.optimize import ThrowOptimizer, speed_limit_bound
from app.core.throw.portrait import phase_portrait
from app.core.throw.simulation import simulate_full
from app.core.throw.thesis import TABLE_3_1, hand_estimate, thesis_comparison

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def arm():
    return ThrowingArm()


@pytest.fixture(scope="module")
def throws(arm):
    return {name: arm.solve(thesis_throw(name)) for name in ("throw1", "throw2")}


def cli(*args):
    return subprocess.run([sys.executable, "-m", "app", "throw", *args], cwd=ROOT, capture_output=True,
                          text=True, timeout=300)


# ---------------------------------------------------------------- model
def test_robot_file_is_appendix_a_reading_b():
    robot = load_robot("throwing_arm")
    v = robot.parameter_values()
    assert (v["c1"], v["c2"], v["c3"]) == pytest.approx((0.198, 0.1561, 0.10649), abs=1e-12)
    assert (v["d1"], v["d2"], v["d3"]) == pytest.approx((0.0, 0.0, 0.0), abs=1e-12)
    assert v["J3"] == pytest.approx(0.06355 - 4.5131 * 0.10649 ** 2, abs=1e-12)
    assert v["J1"] == pytest.approx(0.2743713 - 4.60714 * 0.198 ** 2, abs=1e-12)
    assert robot.actuated == (True, True, False)
    assert robot.limits["q1"].position == pytest.approx((-math.pi / 6, 7 * math.pi / 6))
    assert [robot.limits[q].velocity for q in ("q1", "q2", "q3")] == pytest.approx(
        [11 * math.pi / 18, 32 * math.pi / 45, 46 * math.pi / 45])
    assert (robot.limits["q1"].torque, robot.limits["q2"].torque) == (176, 100)
    # the ball is l1, l2, l3 from the shoulder, which is platform + l0 above the ground
    num = NumericModel(robot)
    pos, _ = num.named_point("ball")
    assert pos([math.pi / 2, 0.0, 0.0])[:2] == pytest.approx([0.0, 0.63 + 0.3105 + 0.4 + 0.39728 + 0.24])


def test_in_plane_com_offsets_match_pinocchio():
    robot = load_robot("throwing_arm")
    result = cross_check(robot, {"d1": -0.02522, "d2": 0.0222, "d3": 0.01109, "J3": 0.01085}, states=30)
    assert result.ok, result.summary()


@pytest.mark.parametrize("reading, overrides, expected", [
    # thesis-notes section 2: (theta_dot_e, T) of pitches one and two for each reading of Appendix A
    ("A", {"J3": 0.06355}, [(3.3115, 0.3253), (4.3852, 0.3358)]),
    ("E", {"d3": 0.01109, "J3": 0.01085}, [(3.8564, 0.2780), (5.4030, 0.2847)]),
    ("F", {"d3": -0.01109, "J3": 0.01085}, [(3.7388, 0.2922), (4.6522, 0.3215)]),
    ("G", {"c3": 0.24 - 0.10649, "J3": 0.06355}, [(2.5368, 0.4078), (3.2647, 0.4213)]),
])
def test_other_readings_of_appendix_a(reading, overrides, expected):
    arm = ThrowingArm(params=overrides)
    got = [arm.solve(thesis_throw(n)) for n in ("throw1", "throw2")]
    assert [(t.theta_dot_e, t.duration) for t in got] == [pytest.approx(e, abs=5e-5) for e in expected], reading


# ---------------------------------------------------------------- kinematics and ballistics (hard)
def test_table_3_1_is_for_4_not_5_metres_per_second():
    printed = list(TABLE_3_1.values())
    at4 = angle_table(4.0, 30.0, list(TABLE_3_1))
    assert at4 == pytest.approx(printed, abs=2e-4)
    assert angle_table(5.0, 30.0, [45])[0] == pytest.approx(10.1103, abs=1e-4)    # not 7.8578
    angle, dist = best_angle(4.0, 30.0)
    assert (math.degrees(angle), dist) == pytest.approx((9.24, 10.026), abs=1e-2)
    notes = [r["note"] for r in thesis_comparison() if r["quantity"].startswith("Table 3.1")]
    assert len(notes) == 8 and all("4 m/s" in n and "5 m/s" in n for n in notes)


def test_hand_estimate(arm):
    est = hand_estimate(arm)
    assert est.speed == pytest.approx(4.1859, abs=5e-5)
    assert hand_estimate(arm, speed=4.18).distance_from_base == pytest.approx(2.756, abs=5e-4)
    assert est.best_angle_deg == pytest.approx(14.5, abs=0.05)


def test_thesis_distances_from_its_release_speeds(arm):
    one = arm.release(thesis_throw("throw1"), 3.954)
    assert (one.distance_from_base_thesis, one.distance_from_release_thesis) == pytest.approx((2.9527, 2.9052), abs=1e-4)
    two = arm.release(thesis_throw("throw2"), 4.057)
    assert two.position[0] == pytest.approx(-0.36506, abs=1e-5)
    assert (two.distance_from_base_thesis, two.distance_from_release_thesis) == pytest.approx((2.6130, 2.9780), abs=1e-4)
    # with the true ball velocity J(q) q' the same speeds throw differently (thesis-notes section 4)
    assert one.distance_from_base == pytest.approx(2.716, abs=1e-3)
    assert two.distance_from_base == pytest.approx(2.748, abs=1e-3)
    assert one.speed / 3.954 == pytest.approx(1.0478, abs=1e-4)


def test_pitch_one_joint_speeds_sit_at_their_limits_with_the_thesis_speed(arm):
    rel = arm.release(thesis_throw("throw1"), 3.954)
    ratios = np.abs(rel.dq) / arm.limits["speed"]
    assert np.all(np.abs(ratios - 1.0) < 0.005), ratios
    assert ratios == pytest.approx([1.0025, 0.9952, 0.9977], abs=1e-4)


# ---------------------------------------------------------------- reduced dynamics (model B)
def test_reference_model_b(throws):
    assert throws["throw1"].theta_dot_e == pytest.approx(3.7762, abs=5e-5)
    assert throws["throw1"].duration == pytest.approx(0.2863, abs=5e-5)
    assert throws["throw2"].theta_dot_e == pytest.approx(4.9680, abs=5e-5)
    assert throws["throw2"].duration == pytest.approx(0.3040, abs=5e-5)


def test_limits_along_the_printed_throws(throws):
    one, two = throws["throw1"].check(), throws["throw2"].check()
    assert one.max_speed_ratio == pytest.approx([0.97, 1.06, 1.01], abs=0.006)
    assert one.max_torque == pytest.approx([133, 73], abs=1)
    assert not one.feasible and any("q2" in v for v in one.violations)
    assert two.max_speed_ratio == pytest.approx([1.34, 1.22, 1.93], abs=0.006)
    assert two.max_torque == pytest.approx([189, 89], abs=1)
    assert any("torque of q1" in v for v in two.violations)


@pytest.mark.parametrize("name", ["throw1", "throw2"])
def test_closed_form_ode_and_full_simulation_agree(arm, throws, name):
    throw = throws[name]
    ode = arm.reduced_ode(throw.spec)
    assert ode.theta_dot_e == pytest.approx(throw.theta_dot_e, rel=1e-9)
    assert ode.duration == pytest.approx(throw.duration, rel=1e-9)
    inside = ode.theta <= throw.spec.theta_e
    err = np.max(np.abs(throw.theta_dot(ode.theta[inside]) - ode.theta_dot[inside])) / throw.theta_dot_e
    assert err < 1e-6
    t = np.linspace(0.0, throw.duration, 40)
    assert np.max(np.abs(throw.theta_at(t) - ode.dense(t)[0])) < 1e-8
    for controller in ("feedforward", "computed_torque"):
        sim = simulate_full(throw, controller)
        assert sim.max_theta_dot_error < 1e-6, controller
        assert sim.release.theta_dot == pytest.approx(throw.theta_dot_e, rel=1e-6)
        assert sim.duration == pytest.approx(throw.duration, rel=1e-6)
        assert sim.max_wrist_drift < 1e-6 and sim.max_ball_drift < 1e-6


def test_joint_motion_and_torques_along_the_throw(arm, throws):
    throw = throws["throw1"]
    tr = throw.sample(50)
    assert tr.t[0] == 0 and tr.t[-1] == pytest.approx(throw.duration, rel=1e-12)     # t[0] is set to 0
    assert tr.q[:, 0] == pytest.approx([1.732, 0.666, 0.6283], abs=1e-4)
    assert tr.theta_dot[-1] == pytest.approx(throw.theta_dot_e, rel=1e-9)
    # the torques make M q'' + c + g + k q3 = [tau1, tau2, 0] hold along the throw
    num = NumericModel(arm.robot, {"k": throw.spec.k})
    for j in (0, 17, 49):
        lhs = num.inverse_dynamics(tr.q[:, j], tr.dq[:, j], tr.ddq[:, j])
        assert lhs == pytest.approx([tr.tau[0, j], tr.tau[1, j], 0.0], abs=1e-8)
    # the ball follows eq. (3.12): theta = projection of the ball on the psi axis through the shoulder
    psi = throw.spec.psi
    shoulder = np.array([0.0, 0.63 + 0.3105])
    proj = (tr.ball.T - shoulder) @ np.array([math.cos(psi), math.sin(psi)])
    assert proj == pytest.approx(tr.theta, abs=1e-12)


# ---------------------------------------------------------------- infeasible throws
def test_pitch_three_is_rejected(arm):
    with pytest.raises(VHCError, match=r"cannot be reached for s between about 0\.0\d+ and 0\.0[89]\d+") as exc:
        arm.solve(thesis_throw("throw3"))
    assert "2.7 mm beyond the reach of link 3" in str(exc.value)


def test_alpha_crossing_zero_is_an_error(arm):
    spec = ThrowSpec(-0.48537, 0.06252, math.radians(8.757), 74.264,
                     (1.60611, 1.47953, 1.44482, 1.37837, 1.34519, 1.30167, 1.26298),
                     (0.94757, 0.88582, 0.90012, 0.75455, 0.69471, 0.56522, 0.45912))
    st = arm.constraint(spec, np.linspace(spec.theta_b, spec.theta_e, 2001))
    assert np.any(np.sign(st.alpha[2, 0]) != np.sign(st.alpha[2, 0, 0]))     # it really does cross zero
    with pytest.raises(VHCError, match="alpha .* changes sign"):
        arm.solve(spec)


def test_a_throw_without_spring_cannot_start(arm):
    with pytest.raises(VHCError, match="cannot start"):
        arm.solve(ThrowSpec(**{**thesis_throw("throw1").__dict__, "k": 0.0}))


def test_bad_throw_parameters():
    with pytest.raises(UserError, match="theta_e"):
        ThrowSpec(0.3, 0.1, 0.3, 20.0, (1.0, 1.1), (0.1, 0.2))
    with pytest.raises(UserError, match="unknown key"):
        parse_throw_config({**thesis_throw("throw1").to_config(), "kk": 1})
    with pytest.raises(UserError, match="model.link4"):
        parse_throw_config({**thesis_throw("throw1").to_config(), "model": {"link4": {"m": 1}}})
    with pytest.raises(UserError, match="must not be negative"):
        ThrowingArm(params={"m3": -1.0})


# ---------------------------------------------------------------- phase portraits and equilibria
def test_equilibria_are_centres_or_saddles(arm):
    spec = thesis_throw("throw3")      # unreachable inside its own interval, rich phase plane around it
    pp = phase_portrait(arm, spec, (-0.3, 0.3), initial=[])
    kinds = sorted(e.kind for e in pp.equilibria)
    assert kinds == ["center", "saddle", "saddle"]
    for eq in pp.equilibria:
        st = arm.constraint(spec, [eq.theta])
        assert abs(st.gamma[2, 0, 0]) < 1e-9
        # the phase curve through the equilibrium itself: an isolated point (centre) or two
        # crossing separatrices (saddle), from the first integral (3.24)
        h = 2e-4
        curve = phase_portrait(arm, spec, (eq.theta - h, eq.theta + h), initial=[(eq.theta, 0.0)], n=401).curves[0]
        ends = curve.theta_dot[[50, -50]]
        if eq.kind == "center":
            assert eq.omega > 0 and np.all(np.isnan(ends))
        else:
            assert eq.omega < 0 and np.all(ends > 0)
            assert ends == pytest.approx(np.sqrt(-eq.omega) * np.abs(curve.theta[[50, -50]] - eq.theta), rel=0.02)


def test_phase_portrait_contains_the_throw(arm, throws):
    throw = throws["throw1"]
    pp = phase_portrait(arm, throw.spec)
    own = pp.curves[-1]
    assert (own.theta0, own.theta_dot0) == pytest.approx((throw.spec.theta_b, 0.0), abs=1e-12)
    assert own.theta_dot[-1] == pytest.approx(throw.theta_dot_e, rel=1e-6)


# ---------------------------------------------------------------- optimizer
def test_speed_limit_bounds(arm):
    assert speed_limit_bound(arm, "physical").distance_from_base == pytest.approx(2.8117, abs=2e-4)
    assert speed_limit_bound(arm, "thesis").distance_from_base == pytest.approx(2.9690, abs=2e-4)


def test_optimizer_beats_the_thesis_under_every_limit_in_full_dynamics(arm):
    # the default budget counts throw evaluations: the same throw on a fast or a slow (or busy) machine
    res = ThrowOptimizer(arm).run(seed=0)
    assert res.distance_from_base >= 2.95
    assert res.evaluations <= res.evaluation_budget + 2000 and not res.time_capped
    assert res.distance_from_base <= res.bound.distance_from_base
    assert res.feasibility.feasible, res.feasibility.violations
    assert min(res.throw.sample(400).q[0]) >= math.pi / 6      # eq. (4.5)
    lim = arm.limits
    for controller in ("feedforward", "computed_torque"):
        sim = simulate_full(res.throw, controller)
        assert sim.release.distance_from_base_thesis >= 2.95
        assert sim.max_wrist_drift < 1e-6 and sim.max_ball_drift < 1e-6
        assert np.all(np.max(np.abs(sim.dq), axis=1) <= lim["speed"] * (1 + 1e-6))
        assert np.all(np.max(np.abs(sim.tau), axis=1) <= lim["torque"] * (1 + 1e-6))
        assert np.all(sim.q.min(axis=1) >= lim["lower"]) and np.all(sim.q.max(axis=1) <= lim["upper"])


# ---------------------------------------------------------------- command line
def test_cli_throw_json():
    proc = cli("throw1", "--json")
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout)
    for key in ("theta_dot_e", "duration", "release_position", "release_velocity", "distance_from_base",
                "distance_from_release", "distance_from_base_thesis", "distance_from_release_thesis",
                "feasible", "violations", "max_speed_ratio", "max_torque"):
        assert key in out
    assert out["theta_dot_e"] == pytest.approx(3.7762, abs=5e-5) and out["duration"] == pytest.approx(0.2863, abs=5e-5)
    assert out["release_position"] == pytest.approx([0.04747, 1.33184 + 0.63], abs=1e-5)
    assert len(out["max_speed_ratio"]) == 3 and len(out["max_torque"]) == 2
    assert out["feasible"] is False and out["violations"]


def test_cli_model_overrides_and_errors(tmp_path):
    cfg = {**thesis_throw("throw1").to_config(), "model": {"link3": {"J": 0.06355}, "platform": 0.63}}
    path = tmp_path / "a.json"
    path.write_text(json.dumps(cfg))
    out = json.loads(cli(str(path), "--json").stdout)
    assert out["theta_dot_e"] == pytest.approx(3.3115, abs=5e-5)                  # reading A
    assert out["duration"] == pytest.approx(0.3253, abs=5e-5)
    proc = cli("throw3", "--json")
    assert proc.returncode == 2 and "cannot be reached" in proc.stderr and not proc.stdout
    bad = tmp_path / "bad.yaml"
    bad.write_text("theta_b: -0.3\ntheta_e: 0.3\npsi_deg: 20\nk: 20\na: [1.7]\nb: [0.5, 0.4]\n")
    proc = cli(str(bad))
    assert proc.returncode == 2 and "a: expected a list of at least two" in proc.stderr
    assert cli("no_such_throw").returncode == 2


def test_shipped_throws_are_the_thesis_tables():
    one = load_throw_config("throw1")
    assert one.spec.a[0] == pytest.approx(1.732, abs=1e-12) and one.spec.degree == (6, 6)
    assert one.thesis["theta_dot_e"] == pytest.approx(3.954, abs=1e-12)
    assert load_throw_config("throw3").spec.psi_deg == pytest.approx(23.640)


def test_shipped_optimized_throws_are_feasible(arm):
    best = arm.solve(load_throw_config("optimized_thesis").spec)
    assert best.check(q1_min=math.pi / 6).feasible
    assert best.release.distance_from_base_thesis == pytest.approx(2.9656, abs=1e-4)
    phys = arm.solve(load_throw_config("optimized_physical").spec)
    assert phys.check(q1_min=math.pi / 6).feasible
    assert phys.release.distance_from_base == pytest.approx(2.8082, abs=1e-4)
    assert phys.release.distance_from_base <= speed_limit_bound(arm, "physical").distance_from_base


SMALL_ALPHA = ThrowSpec(-0.29345, 0.62183, math.radians(24.13967), 9.93597,
                        (1.53677, 1.35858, 1.1698, 0.95481, 0.92204, 0.96733, 1.25785),
                        (1.07507, 0.95095, 1.05324, 1.04583, 0.8813, 0.68384, 0.04293))


@pytest.mark.parametrize("spec", [
    SMALL_ALPHA,                                                        # |alpha| dips to 2 % of its median
    ThrowSpec(**{**thesis_throw("throw1").__dict__, "theta_dot_b": 1e-3}),   # almost from rest
    ThrowSpec(**{**thesis_throw("throw1").__dict__, "theta_dot_b": 0.5}),
], ids=["small-alpha", "theta_dot_b=1e-3", "theta_dot_b=0.5"])
def test_closed_form_where_it_is_delicate(arm, spec):
    a = np.abs(arm.constraint(spec, np.linspace(spec.theta_b, spec.theta_e, 4001)).alpha[2, 0])
    if spec is SMALL_ALPHA:
        assert a.min() < 0.03 * np.median(a)
    throw = arm.solve(spec)
    ode = arm.reduced_ode(spec)
    assert throw.theta_dot_e == pytest.approx(ode.theta_dot_e, rel=1e-9)
    assert throw.duration == pytest.approx(ode.duration, rel=1e-9)
    inside = ode.theta <= spec.theta_e
    assert np.max(np.abs(throw.theta_dot(ode.theta[inside]) - ode.theta_dot[inside])) < 1e-6 * throw.theta_dot_e


def test_optimizer_budget_is_counted_in_evaluations_not_seconds(arm):
    """Same seed, same throw, bit for bit, whatever the machine's load (here: a second run while another
    process keeps a core busy); the evaluation count stays within the budget."""
    bound = speed_limit_bound(arm, "thesis", seed=3)

    def run():
        return ThrowOptimizer(arm).run(seed=3, evaluations=1000, candidates=200, starts=1, bound=bound)

    quiet = run()
    busy = subprocess.Popen([sys.executable, "-c", "while True: pass"])
    try:
        loaded = run()
    finally:
        busy.kill()
        busy.wait()
    assert np.array_equal(ThrowOptimizer(arm).to_vector(quiet.spec), ThrowOptimizer(arm).to_vector(loaded.spec))
    assert quiet.evaluations == loaded.evaluations
    assert quiet.evaluations <= 1000 + 2000 and not quiet.time_capped
    assert quiet.evaluation_history == loaded.evaluation_history
    # a budget smaller than the global stage's pool cuts the pool (here too small to find a throw)
    small = ThrowOptimizer(arm)
    with pytest.raises(VHCError, match="raise the budget"):
        small.run(seed=3, evaluations=150, candidates=200, starts=1, bound=bound)
    assert small.evaluations == 150
