"""Linear closed loops (app/core/linear_control.py) against independent numeric computations."""
import numpy as np
import pytest
import sympy as sp

from app.core import linear_control as lc
from app.core.expressions import symbol

SEED = 11


def test_routh_column_agrees_with_the_roots_on_random_polynomials():
    rng = np.random.default_rng(SEED)
    for trial in range(40):
        degree = int(rng.integers(2, 6))
        coeffs = [1.0] + list(rng.uniform(-0.5, 3.0, degree))
        poly = sp.Poly(sum(sp.Float(c) * lc.s ** (degree - i) for i, c in enumerate(coeffs)), lc.s)
        column = [float(c) for c in lc.routh_column(poly)]
        hurwitz = all(c > 0 for c in column)
        stable = lc.max_real_part(coeffs) < 0
        assert hurwitz == stable, f"seed {SEED}, trial {trial}: {coeffs} column {column}"


def test_characteristic_polynomial_matches_the_state_matrix_of_a_random_two_mass_loop():
    """Two masses, springs and dampers under P force control: roots of det A(s) = eigenvalues of
    the first-order state matrix built by hand."""
    rng = np.random.default_rng(SEED)
    names = "m_r m_w b_r b_w b_s k_s k_w k_f".split()
    mr, mw, br, bw, bs, ks, kw, kf = (symbol(n) for n in names)
    xr, xw, Fd = symbol("x_r"), symbol("x_w"), symbol("F_d")
    dxr, dxw, ddxr, ddxw = (symbol(n) for n in "dx_r dx_w ddx_r ddx_w".split())
    Fc = ks * (xr - xw)
    loop = lc.LinearLoop([mr * ddxr + br * dxr + bs * (dxr - dxw) + Fc - kf * (Fd - Fc),
                          mw * ddxw + bw * dxw + bs * (dxw - dxr) - Fc + kw * xw], [xr, xw], [], [Fd])
    char = loop.characteristic_polynomial()
    for trial in range(10):
        v = dict(zip((mr, mw, br, bw, bs, ks, kw, kf), rng.uniform(0.2, 5.0, 8)))
        M = np.diag([v[mr], v[mw]])
        D = np.array([[v[br] + v[bs], -v[bs]], [-v[bs], v[bw] + v[bs]]])
        K = np.array([[v[ks] * (1 + v[kf]), -v[ks] * (1 + v[kf])], [-v[ks], v[ks] + v[kw]]])
        A = np.block([[np.zeros((2, 2)), np.eye(2)], [-np.linalg.solve(M, K), -np.linalg.solve(M, D)]])
        eig = np.sort_complex(np.linalg.eigvals(A))
        coeffs = [float(c) for c in sp.Poly(char.xreplace(v), lc.s).all_coeffs()]
        roots = np.sort_complex(np.roots(coeffs))
        assert np.allclose(roots, eig, atol=1e-8), f"seed {SEED}, trial {trial}"


def test_equilibrium_and_dc_gain_agree():
    """The steady measured force of a step equals W(0) F_d (final value theorem)."""
    m, b, k, kp, ki, Fd = (symbol(n) for n in "m b k K_P K_I F_d".split())
    x, dx, ddx, z, dz = (symbol(n) for n in "x dx ddx z dz".split())
    loop = lc.LinearLoop([m * ddx + b * dx + k * x - kp * (Fd - k * x) - ki * z, dz - (Fd - k * x)], [x], [z], [Fd])
    eq = loop.equilibrium()
    num, den = loop.transfer(k * x)
    assert sp.cancel((num / den).subs(lc.s, 0) * Fd - k * eq.values[x]) == 0
    assert sp.cancel(eq.values[x] - Fd / k) == 0


def test_nonlinear_model_is_refused():
    q, dq, ddq = symbol("q"), symbol("dq"), symbol("ddq")
    with pytest.raises(lc.LinearLoopError):
        lc.LinearLoop([ddq + sp.sin(q)], [q], [], [])


def test_gain_bound_from_a_condition():
    k, m = symbol("k"), symbol("m")
    assert lc.solve_linear_condition(m - 2 * k, k, [m]).relation == "<"
    assert lc.solve_linear_condition(k * (m - 1), k, [m]) is None   # sign of m - 1 unknown
