"""The stable command-line contracts: derive --json on a robot file written from scratch, and
clear errors with exit code 2 on bad input."""
import json
import subprocess
import sys
from pathlib import Path

import pytest
import sympy as sp

ROOT = Path(__file__).resolve().parents[1]


def run(*args, check=True):
    proc = subprocess.run([sys.executable, "-m", "app", *args], cwd=ROOT, capture_output=True, text=True,
                          timeout=300)
    if check:
        assert proc.returncode == 0, proc.stderr
    return proc


# A robot that is not shipped: a planar PR in a horizontal plane whose prismatic axis is tilted by a
# constant angle tilt from the x-axis, followed by a revolute joint; CoM of link 2 at distance d2.
NEW_ROBOT = """
name: tilted_pr
title: Tilted PR (test)
plane: horizontal
coordinates: [q1, q2]
parameters:
  m1: {value: 3, kind: mass}
  m2: {value: 2, kind: mass}
  d2: {value: 0.3, kind: com}
  I2: {value: 0.05, kind: inertia}
  tilt: {value: 0.5, kind: angle}
gravity: [0, 0, 0]
bodies:
  - name: slider
    joint: {type: prismatic, axis: [1, 0, 0], q: q1, origin: {rpy: [0, 0, tilt]}}
    mass: m1
  - name: arm
    joint: {type: revolute, axis: z, q: q2}
    mass: m2
    com: [d2, 0, 0]
    inertia: I2
"""


def test_derive_json_of_a_new_robot_file(tmp_path):
    path = tmp_path / "tilted_pr.yaml"
    path.write_text(NEW_ROBOT)
    out = json.loads(run("derive", str(path), "--json").stdout)
    assert out["q"] == ["q1", "q2"]
    for key in ("q", "params", "M", "C", "g", "Y", "a"):
        assert key in out
    q1, q2, dq1, dq2 = sp.symbols("q1 q2 dq1 dq2")
    m1, m2, d2, I2, tilt = sp.symbols("m1 m2 d2 I2 tilt")
    M = sp.Matrix([[sp.sympify(e) for e in row] for row in out["M"]])
    # By hand: p_c2 = q1 (cos b, sin b) + d2 (cos(b + q2), sin(b + q2)).
    expected_M = sp.Matrix([[m1 + m2, -m2 * d2 * sp.sin(q2)], [-m2 * d2 * sp.sin(q2), I2 + m2 * d2 ** 2]])
    assert sp.simplify(M - expected_M) == sp.zeros(2, 2)
    C = sp.Matrix([[sp.sympify(e) for e in row] for row in out["C"]])
    c = C * sp.Matrix([dq1, dq2])
    assert sp.simplify(c - sp.Matrix([-m2 * d2 * sp.cos(q2) * dq2 ** 2, 0])) == sp.zeros(2, 1)
    assert [sp.sympify(e) for e in out["g"]] == [0, 0]
    # Y a reproduces the model with 3 coefficients (m1 + m2, m2 d2, I2 + m2 d2^2)
    assert len(out["a"]) == 3
    Y = sp.Matrix([[sp.sympify(e) for e in row] for row in out["Y"]])
    a = sp.Matrix([sp.sympify(e) for e in out["a"]])
    ddq = sp.Matrix(sp.symbols("ddq1 ddq2"))
    assert sp.simplify(Y * a - (M * ddq + c)) == sp.zeros(2, 1)


def test_derive_text_output_names_the_robot():
    out = run("derive", "planar_2r").stdout
    assert "M(q)" in out and "planar_2r" in out


def test_unknown_robot_exits_2():
    proc = run("derive", "no_such_robot", check=False)
    assert proc.returncode == 2
    assert "unknown robot 'no_such_robot'" in proc.stderr
    assert "Traceback" not in proc.stderr


def test_malformed_robot_file_exits_2_with_field(tmp_path):
    bad = NEW_ROBOT.replace("mass: m2", "mass: m2 +* 3")
    path = tmp_path / "bad.yaml"
    path.write_text(bad)
    proc = run("derive", str(path), "--json", check=False)
    assert proc.returncode == 2
    assert "bad.yaml" in proc.stderr and "bodies[1] (arm).mass" in proc.stderr and "syntax error" in proc.stderr


def test_eval_attempt_is_refused(tmp_path):
    bad = NEW_ROBOT.replace("mass: m2", "mass: __import__('os').system('echo pwned')")
    path = tmp_path / "evil.yaml"
    path.write_text(bad)
    proc = run("derive", str(path), check=False)
    assert proc.returncode == 2
    assert "pwned" not in proc.stdout
    assert "evil.yaml: bodies[1] (arm).mass: only plain function calls are allowed" in proc.stderr


def test_bad_known_parameter_exits_2():
    proc = run("derive", "planar_2r", "--known", "l1,zz", check=False)
    assert proc.returncode == 2 and "zz" in proc.stderr


def test_names_sympify_cannot_read_back_are_refused(tmp_path):
    bad = NEW_ROBOT.replace("tilt", "gamma")
    path = tmp_path / "gamma.yaml"
    path.write_text(bad)
    proc = run("derive", str(path), "--json", check=False)
    assert proc.returncode == 2
    assert "parameters.gamma: 'gamma' is a sympy/Python name" in proc.stderr


def test_solve_refuses_bad_variants():
    proc = run("solve", "2020-09-11#3", "--set", "m1=-3", check=False)
    assert proc.returncode == 2 and "m1: a mass must not be negative (got -3)" in proc.stderr
    proc = run("solve", "2020-09-11#3", "--set", "zz=1", check=False)
    assert proc.returncode == 2 and "'zz' is neither a given value of the exercise nor a parameter" in proc.stderr
    proc = run("solve", "2020-09-11#3", "--set", "m1=nan", check=False)
    assert proc.returncode == 2 and "m1:" in proc.stderr
    out = json.loads(run("solve", "2020-09-11#3", "--set", "m2=1", "--json").stdout)
    # M11 at q* = (0, 3): I1 + I2 + m1 d1^2 + m2 (l1^2 + q2^2) = 0.25 + 0.875 + 0.75 + 10
    assert out["answers"]["M_at"][0][0] == pytest.approx(11.875)


def test_optimize_json_gives_the_result_and_the_evaluations_spent():
    """``throw --optimize --json`` (a stable contract): the best throw as a throw object, and the
    evaluation count against its budget (a small budget: the search itself is tested in test_throwing)."""
    out = json.loads(run("throw", "--optimize", "--evaluations", "300", "--json").stdout)
    assert out["evaluations"] == 300 and out["evaluation_budget"] == 300 and out["time_capped"] is False
    assert 1 <= out["evaluations_to_best"] <= 300
    result = out["result"]
    assert result["feasible"] is True and result["violations"] == []
    assert result["distance_from_base_thesis"] == pytest.approx(out["distance_from_base"], rel=1e-12)
    assert result["config"] == out["config"]
