"""Properties of the underactuated / constrained / control-law tasks, checked numerically against the
full model (NumericModel), not against printed answers."""
import numpy as np
import pytest
import sympy as sp
from scipy.integrate import solve_ivp

from app.core.exercise import ExerciseError, parse_exercise, solve
from app.core.expressions import symbol
from app.core.numeric import NumericModel
from app.core.robot import load_robot


def run(robot, tasks, given=None):
    ex = parse_exercise({"id": "test", "robot": robot, "question": "?", "tasks": tasks, "given": given or {}})
    return solve(ex).answers


def numeric(expr, robot, extra_syms=()):
    """Lambdify an answer over (q, dq, extra symbols) with the robot's default parameter values."""
    values = {p.symbol: p.value for p in robot.parameters.values()}
    args = list(robot.q) + list(robot.dq) + [symbol(s) for s in extra_syms]
    return sp.lambdify(args, sp.Matrix(expr).subs(values), "numpy")


@pytest.mark.parametrize("robot_name, passive, linearize", [
    ("crane_2018_03_27", None, None),              # collocated: q1'' = a (cart)
    ("rp_2004_03_25", ["q2"], None),               # collocated: q1'' = a1
    ("rp_2004_03_25", ["q2"], ["q2"]),             # non-collocated: q2'' = a2
    ("crane_2018_03_27", None, ["q2"]),            # non-collocated (where cos q2 != 0)
])
def test_pfl_law_gives_the_commanded_acceleration(robot_name, passive, linearize):
    robot = load_robot(robot_name)
    spec = {"kind": "pfl", "inputs": ["a"]}
    if passive:
        spec["passive"] = passive
    if linearize:
        spec["linearize"] = linearize
    ans = run(robot_name, [spec])
    law = numeric(ans["u"], robot, ["a"])
    num = NumericModel(robot)
    n = robot.n
    act = [c not in (passive or []) and robot.actuated[i] for i, c in enumerate(robot.coordinates)]
    lin = robot.coordinates.index((linearize or [c for c, a in zip(robot.coordinates, act) if a])[0])
    rng = np.random.default_rng(0)
    for _ in range(25):
        q = rng.uniform(-1.2, 1.2, n)
        dq = rng.uniform(-2, 2, n)
        a = rng.uniform(-5, 5)
        u = np.asarray(law(*q, *dq, a), dtype=float).ravel()
        tau = np.zeros(n)
        tau[np.array(act)] = u
        ddq = num.forward_dynamics(q, dq, tau)
        assert ddq[lin] == pytest.approx(a, abs=1e-9 * max(1, abs(a)))
        closed = np.asarray(numeric(ans["closed_loop"], robot, ["a"])(*q, *dq, a), dtype=float).ravel()
        assert np.allclose(closed, ddq, atol=1e-9)


def test_pfl_in_simulation_makes_the_cart_a_double_integrator():
    """Crane with the collocated law and a = sin(t): q1(t) = q1(0) + t v0 + t - sin(t)."""
    robot = load_robot("crane_2018_03_27")
    law = numeric(run("crane_2018_03_27", [{"kind": "pfl", "inputs": ["a"]}])["u"], robot, ["a"])
    num = NumericModel(robot)

    def f(t, x):
        a = np.sin(t)
        u = float(np.asarray(law(*x[:2], *x[2:], a)).ravel()[0])
        return np.concatenate([x[2:], num.forward_dynamics(x[:2], x[2:], [u, 0.0])])

    x0 = np.array([0.2, 0.5, 0.3, -0.4])
    sol = solve_ivp(f, (0, 4), x0, rtol=1e-11, atol=1e-12, dense_output=True)
    t = np.linspace(0, 4, 9)
    expected = x0[0] + x0[2] * t + t - np.sin(t)
    assert np.allclose(sol.sol(t)[0], expected, atol=1e-7)


def test_pfl_rejects_a_choice_without_coupling():
    with pytest.raises(ExerciseError):
        run("rp_2004_03_25", [{"kind": "pfl"}])          # fully actuated: no passive joint


def test_linearization_matches_finite_differences():
    robot = load_robot("crane_2018_03_27")
    ans = run("crane_2018_03_27", [{"kind": "linearization", "at": {"q1": 0, "q2": 0}}])
    values = {p.symbol: p.value for p in robot.parameters.values()}
    A = np.array(ans["A"].subs(values), dtype=float)
    B = np.array(ans["B"].subs(values), dtype=float)
    num = NumericModel(robot)

    def f(x, u):
        return np.concatenate([x[2:], num.forward_dynamics(x[:2], x[2:], [u, 0.0])])

    eps = 1e-6
    x0 = np.zeros(4)
    A_fd = np.column_stack([(f(x0 + eps * e, 0) - f(x0 - eps * e, 0)) / (2 * eps) for e in np.eye(4)])
    B_fd = (f(x0, eps) - f(x0, -eps)) / (2 * eps)
    assert np.allclose(A, A_fd, atol=1e-6)
    assert np.allclose(B.ravel(), B_fd, atol=1e-6)


def test_linearization_refuses_a_non_equilibrium():
    with pytest.raises(ExerciseError):
        run("crane_2018_03_27", [{"kind": "linearization", "at": {"q1": 0, "q2": 0.5}}])


@pytest.mark.parametrize("robot_name, spec", [
    ("rp_radial_horizontal", {"point": "ee", "constraint": "px - 0.7", "D": ["0", "1"]}),
    ("twolink_unit_payload", {"point": "ee", "constraint": "px", "pseudo_velocity": {"direction": [0, 1]}}),
])
def test_reduced_dynamics_agrees_with_the_constrained_full_model(robot_name, spec):
    """On the constraint manifold, q'' of the reduced model (with v' from M_v v' + n_v = B_v u) equals
    q'' of the full model with the multiplier lambda; lambda keeps A q'' + A' q' = 0."""
    robot = load_robot(robot_name)
    ans = run(robot_name, [dict(kind="reduced_dynamics", **spec)])
    n = robot.n
    us = [f"u{i + 1}" for i in range(n)]
    f = {k: numeric(ans[k], robot, us + ["dv"]) for k in ("A", "A_dot", "F", "M_v", "n_v", "B_v", "qdd", "lambda")}
    h = numeric(ans["h"], robot)
    num = NumericModel(robot)
    rng = np.random.default_rng(4)
    from scipy.optimize import brentq
    for _ in range(10):
        # a point of the constraint: pick q1, solve h = 0 for q2; a velocity in the null space of A
        q1 = rng.uniform(0.1, 0.6)
        g = lambda x: float(np.asarray(h(q1, x, 0, 0)).ravel()[0])
        grid = np.linspace(0.3, 3.0, 200)
        vals = [g(x) for x in grid]
        k = next(i for i in range(199) if vals[i] * vals[i + 1] < 0)
        q = np.array([q1, brentq(g, grid[k], grid[k + 1], xtol=1e-14)])
        Fq = np.asarray(f["F"](*q, 0, 0, *[0] * n, 0), dtype=float).reshape(n, -1)
        dq = (Fq @ [rng.uniform(-1, 1)]).ravel()
        u = rng.uniform(-3, 3, n)
        args = (*q, *dq, *u)
        Mv = float(np.asarray(f["M_v"](*args, 0)).ravel()[0])
        nv = float(np.asarray(f["n_v"](*args, 0)).ravel()[0])
        Bv = np.asarray(f["B_v"](*args, 0), dtype=float).ravel()
        dv = (Bv @ u - nv) / Mv
        qdd_red = np.asarray(f["qdd"](*args, dv), dtype=float).ravel()
        lam = float(np.asarray(f["lambda"](*args, 0)).ravel()[0])
        A = np.asarray(f["A"](*args, 0), dtype=float).ravel()
        Ad = np.asarray(f["A_dot"](*args, 0), dtype=float).ravel()
        qdd_full = num.forward_dynamics(q, dq, u + A * lam)
        assert np.allclose(qdd_red, qdd_full, atol=1e-8)
        assert abs(A @ qdd_full + Ad @ dq) < 1e-8


def test_parametrization_in_given_coefficients_reproduces_the_model():
    robot = load_robot("crane_2018_03_27")
    coeffs = ["m + m_p", "I_p + m_p*d_p**2", "m_p*d_p", "f_v"]
    ans = run("crane_2018_03_27", [{"kind": "dynamics"}, {"kind": "parametrization", "coefficients": coeffs}])
    model = ans["M"] * sp.Matrix(robot.ddq) + ans["c"] + ans["g"] + ans["friction"]
    diff = (ans["Y"] * ans["a"] - model).applyfunc(sp.expand)
    assert all(sp.simplify(e) == 0 for e in diff)


def test_parametrization_rejects_coefficients_that_do_not_fit():
    with pytest.raises(ExerciseError, match="do not parametrize"):
        run("crane_2018_03_27", [{"kind": "parametrization", "coefficients": ["m", "I_p + m_p*d_p**2", "m_p*d_p", "f_v"]}])
    with pytest.raises(ExerciseError, match="not independent"):
        run("crane_2018_03_27", [{"kind": "parametrization", "coefficients": ["m + m_p", "2*m + 2*m_p", "m_p*d_p", "f_v"]}])


def test_adaptive_law_lyapunov_derivative_along_the_closed_loop():
    """Simulate the Slotine-Li law on the polar 2R and check that V = 1/2 s^T M s + e^T K_P e +
    1/2 atilde^T Gamma^-1 atilde decreases as V_dot = -e'^T K_D e' - e^T K_P K_D^-1 K_P e says."""
    name = "polar_2r_2016_06_06"
    robot = load_robot(name)
    coeffs = ["I_1y + I_2y + m2*d2**2", "I_2x - I_2y - m2*d2**2", "I_2y + m2*d2**2", "m2*g0*d2"]
    ans = run(name, [{"kind": "adaptive_law", "coefficients": coeffs}])
    values = {p.symbol: p.value for p in robot.parameters.values()}
    a_true = np.array([float(e.subs(values)) for e in ans["a"]])
    kp, kd, gam = np.array([20.0, 30.0]), np.array([8.0, 10.0]), np.array([0.5, 0.5, 0.5, 0.5])
    gains = {**{symbol(f"kp{i + 1}"): kp[i] for i in range(2)}, **{symbol(f"kd{i + 1}"): kd[i] for i in range(2)},
             **{symbol(f"gamma{i + 1}"): gam[i] for i in range(4)}}
    syms = list(robot.q) + list(robot.dq) + [symbol(s) for s in
                                             ("e1", "e2", "de1", "de2", "dq1_r", "dq2_r", "ddq1_r", "ddq2_r",
                                              "ahat1", "ahat2", "ahat3", "ahat4")]
    u_f = sp.lambdify(syms, ans["u"].subs(gains).subs(values), "numpy")
    up_f = sp.lambdify(syms, ans["update"].subs(gains).subs(values), "numpy")
    vdot_f = sp.lambdify(syms, sp.Matrix([ans["V_dot"]]).subs(gains), "numpy")
    num = NumericModel(robot)
    qd = lambda t: np.array([np.sin(t), 0.5 * np.cos(t)])
    dqd = lambda t: np.array([np.cos(t), -0.5 * np.sin(t)])
    ddqd = lambda t: np.array([-np.sin(t), -0.5 * np.cos(t)])
    lam = kp / kd

    def pieces(t, x):
        q, dq, ah = x[:2], x[2:4], x[4:]
        e, de = qd(t) - q, dqd(t) - dq
        dqr, ddqr = dqd(t) + lam * e, ddqd(t) + lam * de
        return (*q, *dq, *e, *de, *dqr, *ddqr, *ah), q, dq, e, de, dqr, ah

    def f(t, x):
        args, q, dq, *_ = pieces(t, x)
        u = np.asarray(u_f(*args), dtype=float).ravel()
        return np.concatenate([dq, num.forward_dynamics(q, dq, u), np.asarray(up_f(*args), dtype=float).ravel()])

    def V(t, x):
        args, q, dq, e, de, dqr, ah = pieces(t, x)
        s = dqr - dq
        at = ah - a_true
        return 0.5 * s @ num.M(q) @ s + e @ (kp * e) + 0.5 * at @ (at / gam)

    x0 = np.concatenate([[0.3, 0.2], [0, 0], a_true * 0.5])
    sol = solve_ivp(f, (0, 2), x0, rtol=1e-11, atol=1e-12, dense_output=True)
    for t in (0.3, 0.9, 1.6):
        h = 1e-5
        dV = (V(t + h, sol.sol(t + h)) - V(t - h, sol.sol(t - h))) / (2 * h)
        args = pieces(t, sol.sol(t))[0]
        assert dV == pytest.approx(float(np.asarray(vdot_f(*args)).ravel()[0]), rel=1e-5, abs=1e-7)


def test_elastic_joint_pd_with_gravity_compensation_regulates_the_links():
    """Elastic 2R under gravity: V' = -theta'^T K_D theta' symbolically, dV/dt matches it along a
    simulation, and the links settle at q_d with the motors at theta_d = q_d + K^-1 g(q_d)."""
    name = "elastic_2r"
    robot = load_robot(name)
    ans = run(name, [{"kind": "elastic_joints"}])
    kd = [symbol("kd1"), symbol("kd2")]
    dth = [symbol("dtheta1"), symbol("dtheta2")]
    assert sp.expand(ans["V_dot"] + kd[0] * dth[0] ** 2 + kd[1] * dth[1] ** 2) == 0
    values = {p.symbol: p.value for p in robot.parameters.values()}
    gains = {symbol("kp1"): 300.0, symbol("kp2"): 200.0, symbol("kd1"): 40.0, symbol("kd2"): 25.0,
             symbol("q1_d"): 0.8, symbol("q2_d"): -0.5}
    args = list(robot.q) + list(robot.dq)
    u_f = sp.lambdify(args, ans["u"].subs(gains).subs(values), "numpy")
    V_f = sp.lambdify(args, sp.Matrix([ans["V"]]).subs(gains).subs(values), "numpy")
    Vd_f = sp.lambdify(args, sp.Matrix([ans["V_dot"]]).subs(gains).subs(values), "numpy")
    num = NumericModel(robot)

    def f(t, x):
        u = np.asarray(u_f(*x), dtype=float).ravel()
        return np.concatenate([x[4:], num.forward_dynamics(x[:4], x[4:], np.concatenate([[0, 0], u]))])

    sol = solve_ivp(f, (0, 8), np.zeros(8), method="LSODA", rtol=1e-10, atol=1e-11, dense_output=True)
    for t in (0.2, 0.7, 1.5):
        h = 1e-5
        dV = (float(np.asarray(V_f(*sol.sol(t + h))).ravel()[0]) - float(np.asarray(V_f(*sol.sol(t - h))).ravel()[0])) / (2 * h)
        assert dV == pytest.approx(float(np.asarray(Vd_f(*sol.sol(t))).ravel()[0]), rel=1e-4, abs=1e-6)
    theta_d = np.array(ans["theta_d"].subs(gains).subs(values), dtype=float).ravel()
    final = sol.sol(8.0)
    assert np.allclose(final[:2], [0.8, -0.5], atol=1e-4)
    assert np.allclose(final[2:4], theta_d, atol=1e-4)
