"""Multivariate factoring takes the same path on every run (app/core/reproducible_sympy.py)."""
import subprocess
import sys

import sympy as sp
import sympy.polys.factortools as factortools
from sympy.core.random import seed as seed_sympy

from app.core.reproducible_sympy import restart, sparse_randint

# det(J J^T) of a planar 3R in canonical trigonometric form: with sympy's own random substitution
# points, global seeds 342, 610 and 1109 (among others, about one in two hundred) make its
# factoring run for minutes.
L1, L2, L3, Q2, Q3 = sp.symbols("l1 l2 l3 q2 q3")
PLANAR_3R_MANIPULABILITY = sp.sympify(
    "-l1**2*l2**2*cos(2*q2)/2 + l1**2*l2**2/2 + l1**2*l2*l3*cos(q3) - l1**2*l2*l3*cos(2*q2 + q3)"
    " - l1**2*l3**2*cos(2*q2 + 2*q3) + l1**2*l3**2 + l1*l2*l3**2*cos(q2) - l1*l2*l3**2*cos(q2 + 2*q3)"
    " - l2**2*l3**2*cos(2*q3) + l2**2*l3**2")


ORIGINAL_TEST_POINTS = factortools.dmp_zz_wang_test_points


def factor_recording_points(expr, monkeypatch):
    points = []
    original = ORIGINAL_TEST_POINTS

    def spy(f, T, ct, A, u, K):
        points.append(tuple(int(a) for a in A))
        return original(f, T, ct, A, u, K)

    monkeypatch.setattr(factortools, "dmp_zz_wang_test_points", spy)
    return sp.factor(expr), points


def test_the_factoring_draws_the_same_points_whatever_sympys_own_seed(monkeypatch):
    assert factortools._randint is sparse_randint, "app/__init__.py did not install the patch"
    runs = []
    for global_seed in (342, 610, 1109):
        seed_sympy(global_seed)
        restart()
        runs.append(factor_recording_points(PLANAR_3R_MANIPULABILITY, monkeypatch))
    (factored, points), *others = runs
    assert points, "Wang's algorithm was not used: the test no longer exercises the patch"
    assert all(p == points for _, p in others)
    assert all(f == factored for f, _ in others)
    assert sp.expand(factored - PLANAR_3R_MANIPULABILITY) == 0


def test_the_substitution_points_are_mostly_zero():
    restart()
    draw = sparse_randint()
    values = [draw(-2, 2) for _ in range(2000)]
    assert 0.7 < values.count(0) / len(values) < 0.85
    assert set(values) == {-2, -1, 0, 1, 2}


def test_an_explicit_seed_is_still_the_callers():
    assert [sparse_randint(5)(0, 100) for _ in range(3)] == [sparse_randint(5)(0, 100)] * 3
    assert sparse_randint([4, 2])(0, 9) == 4


def test_importing_app_before_sympy_patches_it_on_import():
    code = ("import sys, app; assert 'sympy' not in sys.modules; "
            "import sympy.polys.factortools as ft, app.core.reproducible_sympy as r; "
            "print(ft._randint is r.sparse_randint)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "True"
