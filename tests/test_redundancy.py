"""Redundancy resolution: pseudoinverses, task priority, SNS against an independently solved QP."""
import numpy as np
import pytest
from scipy.optimize import linprog, minimize

from app.core.redundancy import (RedundancyError, acceleration_bounds, damped_pinv, max_task_scale, pinv, resolve,
                                 sns, task_priority, velocity_bounds, weighted_pinv)


def _random_instance(rng):
    m = int(rng.integers(1, 4))
    n = m + int(rng.integers(1, 4))
    J = rng.normal(size=(m, n))
    v = rng.normal(size=m) * rng.uniform(0.5, 4.0)
    return J, v, -rng.uniform(0.2, 2.0, size=n), rng.uniform(0.2, 2.0, size=n)


def _qp_reference(J, v, lo, hi):
    """Largest scale s <= 1 by LP, then the minimum-norm joint vector for s v by SLSQP."""
    m, n = J.shape
    c = np.zeros(n + 1)
    c[-1] = -1.0
    lp = linprog(c, A_eq=np.hstack([J, -v[:, None]]), b_eq=np.zeros(m), bounds=list(zip(lo, hi)) + [(0, 1)], method="highs")
    assert lp.status == 0
    s = lp.x[-1]
    qp = minimize(lambda x: x @ x, lp.x[:n], jac=lambda x: 2 * x, bounds=list(zip(lo, hi)), method="SLSQP",
                  constraints=[{"type": "eq", "fun": lambda x: J @ x - s * v, "jac": lambda x: J}],
                  options={"ftol": 1e-15, "maxiter": 1000})
    return s, qp.x


def test_sns_minimum_norm_equals_the_qp_on_200_random_instances():
    rng = np.random.default_rng(2024)
    scaled = 0
    for _ in range(200):
        J, v, lo, hi = _random_instance(rng)
        out = sns(J, v, lo, hi, minimum_norm=True)
        s_ref, x_ref = _qp_reference(J, v, lo, hi)
        scaled += s_ref < 1 - 1e-9
        assert abs(out.scale - s_ref) < 1e-7
        assert np.all(out.dq >= lo - 1e-9) and np.all(out.dq <= hi + 1e-9)
        assert np.allclose(J @ out.dq, out.scale * v, atol=1e-8)
        assert np.linalg.norm(out.dq - x_ref) < 1e-5
    assert 40 < scaled < 160          # both feasible and scaled tasks were exercised


def test_basic_sns_is_feasible_and_exact_when_no_scaling_is_needed():
    rng = np.random.default_rng(7)
    for _ in range(200):
        J, v, lo, hi = _random_instance(rng)
        out = sns(J, v, lo, hi)
        assert np.all(out.dq >= lo - 1e-9) and np.all(out.dq <= hi + 1e-9)
        assert np.allclose(J @ out.dq, out.scale * v, atol=1e-8)
        assert out.scale <= max_task_scale(J, v, lo, hi)[0] + 1e-9


def test_absolute_threshold_drops_round_off_singular_values():
    J = np.array([[1e-17, 0.0], [0.0, 1.0]])
    assert np.allclose(pinv(J), [[0, 0], [0, 1]])
    assert np.allclose(pinv(J, threshold=0.0)[0, 0], 1e17)


def test_weighted_pinv_identity_and_moore_penrose_properties():
    rng = np.random.default_rng(3)
    for rank_deficient in (False, True):
        J = rng.normal(size=(2, 4))
        if rank_deficient:
            J[1] = 2 * J[0]
        A = rng.normal(size=(4, 4))
        W = A @ A.T + 4 * np.eye(4)
        JW = weighted_pinv(J, W)
        assert np.allclose(J @ JW @ J, J) and np.allclose(JW @ J @ JW, JW)
        assert np.allclose((J @ JW).T, J @ JW) and np.allclose((W @ JW @ J).T, W @ JW @ J)
        if not rank_deficient:
            Wi = np.linalg.inv(W)
            assert np.allclose(JW, Wi @ J.T @ np.linalg.inv(J @ Wi @ J.T))


def test_damped_least_squares_tends_to_the_pseudoinverse():
    J = np.array([[1.0, 2.0, 0.5], [0.0, 1.0, 1.0]])
    assert np.allclose(damped_pinv(J, 1e-8), pinv(J), atol=1e-6)
    v = np.array([1.0, -1.0])
    assert np.linalg.norm(damped_pinv(J, 0.5) @ v) < np.linalg.norm(pinv(J) @ v)


def test_projected_gradient_keeps_the_task():
    J = np.array([[1.0, 1.0, 1.0]])
    r = resolve(J, [1.0], preferred=[1.0, 0.0, -2.0])
    assert np.allclose(J @ r.dq, [1.0]) and np.allclose(J @ r.dq_null, 0.0)


def test_task_priority_keeps_the_first_task_and_flags_algorithmic_singularities():
    J1 = np.array([[1.0, 0.0, 0.0]])
    J2 = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    tp = task_priority([(J1, [1.0]), (J2, [2.0, 3.0])])
    assert np.allclose(tp.dq, [1.0, 3.0, 0.0])
    assert not tp.levels[0].algorithmic_singularity and tp.levels[1].algorithmic_singularity


def test_bounds_from_joint_limits():
    lo, hi = velocity_bounds([0.0, 1.0], [-1, -1], [1, 1.05], [2, 2], 0.1)
    assert np.allclose(lo, [-2, -2]) and np.allclose(hi, [2, 0.5])
    lo, hi = acceleration_bounds([0.0], [0.0], [-1], [1], [1], [10], 0.1)
    assert np.allclose([lo[0], hi[0]], [-10, 10])


def test_bad_input_is_a_user_error():
    with pytest.raises(RedundancyError):
        sns([[1.0, 1.0]], [1.0], [0.5, -1], [1, 1])
    with pytest.raises(RedundancyError):
        weighted_pinv([[1.0, 1.0]], [[1.0, 0.0], [0.0, -1.0]])
