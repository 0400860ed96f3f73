"""Interaction matrices (app/core/visual_servoing.py) against the motion of projected points."""
import numpy as np
import sympy as sp

from app.core import visual_servoing as vs

SEED = 3


def test_interaction_matrix_predicts_the_feature_velocity_of_random_points():
    """f' = J_p (V, W) for a fixed point moving as P' = -V - W x P in the camera frame."""
    rng = np.random.default_rng(SEED)
    for trial in range(50):
        lam = rng.uniform(0.5, 2.0)
        P = np.column_stack([rng.uniform(-1, 1, 3), rng.uniform(-1, 1, 3), rng.uniform(0.5, 3.0, 3)])
        V, W = rng.normal(size=3), rng.normal(size=3)
        Pdot = -V - np.cross(W, P)
        h = 1e-6
        f_plus = vs.project(P + h * Pdot, lam)[:, :2].reshape(-1)
        f_minus = vs.project(P - h * Pdot, lam)[:, :2].reshape(-1)
        J = vs.numeric_interaction_matrix(vs.project(P, lam), lam)
        assert np.allclose(J @ np.concatenate([V, W]), (f_plus - f_minus) / (2 * h), atol=1e-6), f"seed {SEED}, trial {trial}"


def test_symbolic_null_bases_are_null_and_complete():
    lam = sp.Symbol("lam", positive=True)
    rng = np.random.default_rng(SEED)
    for n_points, combine, dim in ((1, "stack", 4), (3, "mean", 4)):
        pts = [sp.symbols(f"u{i} v{i} Z{i}", positive=True) for i in range(n_points)]
        J = vs.interaction_matrix(pts, lam, combine)
        basis = vs.null_basis(J)
        assert len(basis) == dim
        values = {s: sp.Float(rng.uniform(0.3, 2.0)) for s in J.free_symbols}
        for b in basis:
            assert max(abs(float(x)) for x in (J * b).xreplace(values)) < 1e-12
