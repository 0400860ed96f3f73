"""Robot files whose inertia matrix M(q) is singular at their default parameter values are refused
(app/core/mass_check.py, issue 15): a body with its mass on its joint axis and no inertia gave
M = 0 and was accepted (the fuzz run of docs/reliability.md, seed 2026, cases 3043 and 4880)."""
from pathlib import Path

import numpy as np
import pytest

from app.core.mass_check import mass_matrix, singular_directions
from app.core.numeric import NumericModel
from app.core.robot import RobotFileError, list_robot_names, load_robot, load_robot_text
from test_cli import run

ROOT = Path(__file__).resolve().parents[1]
FIXTURES = ROOT / "tests" / "fixtures"

PENDULUM_ON_AXIS = """\
name: on_axis
coordinates: [theta]
parameters:
  m: {value: 2, kind: mass}
  g0: {value: 9.81, kind: gravity}
gravity: [0, -g0, 0]
bodies:
  - name: link
    joint: {type: revolute, axis: z, q: theta}
    mass: m
"""

# a planar 2R arm whose second body has its mass on the second joint's axis and no inertia:
# turning q2 alone moves nothing
SECOND_ON_AXIS = """\
name: second_on_axis
coordinates: [q1, q2]
parameters:
  m1: {value: 1, kind: mass}
  m2: {value: 3, kind: mass}
  l1: {value: 0.5, kind: length}
  I1: {value: 0.1, kind: inertia}
bodies:
  - name: link1
    joint: {type: revolute, axis: z, q: q1}
    mass: m1
    com: [0.25, 0, 0]
    inertia: I1
  - name: link2
    parent: link1
    joint: {type: revolute, axis: z, q: q2, origin: {xyz: [l1, 0, 0]}}
    mass: m2
    com: [0, 0, 0]
    inertia: 0
"""


def test_mass_on_the_joint_axis_is_refused_by_derive_in_one_line(tmp_path):
    path = tmp_path / "on_axis.yaml"
    path.write_text(PENDULUM_ON_AXIS, encoding="utf-8")
    proc = run("derive", str(path), check=False)
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), lines[:3]
    assert "M(q) is singular" in lines[0] and "theta (joint of link)" in lines[0]
    assert proc.stdout == ""


def test_the_fuzz_case_that_found_it_is_refused(tmp_path):
    proc = run("derive", str(FIXTURES / "refused" / "fuzz_2026_case3043_singular_mass.yaml"), check=False)
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "M(q) is singular" in lines[0] and "theta" in lines[0], lines[:3]


def test_the_joint_that_moves_nothing_is_named():
    with pytest.raises(RobotFileError) as info:
        load_robot_text(SECOND_ON_AXIS, "second_on_axis.yaml")
    message = str(info.value)
    assert "q2 (joint of link2)" in message and "q1" not in message.split("moving", 1)[1]
    assert len(message) < 320


def test_an_inertia_about_the_axis_or_a_mass_off_it_makes_the_file_acceptable():
    with_inertia = SECOND_ON_AXIS.replace("    inertia: 0\n", "    inertia: 0.01\n")
    off_axis = SECOND_ON_AXIS.replace("    com: [0, 0, 0]\n", "    com: [0.2, 0, 0]\n")
    for text in (with_inertia, off_axis):
        robot = load_robot_text(text, "fixed.yaml")
        values = {p.symbol: p.value for p in robot.parameters.values()}
        assert singular_directions(robot, values) is None
        assert np.linalg.eigvalsh(mass_matrix(robot, values, [0.4, -1.1])).min() > 1e-4


@pytest.mark.parametrize("name", ["planar_2r", "rp_2004_03_25", "crane_2018_03_27", "throwing_arm", "catching_arm"]
                         + [n for n in list_robot_names() if "elastic" in n][:2])
def test_the_numeric_mass_matrix_equals_the_derived_one(name):
    """The check's M(q), built by walking the chain in numbers, is the symbolic model's M(q)
    (elastic joints with their rotor inertias included)."""
    robot = load_robot(name)
    values = {p.symbol: p.value for p in robot.parameters.values()}
    model = NumericModel(robot)
    rng = np.random.default_rng(7)
    for _ in range(3):
        q = rng.uniform(-1.5, 1.5, robot.n)
        np.testing.assert_allclose(mass_matrix(robot, values, q), model.M(q), rtol=1e-9, atol=1e-12)


def test_every_shipped_robot_and_fixture_passes_the_check():
    paths = [name for name in list_robot_names()] + sorted(str(p) for p in FIXTURES.glob("*.yaml")
                                                            if "bodies:" in p.read_text())
    for path in paths:
        load_robot(path)        # raises RobotFileError when refused
