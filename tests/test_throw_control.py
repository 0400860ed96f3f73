"""Closed-loop throws in full dynamics (app/core/throw/closed_loop.py, app/core/throw/montecarlo.py):
every controller reproduces the plan on the exact plant, the transverse linearization matches finite
differences of the full model, and the Monte-Carlo study is seeded and vectorized."""
import json

import numpy as np
import pytest

from app.cli import main
from app.core.errors import UserError
from app.core.numeric import NumericModel
from app.core.throw.closed_loop import (CONTROLLERS, Controller, _linearizing_torque, _outputs, _theta_jacobian,
                                       simulate_closed_loop, state_of)
from app.core.throw.plants import Plant, load_plant, parse_plant
from app.core.throw.montecarlo import draw_plants, monte_carlo
from app.core.throw.arm import ThrowingArm
from app.core.throw.config import load_throw_config


@pytest.fixture(scope="module")
def planned():
    cfg = load_throw_config("optimized_thesis")
    arm = ThrowingArm(params=cfg.model)
    return arm.solve(cfg.spec)


@pytest.fixture(scope="module")
def transverse(planned):
    return Controller(planned, "transverse")


# Open loop has no feedback, so integration errors grow along the throw: it needs the smaller step.
@pytest.mark.parametrize("controller, step", [("open", 2.5e-4), ("vhc", 1e-3), ("transverse", 5e-4)])
def test_exact_plant_reproduces_the_planned_throw(planned, transverse, controller, step):
    ctl = transverse if controller == "transverse" else controller
    run = simulate_closed_loop(planned, ctl, Plant(), step=step)
    rel = planned.release
    assert run.released[0]
    assert run.release_speed[0] == pytest.approx(rel.speed, rel=1e-6)
    assert run.distance[0] == pytest.approx(rel.distance_from_base, rel=1e-6)
    assert run.theta_dot_e[0] == pytest.approx(planned.theta_dot_e, rel=1e-6)
    assert run.release_time[0] == pytest.approx(planned.duration, rel=1e-6)
    # the plan keeps every speed limit with the optimizer's 0.1 % margin: so does the exact plant
    assert np.all(run.max_speed_ratio[:, 0] < 1.0) and np.all(run.max_speed_ratio[:, 0] > 0.998)


def test_transverse_linearization_matches_finite_differences_of_the_full_model(planned, transverse):
    """Columns of A and B against central differences of the full 3-DOF model (NumericModel's forward
    dynamics under the feedback that imposes y'' = v), at five points of the orbit."""
    plan, lin = transverse.plan, transverse.linearization
    arm = planned.arm
    num = NumericModel(arm.robot, {**arm.values, "k": planned.spec.k})

    def transverse_rate(theta, xv):
        """(I', y'', y''') ... i.e. d/dt (I, y, y') of the full model at (theta, x_perp), input v."""
        I, y, yd, v = xv[0], xv[1:3], xv[3:5], xv[5:7]
        psi = plan.psi(np.array([theta]))[0]
        thd = np.sqrt(psi + I)
        q, dq, _ = state_of(plan, np.array([theta]), np.array([thd]), 0.0, y[:, None], yd[:, None], np.zeros((2, 1)))
        _th, _thd, _y, _yd, L, r = _outputs(plan, q, dq)
        tau = _linearizing_torque(plan, q, dq, v[:, None], L, r)[:, 0]
        ddq = num.forward_dynamics(q[:, 0], dq[:, 0], [tau[0], tau[1], 0.0])
        _t, J, Jdq = _theta_jacobian(arm, q, dq, planned.spec.psi)
        thdd = J[:, 0] @ ddq + Jdq[0]
        slope = np.interp(theta, plan.theta, plan.psi_slopes)
        ydd = L[0] @ ddq + r[:, 0]
        return np.concatenate([[2 * thd * thdd - slope * thd], yd, ydd])

    for j in (60, 140, 200, 300, 390):
        theta = lin.theta[j]
        AB = np.hstack([lin.A[j], lin.B[j]])
        fd = np.zeros((5, 7))
        for i in range(7):
            e = np.zeros(7)
            e[i] = 1e-6
            fd[:, i] = (transverse_rate(theta, e) - transverse_rate(theta, -e)) / 2e-6
        assert np.max(np.abs(fd - AB)) <= 1e-6 * np.max(np.abs(AB)), (j, fd - AB)


def test_heavier_plant_transverse_beats_open_loop(planned, transverse):
    """Masses +10 %, k -10 %, wrist friction, 1 ms control period, sensor noise (the shipped plant
    'heavier'): a small seeded Monte-Carlo; the transverse stabilizer's landing error is far smaller."""
    seed = 3
    study = monte_carlo(planned, load_plant("heavier"), ["open", "transverse"], plants=8, seed=seed)
    err = {c: study.summary(c)["landing_error"]["mean"] for c in ("open", "transverse")}
    assert np.all(study.results["open"].released), seed
    assert err["open"] > 0.2, (seed, err)                  # about 0.48 m short
    assert err["transverse"] < err["open"] / 5, (seed, err)   # the acceptance ratio (measured: > 100x)


def test_monte_carlo_is_seeded(planned):
    plant = load_plant("heavier")
    a, b = (draw_plants(planned, plant, 6, seed=5) for _ in range(2))
    assert np.array_equal(a.params, b.params) and np.array_equal(a.coulomb, b.coulomb)
    c = draw_plants(planned, plant, 6, seed=6)
    assert not np.array_equal(a.params, c.params)
    k = planned.arm.parameter_names.index("m3")
    factors = a.params[k] / (planned.arm.values["m3"] * 1.1)
    assert np.all(np.abs(factors - 1) <= 0.05 + 1e-12) and np.ptp(factors) > 0


@pytest.mark.parametrize("data, message", [
    ({"scale": {"m1": -1}}, "must be positive"),
    ({"scale": {"l1": 1.1}}, "unknown parameter 'l1'"),
    ({"wrist_friction": {"viscous": -0.1}}, "non-negative"),
    ({"sensor_noise": {"q": 0.001}}, "needs a control period"),
    ({"uncertainty": {"m1": 1.5}}, "in [0, 1)"),
    ({"uncertainty": {"coulomb": [0.3, 0.1]}}, "lo <= hi"),
    ({"colour": "red"}, "unknown keys"),
])
def test_bad_plant_files_are_refused(data, message):
    with pytest.raises(UserError, match=message.replace("(", r"\(").replace(")", r"\)").replace("[", r"\[")):
        parse_plant(data, "plant.yaml")


def test_cli_closed_loop_json(capsys):
    assert main(["throw", "throw1", "--closed-loop", "vhc", "--plant", "heavier", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["theta_dot_e"] == pytest.approx(3.7762, abs=1e-4)       # the throw's own fields are kept
    cl = out["closed_loop"]
    run = cl["runs"][0]
    assert run["controller"] == "vhc" and run["released"]
    assert run["landing_error"] == pytest.approx(run["distance_from_base"] - out["distance_from_base"], abs=1e-12)
    assert run["violation"] and max(run["max_speed_ratio"]) > 1   # throw one is over its q2 speed limit already
    assert cl["planned_distance_from_base"] == pytest.approx(out["distance_from_base"], rel=1e-12)


def test_cli_monte_carlo_summary(capsys, tmp_path):
    plant = tmp_path / "plant.yaml"
    plant.write_text("scale: {m3: 1.05}\ncontrol_period: 0.002\nuncertainty: {m3: 0.02}\n")
    assert main(["throw", "optimized_thesis", "--closed-loop", "open", "--plant", str(plant),
                 "--monte-carlo", "3", "--seed", "2", "--json"]) == 0
    mc = json.loads(capsys.readouterr().out)["closed_loop"]["monte_carlo"]
    s = mc["controllers"]["open"]
    assert mc["plants"] == 3 and mc["seed"] == 2
    q = s["distance"]["quantiles"]
    assert q["0.05"] <= q["0.5"] <= q["0.95"]
    assert s["distance"]["std"] > 0 and 0 <= s["violation_rate"] <= 1
    # a heavier wrist link throws shorter open loop
    assert s["distance"]["mean"] < 2.6866


def test_cli_bad_input_exits_2(capsys):
    assert main(["throw", "throw1", "--closed-loop", "vhc", "--plant", "no-such-plant"]) == 2
    assert "no plant file" in capsys.readouterr().err
    assert main(["throw", "throw1", "--monte-carlo", "5"]) == 2
    assert "need --closed-loop" in capsys.readouterr().err
