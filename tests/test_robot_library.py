"""The shipped robot library covers every planar family of the exam collection, and malformed
robot files fail with a message that names the file, the field and the problem."""
import re
from collections import defaultdict

import pytest

from app.core.robot import RobotFileError, list_robot_names, load_robot


def joint_string(robot) -> str:
    """'RP', 'PPRR', ... : the moving joints from the base (fixed joints skipped)."""
    return "".join({"revolute": "R", "prismatic": "P"}[b.joint.type] for b in robot.bodies if b.joint.type != "fixed")


def uses_absolute_angles(robot) -> bool:
    """True when a revolute joint variable is a difference of coordinates (q3 - q2)."""
    return any(b.joint.type == "revolute" and len(b.joint.value.free_symbols) > 1 for b in robot.bodies)


PLANAR = {name: load_robot(name) for name in list_robot_names()}
PLANAR = {name: r for name, r in PLANAR.items() if r.is_planar}
BY_FAMILY = defaultdict(list)
for _name, _robot in PLANAR.items():
    BY_FAMILY[joint_string(_robot)].append(_name)

FAMILIES = {"RP": 5, "PR": 1, "RR": 3, "RRR": 3, "RRRR": 2, "PPR": 3, "PRP": 3, "RPR": 3, "PRR": 3,
            "RRPR": 1, "PPRR": 1}


@pytest.mark.parametrize("family,count", sorted(FAMILIES.items()))
def test_family_is_covered(family, count):
    assert len(BY_FAMILY[family]) >= count, f"{family}: only {BY_FAMILY[family]}"


def test_generic_robots_are_shipped():
    for name, family in (("planar_2r", "RR"), ("planar_3r", "RRR"), ("planar_4r", "RRRR"), ("planar_pr", "PR"),
                         ("planar_ppr", "PPR"), ("planar_rpr", "RPR"), ("planar_prr", "PRR")):
        assert joint_string(PLANAR[name]) == family, name


def test_absolute_angle_robots():
    absolute = {joint_string(PLANAR[n]) for n in PLANAR if uses_absolute_angles(PLANAR[n])}
    assert {"RRR", "RRRR"} <= absolute
    assert not uses_absolute_angles(PLANAR["planar_4r"])


def test_exam_robots_are_named_after_their_exam():
    for name, robot in PLANAR.items():
        if name.startswith("planar_"):
            continue
        m = re.match(r"^([rp]+)_(\d{4})_(\d{2})_(\d{2})$", name)
        if m is None or robot.group != "exam":
            continue
        family = m.group(1).upper()
        assert joint_string(robot) == family, f"{name} has joints {joint_string(robot)}"


def test_2p2r_has_viscous_friction_on_every_joint():
    robot = PLANAR["pprr_2018_04_26"]
    assert set(robot.viscous) == set(robot.coordinates)


def test_every_parameter_has_a_kind_and_a_unit():
    mine = [n for n in PLANAR if re.match(r"^([rp]+_\d{4}_\d{2}_\d{2}|planar_\w+)$", n)]
    assert len(mine) >= 25
    for name in mine:
        robot = PLANAR[name]
        for p in robot.parameters.values():
            assert p.kind != "other" and p.unit, f"{name}: parameter {p.name} needs a kind and a unit"


# ---------------------------------------------------------------------- malformed files
GOOD = """\
name: broken
plane: vertical
coordinates: [q1, q2]
parameters:
  m1: {value: 2, kind: mass, unit: kg}
  m2: {value: 1, kind: mass, unit: kg}
  l1: {value: 0.5, kind: length, unit: m}
  g0: {value: 9.81, kind: gravity, unit: m/s^2}
gravity: [0, -g0, 0]
bodies:
  - name: link1
    joint: {type: revolute, axis: z, q: q1}
    mass: m1
    com: [l1/2, 0, 0]
  - name: link2
    joint: {type: prismatic, axis: x, q: q2, origin: [l1, 0, 0]}
    mass: m2
"""

BROKEN = {
    "unknown parameter": (("com: [l1/2, 0, 0]", "com: [l3/2, 0, 0]"), ["bodies[0] (link1).com", "unknown name 'l3'"]),
    "negative mass": (("m1: {value: 2,", "m1: {value: -2,"), ["parameters.m1.value", "must not be negative"]),
    "bad axis": (("axis: x", "axis: w"), ["bodies[1] (link2).joint.axis", "unknown axis"]),
    "missing coordinate": (("q: q2,", "q: q3,"), ["bodies[1] (link2).joint.q", "unknown name 'q3'"]),
    "import attempt": (("mass: m2", "mass: __import__('os').system('true')"), ["bodies[1] (link2).mass", "__import__"]),
    "yaml syntax": (("bodies:", "bodies: [unclosed"), ["not valid YAML"]),
    # issue 15: bodies' physics checked at the default values, hostile expressions refused at once
    "negative body mass": (("mass: m2", "mass: -1"), ["bodies[1] (link2).mass", "must not be negative", "-1"]),
    "negative mass expression": (("mass: m2", "mass: -(m2)"), ["bodies[1] (link2).mass", "must not be negative"]),
    "indefinite inertia": (("com: [l1/2, 0, 0]", "com: [l1/2, 0, 0]\n    inertia: [[1, 2, 0], [2, 1, 0], [0, 0, 1]]"),
                           ["bodies[0] (link1).inertia", "positive semi-definite"]),
    "negative friction": (("gravity: [0, -g0, 0]", "gravity: [0, -g0, 0]\nfriction: {viscous: {q1: -0.5}}"),
                          ["friction.viscous.q1", "must not be negative"]),
    "full-width name in an expression": (("mass: m2", "mass: \uff4d2"), ["bodies[1] (link2).mass", "non-ASCII"]),
    "full-width parameter name": (("m1: {value: 2,", "\uff4d1: {value: 2,"), ["ASCII identifier"]),
    "revolute joint variable sin(q1)": (("q: q1}", "q: \"sin(q1)\"}"), ["bodies[0] (link1).joint.q", "integer multiples"]),
    "prismatic joint variable sin(q2)": (("q: q2,", "q: \"sin(q2)\","), ["bodies[1] (link2).joint.q", "polynomial"]),
    "power tower": (("mass: m2", "mass: ((((9**64)**64)**64)**64)"), ["bodies[1] (link2).mass", "too large"]),
    "nested symbolic power": (("mass: m2", "mass: ((m1+m2)**64+l1)**64"), ["bodies[1] (link2).mass", "too large"]),
    "complex mass": (("mass: m2", "mass: sqrt(-1)"), ["bodies[1] (link2).mass", "real, finite"]),
    "alias bomb": (("name: broken\n", "BOMB"), ["not valid YAML", "aliases"]),
    "damper on a nonlinear stretch": (("gravity: [0, -g0, 0]", "gravity: [0, -g0, 0]\ndampers: [{coefficient: 1, expr: q1**2}]"),
                                      ["dampers[0].expr", "affine"]),
    "negative damper": (("gravity: [0, -g0, 0]", "gravity: [0, -g0, 0]\ndampers: [{coefficient: -1, expr: q2 - q1}]"),
                        ["dampers[0].coefficient", "must not be negative"]),
    "preloaded nonlinear force": (("gravity: [0, -g0, 0]", "gravity: [0, -g0, 0]\nsprings: [{expr: q2, force: 1 + delta}]"),
                                  ["springs[0].force", "vanish at delta = 0"]),
}
BOMB = "a: &a [x, x, x, x]\n" + "".join(f"{chr(98 + i)}: &{chr(98 + i)} [*{chr(97 + i)}, *{chr(97 + i)}, *{chr(97 + i)}]\n"
                                         for i in range(10))


def test_the_template_is_valid(tmp_path):
    path = tmp_path / "ok.yaml"
    path.write_text(GOOD)
    assert joint_string(load_robot(str(path))) == "RP"


@pytest.mark.parametrize("case", sorted(BROKEN))
def test_malformed_file_is_reported(tmp_path, case):
    (old, new), fragments = BROKEN[case]
    assert old in GOOD
    path = tmp_path / f"{case.replace(' ', '_')}.yaml"
    text = GOOD.replace(old, new if new != "BOMB" else BOMB + old, 1)
    path.write_text(text, encoding="utf-8")
    with pytest.raises(RobotFileError) as err:
        load_robot(str(path))
    message = str(err.value)
    assert str(path) in message
    for fragment in fragments:
        assert fragment in message, f"{case}: {message!r} lacks {fragment!r}"


def test_coordinate_that_moves_nothing_is_reported(tmp_path):
    path = tmp_path / "extra.yaml"
    path.write_text(GOOD.replace("coordinates: [q1, q2]", "coordinates: [q1, q2, q3]"))
    with pytest.raises(RobotFileError, match=r"coordinates: coordinate\(s\) \['q3'\] move no joint"):
        load_robot(str(path))


def test_not_a_robot_file_is_refused_in_one_line(tmp_path):
    for target, fragment in ((tmp_path, "not a regular file"), ("/dev/zero", "not a regular file"), ("", "empty robot name")):
        with pytest.raises(RobotFileError, match=fragment) as err:
            load_robot(target)
        assert "\n" not in str(err.value)
    big = tmp_path / "big.yaml"
    big.write_text("notes: " + "x" * 1_100_000)
    with pytest.raises(RobotFileError, match="larger than"):
        load_robot(big)
