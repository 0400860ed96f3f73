"""A model whose c(q, q') would be too long written out (more than ``LONG_ENTRY`` terms in an entry)
keeps C and c through the Christoffel matrices, its intermediate variables: the same values as the
written-out form, pinocchio agrees, M' - 2C stays skew-symmetric, and the steps say what was kept."""
import numpy as np

from app.core import dynamics
from app.core.dynamics import derive
from app.core.numeric import NumericModel
from app.core.numeric.twin import cross_check
from app.core.robot import load_robot
from app.core.trig import equal


def test_a_long_model_keeps_c_and_C_through_the_christoffel_matrices(monkeypatch):
    robot = load_robot("planar_3r")
    written_out = derive(robot, use_cache=False)
    monkeypatch.setattr(dynamics, "LONG_ENTRY", 5)        # planar 3R's c has up to 25 terms an entry
    kept = derive(robot, use_cache=False)

    assert kept.c != written_out.c                         # another form ...
    assert all(equal(a, b) for a, b in zip(kept.c, written_out.c))       # ... of the same values
    assert all(equal(a, b) for a, b in zip(kept.C, written_out.C))
    assert kept.M == written_out.M and kept.g == written_out.g
    assert kept.parametrization.Y == written_out.parametrization.Y

    steps = {s.title: s for s in kept.steps}
    assert r"\dot q^T C_i(q)\, \dot q" in steps["Coriolis and centrifugal terms"].latex
    assert "intermediate variables" in steps["Coriolis and centrifugal terms"].text
    assert r"\sum_{k=1}^{3}" in steps[r"Factorization $c = C(q, \dot q)\, \dot q$"].latex
    equations = steps["Equations of motion"]
    assert r"\ddot{q}_{1}" not in equations.latex and "more than" in equations.text
    assert r"\ddot{q}_{1}" in {s.title: s for s in written_out.steps}["Equations of motion"].latex

    check = cross_check(robot, dynamics=kept)
    assert max(check.max_rel_error.values()) < 1e-9, check

    num = NumericModel(robot, dynamics=kept)
    rng = np.random.default_rng(3)
    for _ in range(3):
        q, dq = rng.normal(size=3), rng.normal(size=3)
        h = 1e-6
        M_dot = (num.M(q + h * dq) - num.M(q - h * dq)) / (2 * h)
        N = M_dot - 2 * num.C(q, dq)
        assert np.abs(N + N.T).max() < 1e-6, "seed 3"
