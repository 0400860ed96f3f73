"""Options of the factorizations, coordinate_map and desired_torque task kinds, on robots other than
the exams they came from: S' = S + S0 with S0 the cross-product matrix of q' (2019-04-29-mid#4 b)
keeps M' - 2S' skew on a 3-dof PPR; the column rule 'first' factorizes c; a forward map given by a
point and a link angle is inverted; a cubic rest-to-rest motion starts with q'' = 6 delta / T^2."""
import numpy as np
import sympy as sp

from app.core.exercise import parse_exercise, solve
from app.core.expressions import symbol


def _solve(robot, tasks, given=None):
    return solve(parse_exercise({"id": "t", "robot": robot, "question": "?", "tasks": tasks,
                                 "given": given or {}}))


def test_adding_the_cross_product_matrix_keeps_skew_symmetry_on_a_3dof_robot():
    skew = [[0, "-dq3", "dq2"], ["dq3", 0, "-dq1"], ["-dq2", "dq1", 0]]
    ans = _solve("ppr_2020_04_15", [{"kind": "factorizations", "plus": skew}]).answers
    assert ans["skew_S"] and ans["skew_S_alt"]
    assert ans["S_alt"] != ans["S"]
    dq = sp.Matrix([symbol(f"dq{i}") for i in (1, 2, 3)])
    assert sp.simplify(ans["S_alt"] * dq - ans["S"] * dq) == sp.zeros(3, 1)


def test_first_column_rule_factorizes_c_and_is_not_skew_on_a_2r():
    ans = _solve("planar_2r", [{"kind": "dynamics"}, {"kind": "factorizations", "alternative": "first"}]).answers
    dq = sp.Matrix([symbol("dq1"), symbol("dq2")])
    assert sp.simplify(ans["S_alt"] * dq - ans["c"]) == sp.zeros(2, 1)
    assert ans["skew_S"] and not ans["skew_S_alt"]


def test_forward_map_is_inverted_and_keeps_the_kinetic_energy():
    # a map that loses a coordinate cannot be inverted: a clear refusal
    from app.core.exercise import ExerciseError
    import pytest
    with pytest.raises(ExerciseError, match="cannot invert"):
        _solve("planar_pr", [{"kind": "coordinate_map", "forward": {"s": "q1 + q2", "t": "2*q1 + 2*q2"}}])
    ans = _solve("planar_pr", [{"kind": "coordinate_map", "forward": {"s": "q1 + q2", "phi": "q2"}}]).answers
    s, phi = symbol("s"), symbol("phi")
    assert ans["q_of_new"] == sp.Matrix([s - phi, phi])
    # the kinetic energy is the same in both sets of coordinates
    rng = np.random.default_rng(7)
    M_q = _solve("planar_pr", [{"kind": "dynamics"}]).answers["M"]
    for _ in range(3):
        q2, dq1, dq2 = rng.normal(size=3)
        dq = sp.Matrix([dq1, dq2])
        dp = sp.Matrix([dq1 + dq2, dq2])
        nums = {p.symbol: p.value for p in __import__("app.core.robot", fromlist=["load_robot"]).load_robot("planar_pr").parameters.values()}
        T_q = (dq.T * M_q.subs(symbol("q2"), q2) * dq)[0].subs(nums)
        T_p = (dp.T * ans["M_new"].subs(phi, q2) * dp)[0].subs(nums)
        assert abs(float(T_q - T_p)) < 1e-9, "seed 7"


def test_cubic_rest_to_rest_starts_with_six_delta_over_t_squared():
    ans = _solve("planar_pr", [{"kind": "desired_torque", "at": 0, "trajectory": {
        "q1": {"start": 0.3, "delta": 0.9, "duration": 1.5, "profile": "cubic"},
        "q2": {"start": 0, "delta": -0.6, "duration": 1.5, "profile": "quintic"}}}]).answers
    np.testing.assert_allclose(ans["ddq_d_at"], [6 * 0.9 / 1.5 ** 2, 0], atol=1e-12)
    np.testing.assert_allclose(ans["dq_d_at"], [0, 0], atol=1e-12)
