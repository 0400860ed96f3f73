"""Properties of the analysis tasks (app/core/tasks/analysis.py) on the planar robot library."""
import re

import numpy as np
import pytest
import sympy as sp

from app.core.compare import same
from app.core.dynamics import derive
from app.core.exercise import ExerciseError, parse_exercise, solve
from app.core.expressions import symbol
from app.core.robot import list_robot_names, load_robot
from app.core.trig import TrigPoly

LIBRARY = [n for n in list_robot_names() if re.match(r"^([rp]+_\d{4}_\d{2}_\d{2}|planar_\w+)$", n)]


def run(robot, *tasks, given=None):
    return solve(parse_exercise({"id": "t", "robot": robot, "question": "?", "tasks": list(tasks),
                                 "given": given or {}})).answers


@pytest.mark.parametrize("name", LIBRARY)
def test_equilibria_cancel_gravity(name):
    robot = load_robot(name)
    dyn = derive(robot)
    answers = run(name, {"kind": "equilibria"})
    table = answers["equilibria"]
    assert answers["equilibria_count"] == table.rows
    values = {p.symbol: p.value for p in robot.parameters.values()}
    rng = np.random.default_rng(0)
    for i in range(table.rows):
        config = {}
        for j, qj in enumerate(robot.q):
            v = table[i, j].subs(values)
            config[qj] = float(v) if not v.free_symbols else float(rng.uniform(-1, 1))
        residual = (dyn.g + dyn.spring).subs(values).subs(config)
        assert max(abs(float(e)) for e in residual) < 1e-9, f"{name}: g != 0 at {config}"


def test_equilibria_with_a_parameter_inside_trig():
    # gravity scaled by sin(alpha) (inclined plane): alpha is not an unknown angle
    assert same([[0, 0], ["pi", 0]], run("rp_2017_09_21", {"kind": "equilibria"})["equilibria"])


def test_relative_angles_from_absolute_ones_give_the_dh_model():
    ans = run("rrrr_2023_06_12", {"kind": "coordinate_map", "new": ["q1", "q2", "q3", "q4"],
                                  "map": {"q1": "q1", "q2": "q1 + q2", "q3": "q1 + q2 + q3",
                                          "q4": "q1 + q2 + q3 + q4"}})
    rename = {symbol(f"{a}_c{i}"): symbol(f"{b}{i}") for i in range(1, 5) for a, b in (("d", "d"), ("I", "I"))}
    assert same(derive(load_robot("planar_4r")).M, ans["M_new"].xreplace(rename))


def test_cartesian_inertia_gives_back_the_kinetic_energy():
    """J^T M_p J = M exactly: every entry of the difference, over one denominator, has a numerator
    that is zero as a trigonometric polynomial (no simplify, no sampling)."""
    ans = run("rp_2020_09_11", {"kind": "cartesian_inertia", "point": "tip"})
    M = derive(load_robot("rp_2020_09_11")).M
    J, Mp = ans["J"], ans["M_p"]
    for entry in J.T * Mp * J - M:
        numerator, _ = sp.fraction(sp.together(entry))
        assert TrigPoly.from_expr(sp.expand(numerator)).is_zero(), entry


def test_second_factorization_is_a_factorization_but_not_skew():
    ans = run("rp_2018_06_11", {"kind": "factorizations"})
    dyn = derive(load_robot("rp_2018_06_11"))
    assert same(dyn.c, ans["S_alt"] * sp.Matrix(dyn.dq))
    assert ans["skew_S"] is True and ans["skew_S_alt"] is False


def test_gravity_balance_cancels_gravity():
    ans = run("planar_3r", {"kind": "gravity_balance", "solve_for": ["d1", "d2", "d3"]})
    assert same([0, 0, 0], ans["g_balanced"])


@pytest.mark.parametrize("task,message", [
    ({"kind": "point_kinematics", "point": "nowhere"}, "unknown point 'nowhere'"),
    ({"kind": "kinetic_energy_decay", "gamma": "gamma"}, "gamma: a sympy/Python name"),
    ({"kind": "gravity_balance", "solve_for": ["x9"]}, "'x9' is not a parameter"),
    ({"kind": "evaluate", "at": {"q7": 1}}, "not a coordinate"),
    ({"kind": "coordinate_map", "new": ["a", "b"], "map": {"q1": "a", "q2": "a"}}, "singular"),
])
def test_bad_options_are_reported(task, message):
    with pytest.raises(ExerciseError, match=re.escape(message)):
        run("planar_2r", task)
