"""Identities every shipped robot's model must satisfy (issue 2 acceptance)."""
import numpy as np
import pytest
import sympy as sp
from scipy.integrate import solve_ivp

from app.core.dynamics import derive
from app.core.numeric import NumericModel, cross_check, random_state
from app.core.robot import list_robot_names, load_robot
from app.core.trig import TrigPoly

ROBOTS = list_robot_names()


@pytest.fixture(scope="module", params=ROBOTS)
def robot(request):
    return load_robot(request.param)


def test_at_least_one_robot():
    assert ROBOTS


def test_inertia_symmetric_positive_definite(robot):
    dyn = derive(robot)
    assert dyn.M == dyn.M.T
    num = NumericModel(robot, dynamics=dyn)
    rng = np.random.default_rng(1)
    for _ in range(20):
        q, _ = random_state(robot, rng)
        eig = np.linalg.eigvalsh(num.M(q))
        assert eig.min() > 0, f"M not positive definite at q={q}: eigenvalues {eig}"


def test_mdot_minus_2c_is_skew(robot):
    dyn = derive(robot)
    q, dq = dyn.q, dyn.dq
    n = len(q)
    Mdot = sp.zeros(n, n)
    for k in range(n):
        Mdot += dyn.M.diff(q[k]) * dq[k]
    N = Mdot - 2 * dyn.C
    for i in range(n):
        for j in range(i, n):
            assert TrigPoly.from_expr(N[i, j] + N[j, i]).is_zero(), f"(Mdot - 2C) not skew at ({i},{j})"


def test_c_equals_C_times_dq(robot):
    dyn = derive(robot)
    diff = dyn.c - dyn.C * sp.Matrix(dyn.dq)
    assert all(TrigPoly.from_expr(e).is_zero() for e in diff)


def test_symbolic_equals_pinocchio(robot):
    result = cross_check(robot, states=50, tolerance=1e-9)
    assert result.ok, result.summary()


def test_regressor_reproduces_the_model(robot):
    dyn = derive(robot)
    par = dyn.parametrization
    lhs = dyn.equations()
    rhs = par.Y * sp.Matrix(par.a) + par.known_terms
    assert all(TrigPoly.from_expr(e).is_zero() for e in (lhs - rhs)), "Y a != M q'' + c + g + ..."
    dqr, ddqr = robot.reference_symbols()
    ref = dyn.M * sp.Matrix(ddqr) + dyn.C * sp.Matrix(dqr) + dyn.g + dyn.spring + dyn.friction.subs(dict(zip(dyn.dq, dqr)))
    assert all(TrigPoly.from_expr(e).is_zero() for e in (ref - par.Y_ref * sp.Matrix(par.a) - par.known_terms_ref))


def test_energy_is_conserved_without_friction_and_torque(robot):
    """Free motion (no torque, friction set to zero) keeps T + U to 1e-6 of the energy scale over 5 s.

    Integrated with DOP853 at rtol = atol = 1e-10: the integrator's own error in T + U is then at most
    2e-8 on every shipped robot (measured when the tolerance was chosen; at most 3e-10 at 1e-12), so a
    drift above 1e-6 is the model's, as with a tighter tolerance, at half the steps. The right-hand
    side is M(q), C(q, q') q' + g(q) + springs + friction of the derived model compiled into one
    function (one call and one solve per evaluation instead of five calls)."""
    no_friction = {p.name: 0.0 for p in robot.parameters.values() if p.kind == "friction"}
    num = NumericModel(robot, no_friction)
    dyn = num.dyn
    bias = dyn.C * sp.Matrix(robot.dq) + dyn.g + dyn.spring + dyn.friction
    terms = sp.lambdify([robot.q, robot.dq, robot.parameter_symbols], [dyn.M, bias], "numpy", cse=True)
    rng = np.random.default_rng(3)
    q0, dq0 = random_state(robot, rng)
    dq0 = 0.5 * dq0
    n = robot.n

    def f(t, x):
        M, b = terms(x[:n], x[n:], num.p)
        return np.concatenate([x[n:], np.linalg.solve(np.asarray(M, float), -np.asarray(b, float).reshape(n))])

    assert np.allclose(f(0.0, np.concatenate([q0, dq0]))[n:], num.forward_dynamics(q0, dq0, np.zeros(n)))
    sol = solve_ivp(f, (0.0, 5.0), np.concatenate([q0, dq0]), method="DOP853", rtol=1e-10, atol=1e-10)
    assert sol.success
    E = [sum(num.energy(x[:n], x[n:])) for x in sol.y.T]
    T0 = num.energy(q0, dq0)[0]
    scale = max(abs(E[0]), T0, 1e-3)
    drift = max(abs(e - E[0]) for e in E) / scale
    assert drift < 1e-6, f"energy drift {drift:.2e}"
