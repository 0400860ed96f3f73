"""Robots nobody wrote by hand: random serial chains (planar and spatial, revolute and prismatic
joints, absolute-angle coordinates, off-axis CoMs, numeric, symbolic, nonlinear and point springs,
dampers, friction) go
through the same engine as the shipped ones and must satisfy the same identities."""
import random

import numpy as np
import pytest
import sympy as sp

from app.core.dynamics import derive
from app.core.numeric import compiled_model, cross_check
from app.core.robot import parse_robot
from app.core.trig import TrigPoly


def random_robot(seed: int) -> dict:
    rng = random.Random(seed)
    n = rng.randint(2, 3)
    planar = rng.random() < 0.4
    params, bodies = {"g0": {"value": 9.81, "kind": "gravity"}}, []
    coords = [f"q{i + 1}" for i in range(n)]
    for i in range(n):
        k = i + 1
        jtype = rng.choice(["revolute", "revolute", "prismatic"])
        axis = "z" if planar else rng.choice(["x", "y", "z", "-y", [1, 1, 0]])
        if planar and jtype == "prismatic":
            axis = rng.choice(["x", "y"])
        params[f"m{k}"] = {"value": round(rng.uniform(0.5, 5), 2), "kind": "mass"}
        params[f"a{k}"] = {"value": round(rng.uniform(0.2, 1), 2), "kind": "length"}
        params[f"c{k}x"] = {"value": round(rng.uniform(0.05, 0.5), 2), "kind": "com"}
        com = [f"c{k}x", 0, 0]
        if rng.random() < 0.4:
            params[f"c{k}y"] = {"value": round(rng.uniform(-0.2, 0.2), 2), "kind": "com"}
            com[1] = f"c{k}y"
        if planar:
            params[f"I{k}"] = {"value": round(rng.uniform(0.01, 0.5), 3), "kind": "inertia"}
            inertia = f"I{k}"
        else:
            for ax in "xyz":
                params[f"I{k}{ax}"] = {"value": round(rng.uniform(0.05, 0.5), 3), "kind": "inertia"}
            inertia = [f"I{k}x", f"I{k}y", f"I{k}z"]
        joint = {"type": jtype, "axis": axis, "q": coords[i]}
        if jtype == "revolute" and i > 0 and rng.random() < 0.3:
            joint["q"] = f"{coords[i]} - {coords[i - 1]}"          # absolute angle as coordinate
        if i > 0:
            joint["origin"] = {"xyz": [f"a{k - 1}", 0, 0]}
            if not planar and rng.random() < 0.5:
                joint["origin"]["rpy"] = [rng.choice([0, "pi/2", "-pi/2"]), 0, 0]
        bodies.append({"name": f"l{k}", "joint": joint, "mass": f"m{k}", "com": com, "inertia": inertia})
    data = {"name": f"random{seed}", "coordinates": coords, "parameters": params,
            "gravity": [0, "-g0", 0] if planar else [0, 0, "-g0"], "bodies": bodies}
    if planar:
        data["plane"] = "vertical"
    if rng.random() < 0.4:
        data["springs"] = [{"stiffness": rng.choice([3.0, "m1"]), "expr": coords[-1]}]
    if rng.random() < 0.3:
        params["fv"] = {"value": 0.4, "kind": "friction"}
        data["friction"] = {"viscous": {coords[0]: "fv"}}
    if rng.random() < 0.3:       # a damper between the first and last coordinates
        data["dampers"] = [{"coefficient": rng.choice([0.7, "m1"]), "expr": f"{coords[-1]} - {coords[0]}"}]
    if rng.random() < 0.3:       # a hardening spring and a spring between a point of the last body and the base
        data.setdefault("springs", []).append({"expr": coords[0], "force": "3*delta + m1*delta**3"})
        data["springs"].append({"stiffness": 5, "between": [[f"l{n}", ["a1", 0, 0]], ["base", [0, 0.3, 0.2]]]})
    return data


@pytest.mark.parametrize("seed", range(16))
def test_random_robot_identities(seed):
    robot = parse_robot(random_robot(seed), f"random{seed}")
    dyn = derive(robot, use_cache=False)
    model = compiled_model(robot, dyn)        # derived once: the cross-check and Y below use it
    check = cross_check(model, states=20)
    assert check.ok, check.summary()
    assert dyn.M == dyn.M.T
    par = dyn.parametrization
    lhs = dyn.equations() - par.Y * sp.Matrix(par.a) - par.known_terms
    assert all(TrigPoly.from_expr(e).is_zero() for e in lhs)
    # the coefficients are independent: Y at random states has full column rank
    f = model.regressor()
    rng = np.random.default_rng(seed)
    p = [robot.parameters[k].value for k in robot.parameters]
    Ys = np.vstack([np.asarray(f(*rng.uniform(-1, 1, (3, robot.n)), p), dtype=float) for _ in range(3 * par.count)])
    assert np.linalg.matrix_rank(Ys) == par.count
