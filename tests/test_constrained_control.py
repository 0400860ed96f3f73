"""Constrained dynamics, Cartesian/task-frame control, impacts and iterative learning checked
against independent numeric computations (random instances, fixed seeds)."""
import numpy as np
import pytest
import sympy as sp

from app.core import linear_control as lc
from app.core import task_frame as tf
from app.core.exercise import parse_exercise, solve
from app.core.expressions import symbol
from app.core.impact import impact
from app.core.learning import iterate
from app.core.numeric import NumericModel, random_state
from app.core.robot import load_robot

SEED = 21


def _run(robot, tasks, given=None):
    ex = parse_exercise({"id": "test", "robot": robot, "question": "?", "tasks": tasks, "given": given or {}})
    return solve(ex).answers


def test_hybrid_input_gives_the_commanded_pseudo_acceleration_and_force():
    """RP end-effector on x = k: under u_hybrid the full model with its multiplier (A q'' + A' q' = 0)
    moves with v' = a_v and pushes on the line with lambda = a_lambda."""
    robot = load_robot("rp_radial_horizontal")
    ans = _run("rp_radial_horizontal", [{"kind": "reduced_dynamics", "point": "ee", "constraint": "px - k",
                                         "D": ["q2*cos(q1)", "sin(q1)"], "hybrid": True}])
    values = {p.symbol: p.value for p in robot.parameters.values()}
    values[symbol("k")] = 0.7
    args = list(robot.q) + list(robot.dq) + [symbol(s) for s in ("v", "a_v", "a_lambda")]
    f_u = sp.lambdify(args, ans["u_hybrid"].xreplace(values), "numpy")
    f_A = sp.lambdify(args, ans["A"].xreplace(values), "numpy")
    f_Ad = sp.lambdify(args, ans["A_dot"].xreplace(values), "numpy")
    f_D = sp.lambdify(args, ans["D"].xreplace(values), "numpy")
    f_Dd = sp.lambdify(args, ans["D_dot"].xreplace(values), "numpy")
    num = NumericModel(robot)
    rng = np.random.default_rng(SEED)
    for trial in range(10):
        q1 = rng.uniform(-0.8, 0.8)
        q = np.array([q1, 0.7 / np.cos(q1)])                         # on the line x = 0.7
        A = np.asarray(f_A(*q, 0, 0, 0, 0, 0), float).reshape(1, 2)
        t = np.array([-A[0, 1], A[0, 0]])
        dq = rng.uniform(-1, 1) * t                                  # tangent velocity
        v = float((np.asarray(f_D(*q, *dq, 0, 0, 0), float) @ dq).ravel()[0])
        a_v, a_l = rng.uniform(-2, 2, 2)
        x = (*q, *dq, v, a_v, a_l)
        u = np.asarray(f_u(*x), float).ravel()
        M = num.M(q)
        n = num.c(q, dq) + num.g(q)
        Ad = np.asarray(f_Ad(*x), float).reshape(1, 2)
        # M q'' - A^T lam = u - n,  A q'' = -A' q'
        K = np.block([[M, -A.T], [A, np.zeros((1, 1))]])
        sol = np.linalg.solve(K, np.concatenate([u - n, -Ad @ dq]))
        ddq, lam = sol[:2], sol[2]
        dv = float((np.asarray(f_D(*x), float) @ ddq + np.asarray(f_Dd(*x), float) @ dq).ravel()[0])
        assert abs(dv - a_v) < 1e-9 and abs(lam - a_l) < 1e-9, f"seed {SEED}, trial {trial}"


def test_task_frame_error_derivatives_match_finite_differences():
    f = tf.rotating_frame_errors(["n", "t"])
    s = f.symbols
    rng = np.random.default_rng(SEED)
    w, ph, a1, a2 = rng.uniform(0.5, 2.0, 4)
    alpha = lambda t: 0.3 * np.sin(w * t) + 0.2 * t ** 2
    e = lambda t: np.array([np.cos(a1 * t + ph), np.sin(a2 * t)])
    te = lambda t: np.array([[np.cos(alpha(t)), np.sin(alpha(t))], [-np.sin(alpha(t)), np.cos(alpha(t))]]) @ e(t)
    h, t0 = 1e-4, 0.7
    d = lambda g, t: (g(t + h) - g(t - h)) / (2 * h)
    dd = lambda g, t: (g(t + h) - 2 * g(t) + g(t - h)) / h ** 2
    subs = {s["alpha"]: alpha(t0), s["dalpha"]: d(alpha, t0), s["ddalpha"]: dd(alpha, t0)}
    subs.update(dict(zip(s["e"], e(t0))))
    subs.update(dict(zip(s["de"], d(e, t0))))
    subs.update(dict(zip(s["dde"], dd(e, t0))))
    assert np.allclose(np.array(f.te_dot.xreplace(subs), float).ravel(), d(te, t0), atol=1e-6)
    assert np.allclose(np.array(f.te_ddot.xreplace(subs), float).ravel(), dd(te, t0), atol=1e-4)


def test_gains_from_response_on_random_poles():
    t = symbol("t")
    rng = np.random.default_rng(SEED)
    for trial in range(3):
        p1, p2 = (-int(x) for x in rng.integers(1, 9, 2))
        # distinct poles: a combination of two exponentials; a double pole: (1 + c t) exp(p t)
        e = 2 * sp.exp(p1 * t) - sp.exp(p2 * t) if p1 != p2 else (1 + 3 * t) * sp.exp(p1 * t)
        kp, kd = lc.second_order_gains(e, t)
        assert kp == p1 * p2 and kd == -(p1 + p2), f"seed {SEED}, trial {trial}"


def test_impact_on_a_wall_keeps_energy_and_reverses_the_normal_velocity():
    robot = load_robot("planar_2r")
    num = NumericModel(robot)
    rng = np.random.default_rng(SEED)
    for trial in range(5):
        q, dq = random_state(robot, rng)
        l1, l2 = 1.0, 0.8
        J = sp.Matrix([[-l1 * np.sin(q[0]) - l2 * np.sin(q[0] + q[1]), -l2 * np.sin(q[0] + q[1])]])   # x of the tip
        for e in (1, sp.Rational(1, 2)):
            r = impact(sp.Matrix(num.M(q)), J, sp.Matrix(dq), e)
            Jn = np.array(J, float)
            after = np.array(r.dq_after, float).ravel()
            assert abs((Jn @ after)[0] + float(e) * (Jn @ dq)[0]) < 1e-9, f"seed {SEED}, trial {trial}"
            if e == 1:
                assert abs(after @ num.M(q) @ after - dq @ num.M(q) @ dq) < 1e-9


def test_gravity_learning_error_stays_below_its_bounds():
    robot = load_robot("planar_2r")
    num = NumericModel(robot)
    q_d, q_0 = np.array([0.8, -0.4]), np.zeros(2)
    alpha = 175.0                         # above the largest norm of dg/dq of planar_2r (checked below)
    rng = np.random.default_rng(SEED)
    for _ in range(200):
        q = rng.uniform(-np.pi, np.pi, 2)
        h = 1e-6
        G = np.column_stack([(num.g(q + h * e) - num.g(q - h * e)) / (2 * h) for e in np.eye(2)])
        assert np.linalg.norm(G, 2) < alpha
    run = iterate(num.g, np.array([1000.0, 1000.0]), q_d, q_0, alpha, 1e-3, iterations=8)
    assert run.converges and run.beta < 0.2 + 1e-12          # beta = 1/5: k_p / 5 > alpha
    assert all(e <= b + 1e-12 for e, b in zip(run.e_iterates, run.e_bounds))
    assert np.allclose(run.u_iterates[-1], num.g(q_d), atol=1e-6)
