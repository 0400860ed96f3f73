"""scalar_bound on random instances against an independent computation: the largest PD gain for
which the torques kp e_i + g_i stay within their bounds (per joint and overall), and the smallest
time scaling of a rest-to-rest cubic under velocity bounds."""
import numpy as np
import sympy as sp

from app.core.exercise import parse_exercise, solve

SEED = 5


def _solve(tasks, given):
    return solve(parse_exercise({"id": "t", "robot": "planar_2r", "question": "?", "given": given,
                                 "tasks": tasks})).answers


def test_largest_gain_keeps_the_torques_within_bounds():
    rng = np.random.default_rng(SEED)
    for trial in range(2):
        e = rng.uniform(-1, 1, 3)
        g = rng.uniform(-2, 2, 3)
        tmax = rng.uniform(5, 10, 3)
        given = {**{f"e{i}": float(e[i]) for i in range(3)}, **{f"g{i}": float(g[i]) for i in range(3)},
                 **{f"U{i}": float(tmax[i]) for i in range(3)}}
        ans = _solve([{"kind": "scalar_bound", "scalar": "kp", "quantities": [f"kp*e{i} + g{i}" for i in range(3)],
                       "bounds": {"max": ["U0", "U1", "U2"]}}], given)
        # independent: kp e + g = +-U, the positive root on the side of the sign of e
        per = [(np.sign(e[i]) * tmax[i] - g[i]) / e[i] for i in range(3)]
        assert abs(ans["kp_value"] - min(per)) < 1e-9, f"seed {SEED}, trial {trial}"
        assert ans["kp_limiting"] == int(np.argmin(per)) + 1, f"seed {SEED}, trial {trial}"
        subs = {sp.Symbol(k, real=True): v for k, v in given.items()}
        vals = [float(sp.N(p.subs(subs))) for p in ans["kp_per_quantity"]]
        np.testing.assert_allclose(vals, per, atol=1e-9, err_msg=f"seed {SEED}, trial {trial}")


def test_smallest_time_scaling_of_a_cubic_under_velocity_bounds():
    # rest-to-rest cubic: peak velocity 3 Delta / (2 T); scaled to k T it must stay below V
    ans = _solve([{"kind": "boundary_polynomial", "duration": "T", "size": 2,
                   "start": {"position": 0, "velocity": 0}, "end": {"position": ["D1", "D2"], "velocity": 0}},
                  {"kind": "scalar_bound", "scalar": "k", "quantities": "q_d_dot", "substitute": {"T": "k*T", "t": "k*T/2"},
                   "bounds": {"max": ["V1", "V2"]}, "find": "smallest"}],
                 {"D1": 1.2, "D2": -0.4, "T": 0.5, "V1": 2.0, "V2": 1.0})
    assert abs(ans["k_value"] - max(1.5 * 1.2 / (2.0 * 0.5), 1.5 * 0.4 / (1.0 * 0.5))) < 1e-9
