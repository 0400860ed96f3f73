"""Redundancy at velocity, acceleration and torque level (app/core/dynamic_redundancy.py and the
dynamic_redundancy task) and SNS with bounds from joint limits, on random instances against
independent computations."""
import numpy as np
import pytest
import sympy as sp

from app.core import dynamic_redundancy as dr
from app.core.exercise import ExerciseError, parse_exercise, solve
from app.core.numeric import NumericModel
from app.core.robot import load_robot


def _random_spd(rng, n):
    A = rng.normal(size=(n, n))
    return A @ A.T + n * np.eye(n)


@pytest.mark.parametrize("seed", range(5))
def test_closed_forms_equal_the_kkt_minimizers(seed):
    rng = np.random.default_rng(seed)
    n, m = 4, 2
    J, r = rng.normal(size=(m, n)), rng.normal(size=m)
    M, nvec, W = _random_spd(rng, n), rng.normal(size=n), _random_spd(rng, n)
    x0 = rng.normal(size=n)
    acc = dr.resolve_torque(J, r, M, nvec, "acceleration", W, x0)
    assert np.allclose(acc.ddq, dr.kkt_minimizer(J, r, W, -W @ x0), atol=1e-9), f"seed {seed}"
    tor = dr.resolve_torque(J, r, M, nvec, "torque", W, x0)
    best = M @ dr.kkt_minimizer(J, r, M.T @ W @ M, M.T @ W @ (nvec - x0)) + nvec
    assert np.allclose(tor.tau, best, atol=1e-8), f"seed {seed}"
    assert np.allclose(J @ tor.ddq, r, atol=1e-9) and np.allclose(M @ tor.ddq + nvec, tor.tau, atol=1e-9), f"seed {seed}"


def test_symbolic_and_numeric_forms_agree():
    rng = np.random.default_rng(7)
    J, r, M, nvec = rng.normal(size=(1, 2)), rng.normal(size=1), _random_spd(rng, 2), rng.normal(size=2)
    sym = dr.resolve_torque(sp.Matrix(J), sp.Matrix(r), sp.Matrix(M), sp.Matrix(nvec), "torque", sp.diag(1, 3))
    num = dr.resolve_torque(J, r, M, nvec, "torque", np.diag([1.0, 3.0]))
    assert np.allclose(np.array(sym.tau.evalf(), dtype=float).ravel(), num.tau, atol=1e-10)


def test_imposed_joints_give_the_joint_space_decomposition():
    rng = np.random.default_rng(3)
    J, r = rng.normal(size=(2, 3)), rng.normal(size=2)
    sol = dr.minimum_weighted_norm(J, r, fixed={2: 0.7})
    assert sol.x[2] == pytest.approx(0.7)
    assert np.allclose(sol.x[:2], np.linalg.solve(J[:, :2], r - J[:, 2] * 0.7))


def _exercise(tasks, given, robot="planar_3r"):
    return parse_exercise({"id": "test", "robot": robot, "question": "?", "given": given, "tasks": tasks})


@pytest.mark.parametrize("seed", range(3))
def test_torque_realizes_the_task_acceleration_with_the_full_model(seed):
    rng = np.random.default_rng(seed)
    q, dq, ddp = rng.uniform(-1, 1, 3), rng.uniform(-1, 1, 3), rng.uniform(-2, 2, 2)
    given = {"q1": float(q[0]), "q2": float(q[1]), "q3": float(q[2]), "dq_now": dq.tolist(), "ddp": ddp.tolist()}
    tasks = [{"kind": "jacobian", "name": "J", "point": "ee", "components": ["x", "y"]},
             {"kind": "dynamic_redundancy", "name": "tau", "jacobian": "J", "task": "ddp", "velocity": "dq_now",
              "objective": "torque", "weights": "inertia"}]
    ans = solve(_exercise(tasks, given)).answers
    robot = load_robot("planar_3r")
    ddq = NumericModel(robot).forward_dynamics(q, dq, ans["tau"])      # independent: M^-1 (tau - n)
    h = 1e-6
    p = lambda t: robot_point(robot, q + t * dq + 0.5 * t * t * ddq)
    ddp_fd = (p(h) - 2 * p(0) + p(-h)) / h ** 2
    assert np.allclose(ddp_fd, ddp, atol=1e-3), f"seed {seed}: {ddp_fd} vs {ddp}"
    assert ans["tau_kkt_gap"] < 1e-8


def robot_point(robot, q):
    l = [robot.parameters[k].value for k in ("l1", "l2", "l3")]
    a = np.cumsum(q)
    return np.array([sum(l[i] * np.cos(a[i]) for i in range(3)), sum(l[i] * np.sin(a[i]) for i in range(3))])


@pytest.mark.parametrize("seed", range(10))
def test_sns_with_bounds_from_limits_keeps_the_next_state_within_every_limit(seed):
    rng = np.random.default_rng(seed)
    q_min, q_max, V, A, T = -2.0, 2.0, 1.5, 6.0, 0.05
    q = rng.uniform(-1.9, 1.9, 3)
    dq = rng.uniform(-1.0, 1.0, 3)
    ddp = rng.uniform(-8, 8, 2)
    given = {"q1": float(q[0]), "q2": float(q[1]), "q3": float(q[2]), "dq_now": dq.tolist(), "ddp": ddp.tolist()}
    tasks = [{"kind": "jacobian", "name": "J", "point": "ee", "components": ["x", "y"]},
             {"kind": "sns", "name": "ddq", "level": "acceleration", "jacobian": "J", "task": "ddp",
              "joint_velocity": "dq_now", "minimum_norm": True,
              "limits": {"position": {"lower": q_min, "upper": q_max}, "velocity": V, "acceleration": A, "sampling_time": T}}]
    try:
        ans = solve(_exercise(tasks, given)).answers
    except ExerciseError as exc:          # a joint must brake whatever the task: refused with a message
        assert "joint" in str(exc), f"seed {seed}: {exc}"
        return
    x = np.asarray(ans["ddq"], float)
    tol = 1e-9
    assert np.all(np.abs(x) <= A + tol), f"seed {seed}"
    assert np.all(np.abs(dq + x * T) <= V + tol), f"seed {seed}"
    q_next = q + dq * T + 0.5 * x * T ** 2
    assert np.all((q_next >= q_min - tol) & (q_next <= q_max + tol)), f"seed {seed}"
    assert np.allclose(ans["ddq_lower"], np.maximum.reduce([2 * (q_min - q - dq * T) / T ** 2, (-V - dq) / T, -A * np.ones(3)]))


# ---------------------------------------------------------------------- Lyapunov analysis (tasks/stability.py)
@pytest.mark.parametrize("seed", range(3))
def test_lyapunov_derivative_equals_the_rate_of_V_along_the_true_dynamics(seed):
    """V and V' of the lyapunov task (PD + gravity compensation on the planar 2R) against dV/dt
    computed by finite differences along the numeric forward dynamics (pinocchio-checked model)."""
    rng = np.random.default_rng(seed)
    gains = {"kp1": 30.0, "kp2": 20.0, "kd1": 6.0, "kd2": 4.0, "q1_d": 0.4, "q2_d": -0.3}
    tasks = [{"kind": "lyapunov", "law": {"gravity": True, "pd": {}}}]
    ans = solve(_exercise(tasks, {}, robot="planar_2r")).answers
    robot = load_robot("planar_2r")
    values = {sp.Symbol(k, real=True): v for k, v in {**robot.parameter_values(), **gains}.items()}
    q, dq = rng.uniform(-1, 1, 2), rng.uniform(-1, 1, 2)
    num = NumericModel(robot)
    Kp, Kd, qd = np.diag([30.0, 20.0]), np.diag([6.0, 4.0]), np.array([0.4, -0.3])
    tau = num.g(q) + Kp @ (qd - q) - Kd @ dq
    ddq = num.forward_dynamics(q, dq, tau)
    state = lambda x, v: {**values, **{s: float(a) for s, a in zip(robot.q, x)}, **{s: float(a) for s, a in zip(robot.dq, v)}}
    V = lambda x, v: float(sp.sympify(ans["V"]).xreplace(state(x, v)))
    h = 1e-6
    rate = (V(q + h * dq, dq + h * ddq) - V(q - h * dq, dq - h * ddq)) / (2 * h)
    assert rate == pytest.approx(float(ans["V_dot"].xreplace(state(q, dq))), abs=1e-5), f"seed {seed}"
    assert rate == pytest.approx(-dq @ Kd @ dq, abs=1e-5), f"seed {seed}"
    assert ans["damps_every_velocity"] is True
    assert same_rows(ans["equilibria"], [["q1_d", "q2_d"]])


def same_rows(matrix, rows):
    from app.core.compare import same
    return same(rows, matrix)


@pytest.mark.parametrize("seed", range(5))
def test_symbolic_norm_bound_is_above_the_norm_everywhere(seed):
    """alpha of app.core.norm_bounds against the largest ||A(q)|| on a grid (random positive data)."""
    from app.core.norm_bounds import norm_bound
    rng = np.random.default_rng(seed)
    q1, q2 = sp.symbols("q1 q2", real=True)
    a, b, c, e = sp.symbols("a b c e", real=True)
    A = sp.Matrix([[a * sp.cos(q1) + b * q2, c * sp.sin(q1)], [c * sp.sin(q1), e * sp.cos(q1 + q2) - b * q2]])
    vals = {s: float(v) for s, v in zip((a, b, c, e), rng.uniform(0.2, 2.0, 4))}
    lo, hi = 0.2, 1.0
    _B, alpha = norm_bound(A, {q2: (lo, hi)}, [a, b, c, e])
    alpha_v = float(alpha.xreplace(vals))
    An = A.xreplace(vals)
    worst = max(np.linalg.norm(np.array(An.xreplace({q1: x, q2: y}).evalf(), dtype=float), 2)
                for x in np.linspace(-np.pi, np.pi, 25) for y in np.linspace(lo, hi, 5))
    assert worst <= alpha_v + 1e-12, f"seed {seed}: max norm {worst} > alpha {alpha_v}"


@pytest.mark.parametrize("seed", range(6))
def test_closed_form_minimum_over_q_against_a_grid(seed):
    from app.core.definiteness import maximum, minimum
    rng = np.random.default_rng(seed)
    q = sp.Symbol("q", real=True)
    c0, c1 = rng.uniform(-2, 2, 2)
    c2 = -abs(rng.uniform(0, 2)) if seed % 2 else 0.0
    expr = c0 + c1 * sp.cos(q) + c2 * sp.cos(q) ** 2
    xs = np.linspace(-np.pi, np.pi, 2001)
    grid = c0 + c1 * np.cos(xs) + c2 * np.cos(xs) ** 2
    assert float(minimum(expr, [q])) == pytest.approx(min(grid), abs=1e-9), f"seed {seed}"
    sq = sp.sympify(c0) + abs(c1) * (sp.sin(q) + sp.cos(q) - 1) ** 2     # vanishes at q = 0
    assert float(minimum(sq, [q])) == pytest.approx(c0, abs=1e-12)
    if c2 == 0:
        assert float(maximum(expr, [q])) == pytest.approx(max(grid), abs=1e-9)


def test_model_check_of_a_real_robot_is_positive_definite_and_agrees_with_eigenvalues():
    """The planar 2R's own M written as a given matrix: the conditions hold for the file's numbers,
    and the matrix is positive definite on a grid (independent numeric eigenvalues)."""
    robot = load_robot("planar_2r")
    from app.core.dynamics import derive
    M = derive(robot).M
    rows = [[str(e) for e in M.row(i)] for i in range(2)]
    ans = solve(_exercise([{"kind": "model_check", "matrix": rows}], {}, robot="planar_2r")).answers
    values = {sp.Symbol(k, real=True): v for k, v in robot.parameter_values().items()}
    assert all(float(sp.sympify(c).xreplace(values)) > 0 for c in ans["M_conditions"])
    q2 = robot.q[1]
    for x in np.linspace(-np.pi, np.pi, 13):
        Mn = np.array(M.xreplace(values).xreplace({q2: x}).evalf(), dtype=float)
        assert np.linalg.eigvalsh(Mn).min() > 0


@pytest.mark.parametrize("seed", range(5))
def test_acceleration_polygon_vertices_bound_every_reachable_acceleration(seed):
    """Random SPD M, bias and bounds: every sampled q'' with lo <= M q'' + n <= hi lies in the hull
    of the vertices and has a norm not above the largest vertex norm."""
    from scipy.spatial import ConvexHull
    from app.core.torque_polygon import acceleration_polytope
    rng = np.random.default_rng(seed)
    M = _random_spd(rng, 2)
    T = rng.uniform(1, 5, 2)
    nvec = rng.uniform(-6, 6, 2)
    P = acceleration_polytope(M, nvec, -T, T)
    assert P.zero_feasible == bool(np.all(np.abs(nvec) <= T)), f"seed {seed}"
    hull = ConvexHull(P.vertices)
    lo, hi = P.vertices.min(axis=0) - 0.5, P.vertices.max(axis=0) + 0.5
    X = rng.uniform(lo, hi, size=(4000, 2))
    tau = X @ M.T + nvec
    feasible = X[np.all((tau >= -T) & (tau <= T), axis=1)]
    assert len(feasible) > 50, f"seed {seed}"
    inside = feasible @ hull.equations[:, :2].T + hull.equations[:, 2] <= 1e-9
    assert inside.all(), f"seed {seed}"
    assert np.linalg.norm(feasible, axis=1).max() <= P.max_norm + 1e-9, f"seed {seed}"


@pytest.mark.parametrize("seed", range(4))
def test_cell_decomposition_free_cells_avoid_the_c_obstacles_and_astar_is_optimal(seed):
    from app.core import roadmap as rm
    rng = np.random.default_rng(seed)
    obstacles = []
    for _ in range(3):
        x, y = rng.uniform(0, 7, 2)
        w, h = rng.uniform(0.5, 2.5, 2)
        obstacles.append([(x, y), (x + w, y), (x + w, y + h), (x, y + h)])
    robot = [(0, 0), (1, 0), (1, 1), (0, 1)]
    cobs = [rm.c_obstacle(o, robot, (0.5, 0.5)) for o in obstacles]
    cells = rm.quadtree((0, 0, 8), cobs, 0.5)
    pts = rng.uniform(0, 8, size=(3000, 2))
    for c in cells:                                   # sampled interior points of free cells are free
        inside = pts[(pts[:, 0] > c.x) & (pts[:, 0] < c.x + c.size) & (pts[:, 1] > c.y) & (pts[:, 1] < c.y + c.size)]
        for p in inside:                              # strictly inside a (counterclockwise) C-obstacle?
            hit = [poly for poly in cobs if all((b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0]) > 1e-9
                                               for a, b in zip(poly, poly[1:] + poly[:1]))]
            assert not hit, f"seed {seed}: cell {c.number} holds a C-obstacle point {p}"
    area = sum(c.size ** 2 for c in cells)
    assert area <= 64 + 1e-9
    edges = rm.adjacency(cells)
    if len(cells) >= 2:
        s, g = cells[0], cells[-1]
        h = lambda k: float(np.hypot(*(np.subtract(cells[k - 1].center, g.center))))
        L1, _p1, e1 = rm.shortest_path(edges, s.number, g.number)
        L2, _p2, e2 = rm.shortest_path(edges, s.number, g.number, h)
        assert L1 == pytest.approx(L2) or (np.isinf(L1) and np.isinf(L2)), f"seed {seed}"
        assert e2 <= e1


@pytest.mark.parametrize("seed", range(3))
def test_voronoi_roadmap_points_are_equidistant_from_their_two_nearest_obstacles(seed):
    from app.core import roadmap as rm
    rng = np.random.default_rng(seed)
    pts = [tuple(p) for p in rng.uniform([1, 1], [9, 5], size=(4, 2))]
    R = rm.voronoi_roadmap((0, 0, 10, 6), pts, [], 0.05)
    P = R.nodes
    walls = [np.abs(P[:, 0]), np.abs(10 - P[:, 0]), np.abs(P[:, 1]), np.abs(6 - P[:, 1])]
    D = np.sort(np.vstack([np.linalg.norm(P - np.asarray(p), axis=1) for p in pts] + walls), axis=0)
    assert np.all(D[1] - D[0] <= 0.05 + 1e-12), f"seed {seed}"
    assert np.allclose(R.clearance, (D[0] + D[1]) / 2), f"seed {seed}"
