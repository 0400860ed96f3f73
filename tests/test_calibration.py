"""Calibration task kind on instances other than the exams: link lengths and encoder offsets of a
planar 2R recovered from exact measurements (nonlinear: Gauss-Newton), and the DH-twist regressor
equal to A0 (dA1/dalpha1) A2 (0; 1) (the formula of 2020-04-15-mid#Q2)."""
import numpy as np
import sympy as sp

from app.core.exercise import parse_exercise, solve
from app.core.expressions import symbol

SEED = 11


def test_lengths_and_offsets_of_a_2r_are_recovered():
    rng = np.random.default_rng(SEED)
    l1, l2, o1, o2 = 1.0 + 0.05 * rng.normal(), 0.8 + 0.05 * rng.normal(), 0.02 * rng.normal(), 0.02 * rng.normal()
    exps = []
    for _ in range(6):
        q = rng.uniform(-2.5, 2.5, size=2)
        a, b = q[0] + o1, q[0] + o1 + q[1] + o2
        exps.append({"q": q.tolist(), "p": [l1 * np.cos(a) + l2 * np.cos(b), l1 * np.sin(a) + l2 * np.sin(b)]})
    ans = solve(parse_exercise({"id": "t", "robot": "planar_2r", "question": "?", "given": {"l1": 1, "l2": 0.8},
                                "tasks": [{"kind": "calibration", "parameters": ["l1", "l2"], "offsets": ["q1", "q2"],
                                           "experiments": exps}]})).answers
    assert not ans["linear"]
    np.testing.assert_allclose(ans["estimate"], [l1, l2, o1, o2], atol=1e-9, err_msg=f"seed {SEED}")
    assert ans["residual"] < 1e-9


def test_twist_regressor_is_the_product_with_the_transform_derivative():
    ans = solve(parse_exercise({"id": "t", "robot": "dh_twist_rr", "question": "?", "tasks": [
        {"kind": "calibration", "transform": {"body": "link1", "parameter": "alpha1"},
         "parameters": ["alpha1"], "components": ["x", "y", "z"]}]})).answers
    q2, a2 = symbol("q2"), symbol("a2")
    A2 = sp.Matrix([[sp.cos(q2), -sp.sin(q2), 0, a2 * sp.cos(q2)], [sp.sin(q2), sp.cos(q2), 0, a2 * sp.sin(q2)],
                    [0, 0, 1, 0], [0, 0, 0, 1]])
    phi = (ans["dA_nominal"] * A2 * sp.Matrix([0, 0, 0, 1]))[:3, 0]
    assert sp.simplify(phi - ans["Phi_nominal"]) == sp.zeros(3, 1)
