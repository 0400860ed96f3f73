"""Numeric Newton-Euler (app/core/newton_euler.py) against pinocchio and the symbolic Jacobians."""
from pathlib import Path

import numpy as np
import pytest

from app.core import jacobians as jac
from app.core.newton_euler import NewtonEuler, NewtonEulerError, Wrench
from app.core.numeric import PinocchioTwin, random_state
from app.core.robot import load_robot

SEED = 5
SIXR = Path(__file__).parent / "fixtures" / "sixr_arm.yaml"


@pytest.mark.parametrize("name", [str(SIXR), "spatial_3r_2017_03_29", "kin_scara", "rp_2004_03_25"])
def test_inverse_dynamics_with_a_tip_wrench_equals_pinocchio(name):
    """u = M q'' + c + g + J^T F_e at random states and wrenches (the 6R has no symbolic model)."""
    robot = load_robot(name)
    ne = NewtonEuler(robot)
    twin = PinocchioTwin(robot, robot.parameter_values())
    rng = np.random.default_rng(SEED)
    body = robot.bodies[-1].name
    for trial in range(10):
        q, dq = random_state(robot, rng)
        ddq = rng.normal(size=robot.n)
        local, force, moment = rng.normal(size=3) * 0.1, rng.normal(size=3) * 10, rng.normal(size=3)
        u = ne.inverse_dynamics(q, dq, ddq, wrenches=[Wrench(body, local, force, moment)])
        M, c, g = twin.terms(q, dq)
        J = ne.geometric_jacobian(q, body, local)
        ref = M @ ddq + c + g + J.T @ np.concatenate([force, moment])
        assert np.max(np.abs(u - ref)) < 1e-9 * max(1.0, np.max(np.abs(ref))), f"seed {SEED}, trial {trial}"


def test_numeric_jacobian_equals_the_symbolic_one():
    robot = load_robot("spatial_3r_2017_03_29")
    ne = NewtonEuler(robot)
    rng = np.random.default_rng(SEED)
    body = robot.bodies[-1].name
    J_sym = jac.geometric_jacobian(robot, body, (0.1, 0.2, -0.05))
    for trial in range(5):
        q, _ = random_state(robot, rng)
        J_num = ne.geometric_jacobian(q, body, (0.1, 0.2, -0.05))
        assert np.allclose(J_num, jac.evaluate(robot, J_sym, q), atol=1e-12), f"seed {SEED}, trial {trial}"


def test_free_space_without_gravity_at_rest_gives_zero():
    robot = load_robot(str(SIXR))
    u = NewtonEuler(robot).inverse_dynamics([0.3, -0.5, 0.8, 0.2, 0.6, -0.4], np.zeros(6), np.zeros(6), gravity=False)
    assert np.max(np.abs(u)) < 1e-12


def test_bad_sizes_and_bodies_are_refused():
    ne = NewtonEuler(load_robot("planar_2r"))
    with pytest.raises(NewtonEulerError):
        ne.inverse_dynamics([0.0], [0.0], [0.0])
    with pytest.raises(NewtonEulerError):
        ne.geometric_jacobian([0.0, 0.0], "nobody")
