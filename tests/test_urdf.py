"""URDF out and in (app/core/urdf.py, `python -m app export ROBOT --urdf FILE`).

Out: pinocchio loads the URDF of every shipped robot that URDF can express, and its M, nle and g
equal the symbolic model at 50 random states. In: a URDF written by hand here and URDFs the lab
writes load like robot files (derive, check), with parameters named after the links, and give
the model pinocchio computes from the same text."""
import json

import numpy as np
import pinocchio as pin
import pytest
import sympy as sp

from app.cli import main
from app.core.dynamics import derive
from app.core.expressions import symbol
from app.core.numeric import NumericModel, cross_check, random_state
from app.core.robot import list_robot_names, load_robot
from app.core.urdf import (MAX_URDF_CHARS, UrdfError, robot_data_from_urdf, to_urdf, urdf_gravity,
                           urdf_refusal)

SHIPPED = list_robot_names()
EXPORTABLE = [name for name in SHIPPED if urdf_refusal(load_robot(name)) is None]
SEED = 18


def pinocchio_terms(model, data, coordinates, q, dq, renamed):
    """M, nle, g of a pinocchio model whose moving joints are named after the coordinates (or
    ``renamed[joint]``; mimic joints carry no velocity), reordered to the robot's coordinates."""
    qp, vp = np.zeros(model.nq), np.zeros(model.nv)
    order = np.zeros(model.nv, dtype=int)
    for j in range(1, model.njoints):
        joint = model.joints[j]
        if joint.nv == 0:
            continue
        k = coordinates.index(renamed.get(model.names[j], model.names[j]))
        if joint.nq == 2:                         # continuous joint: (cos, sin)
            qp[joint.idx_q:joint.idx_q + 2] = np.cos(q[k]), np.sin(q[k])
        else:
            qp[joint.idx_q] = q[k]
        vp[joint.idx_v] = dq[k]
        order[joint.idx_v] = k
    M = pin.crba(model, data, qp)
    M = np.triu(M) + np.triu(M, 1).T
    back = np.argsort(order)
    return (M[np.ix_(back, back)], pin.nonLinearEffects(model, data, qp, vp)[back],
            pin.computeGeneralizedGravity(model, data, qp)[back])


def assert_pinocchio_agrees(model, num: NumericModel, rng, states=50, tolerance=1e-9, renamed=None):
    data = model.createData()
    coordinates = list(num.robot.coordinates)
    for _ in range(states):
        q, dq = random_state(num.robot, rng)
        M, nle, g = pinocchio_terms(model, data, coordinates, q, dq, renamed or {})
        for label, ours, theirs in (("M", num.M(q), M), ("nle", num.c(q, dq) + num.g(q), nle), ("g", num.g(q), g)):
            scale = max(1.0, float(np.max(np.abs(theirs))))
            error = float(np.max(np.abs(ours - theirs))) / scale
            assert error < tolerance, f"{num.robot.name}: {label} differs by {error:.1e} at q={q}, dq={dq}"


def test_most_shipped_robots_are_exportable():
    assert len(EXPORTABLE) >= 55, f"only {len(EXPORTABLE)} of {len(SHIPPED)} robots export to URDF"


@pytest.mark.parametrize("name", EXPORTABLE)
def test_pinocchio_loads_the_urdf_and_agrees_with_the_symbolic_model(name):
    robot = load_robot(name)
    model = pin.buildModelFromXML(to_urdf(robot), mimic=True)
    model.gravity.linear = urdf_gravity(robot)
    assert model.nv == robot.n
    assert_pinocchio_agrees(model, NumericModel(robot), np.random.default_rng(SEED))


def test_parameter_values_are_written():
    robot = load_robot("planar_2r")
    heavier = pin.buildModelFromXML(to_urdf(robot, {"m2": 9.0}))
    assert_pinocchio_agrees(heavier, NumericModel(robot, {"m2": 9.0}), np.random.default_rng(SEED), states=5)


@pytest.mark.parametrize("name,reason", [
    ("throwing_arm", "the spring 'wrist' on q3 (URDF has no springs)"),
    ("elastic_2r", "elastic joints: the motor coordinate(s) theta1, theta2 move no link"),
    ("kin_planar_3r_absolute", "link2 moves by -q1 + q2, a map of several coordinates"),
    ("two_masses_spring", "the spring 'contact'"),
])
def test_what_urdf_cannot_express_is_refused_with_the_reason(name, reason, tmp_path, capsys):
    assert reason in urdf_refusal(load_robot(name))
    target = tmp_path / "out.urdf"
    assert main(["export", name, "--urdf", str(target)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("error: ") and reason in err
    assert not target.exists()


def test_export_command_writes_a_file_pinocchio_reads(tmp_path, capsys):
    target = tmp_path / "governor.urdf"
    assert main(["export", "governor_2018_01_11", "--urdf", str(target)]) == 0
    assert "mimic=True" in capsys.readouterr().out       # phi moves both balls' arms: one mimic joint
    model = pin.buildModelFromUrdf(str(target), mimic=True)
    assert (model.nq, model.nv) == (3, 2)                # theta continuous (cos, sin), phi


# ---------------------------------------------------------------------- in
# Written by hand: a massive mount on a fixed joint under a massless world link, a revolute
# shoulder with limits and damping, a link whose inertia frame is rotated, a prismatic slide
# rolled by pi/2, a wrist about a skew axis, a product of inertia, a massless tool frame.
HAND_WRITTEN = """<?xml version="1.0"?>
<robot name="hand_written">
  <link name="world"/>
  <joint name="mount" type="fixed">
    <parent link="world"/><child link="base_link"/><origin xyz="0 0 0.1"/>
  </joint>
  <link name="base_link">
    <inertial><mass value="5"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <joint name="shoulder" type="revolute">
    <parent link="base_link"/><child link="upper-arm"/>
    <origin xyz="0 0 0.3"/><axis xyz="0 0 1"/>
    <limit lower="-2" upper="2" effort="40" velocity="3"/>
    <dynamics damping="0.2"/>
  </joint>
  <link name="upper-arm">
    <inertial>
      <origin xyz="0.2 0 0" rpy="0 0 0.5"/><mass value="2"/>
      <inertia ixx="0.01" iyy="0.05" izz="0.06" ixy="0" ixz="0" iyz="0"/>
    </inertial>
  </link>
  <joint name="slide" type="prismatic">
    <parent link="upper-arm"/><child link="forearm"/>
    <origin xyz="0.4 0 0" rpy="1.5707963267948966 0 0"/><axis xyz="1 0 0"/>
    <limit lower="0" upper="0.3" effort="100" velocity="1"/>
  </joint>
  <link name="forearm">
    <inertial>
      <origin xyz="0.1 0 0"/><mass value="1"/>
      <inertia ixx="0.001" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/>
    </inertial>
  </link>
  <joint name="wrist" type="continuous">
    <parent link="forearm"/><child link="hand"/><origin xyz="0.2 0 0"/><axis xyz="0 0.6 0.8"/>
  </joint>
  <link name="hand">
    <inertial><mass value="0.5"/><inertia ixx="0.002" iyy="0.002" izz="0.001" ixy="0.0001" ixz="0" iyz="0"/></inertial>
  </link>
  <joint name="tool_joint" type="fixed">
    <parent link="hand"/><child link="tool"/><origin xyz="0 0 0.05"/>
  </joint>
  <link name="tool"/>
</robot>
"""


@pytest.fixture(scope="module")
def hand_written(tmp_path_factory):
    path = tmp_path_factory.mktemp("urdf") / "hand_written.urdf"
    path.write_text(HAND_WRITTEN)
    return path


def test_a_hand_written_urdf_reads_as_a_robot(hand_written):
    """Costs about 3 s of CPU: the symbolic model of a spatial 3-DOF arm with full inertia tensors."""
    robot = load_robot(hand_written)
    assert robot.coordinates == ("q1", "q2", "q3")
    assert [b.name for b in robot.bodies] == ["base_link", "upper_arm", "forearm", "hand"]   # link upper-arm
    assert [b.joint.type for b in robot.bodies] == ["fixed", "revolute", "prismatic", "revolute"]
    for name, value in (("m_upper_arm", 2.0), ("l_forearm_x", 0.4), ("c_upper_arm_x", 0.2),
                        ("I_hand_xy", 0.0001), ("fv_upper_arm", 0.2), ("l_upper_arm_z", 0.3)):
        assert robot.parameters[name].value == pytest.approx(value, rel=1e-12)
    assert robot.points["tool"].body == "hand"
    assert robot.limits["q1"].position == pytest.approx((-2.0, 2.0)) and robot.limits["q1"].torque == pytest.approx(40.0)
    assert "q3" not in robot.limits                       # continuous: no limits
    dyn = derive(robot)
    # By hand: the slide is horizontal (the shoulder turns about the vertical, the roll keeps the
    # slide's x axis): it carries the forearm and the hand, and gravity does no work along it.
    assert sp.expand(dyn.M[1, 1] - symbol("m_forearm") - symbol("m_hand")) == 0
    assert dyn.g[1] == 0 and dyn.g[0] == 0
    assert dyn.friction[0] == symbol("fv_upper_arm") * symbol("dq1")
    # pinocchio reading the same text gives the same model
    assert_pinocchio_agrees(pin.buildModelFromXML(HAND_WRITTEN), NumericModel(robot, dynamics=dyn),
                            np.random.default_rng(SEED), renamed={"shoulder": "q1", "slide": "q2", "wrist": "q3"})
    assert robot.notes[0] == "q1: the revolute joint 'shoulder'"


def test_derive_and_check_accept_a_urdf_file(hand_written, capsys):
    assert main(["derive", str(hand_written), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["q"] == ["q1", "q2", "q3"] and "m_forearm" in out["params"]
    assert main(["check", str(hand_written), "--states", "10"]) == 0
    assert "-> OK" in capsys.readouterr().out


@pytest.mark.parametrize("name", ["rp_2004_03_25", "governor_2018_01_11"])
def test_a_urdf_the_lab_writes_reads_back_to_the_same_model(name, tmp_path):
    """RP: gravity along +x (a rotated world link); the governor: a mimic joint."""
    original = load_robot(name)
    path = tmp_path / f"{name}.urdf"
    path.write_text(to_urdf(original))
    robot = load_robot(path)
    assert robot.n == original.n
    assert all(p.startswith(("m_", "c_", "I_", "l_", "fv_", "fc_", "g0")) for p in robot.parameters)
    assert cross_check(robot, states=20, seed=SEED).ok
    ours, theirs = NumericModel(robot), NumericModel(original)
    rng = np.random.default_rng(SEED)
    for _ in range(20):
        q, dq = random_state(original, rng)
        np.testing.assert_allclose(ours.M(q), theirs.M(q), rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(ours.c(q, dq) + ours.g(q), theirs.c(q, dq) + theirs.g(q), rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("text,message", [
    ('<!DOCTYPE r [<!ENTITY a "aaaaaaaaaa"><!ENTITY b "&a;&a;&a;&a;">]><robot name="x">&b;</robot>',
     "must not declare a DOCTYPE or entities"),
    ('<robot name="x"><link name="a"/><link name="b"/></robot>', "expected one root link"),
    ('<robot name="x"><link name="a"/><link name="b"/><joint name="j" type="floating">'
     '<parent link="a"/><child link="b"/></joint></robot>', "a floating joint cannot be read"),
    ('<robot name="x"><link name="a"/><joint name="j" type="revolute"><parent link="a"/>'
     '<child link="c"/></joint></robot>', "names the unknown link 'c'"),
    ('<robot name="x"><link name="a"/><link name="b"><inertial><mass value="-1"/></inertial></link>'
     '<joint name="j" type="revolute"><parent link="a"/><child link="b"/></joint></robot>', "must not be negative"),
    ('<robot name="x"><link name="a"/><link name="b"/><joint name="j" type="fixed">'
     '<parent link="a"/><child link="b"/></joint></robot>', "nothing moves"),
    ("<robot name='x'><link name='a'></robot>", "not valid XML"),
    ("<sdf version='1.6'/>", "not <robot>"),
])
def test_a_bad_urdf_is_refused_in_one_line(text, message):
    with pytest.raises(UrdfError, match=message):
        robot_data_from_urdf(text, "bad.urdf")


def test_an_oversized_urdf_is_refused_before_parsing():
    text = "<robot name='x'>" + " " * MAX_URDF_CHARS + "</robot>"
    with pytest.raises(UrdfError, match="characters, more than"):
        robot_data_from_urdf(text, "big.urdf")


def test_the_page_opens_a_urdf_file(lab, browser, tmp_path):
    """About 10 s (a browser tab): the page starts on a URDF file (`serve --robot FILE`), and "Open a
    robot file" in the Robot tab loads another one; the Model tab typesets its model, parameters
    named after the links."""
    from app.viewer import screenshot as shots
    path, first = tmp_path / "arm.urdf", tmp_path / "first.urdf"
    path.write_text(to_urdf(load_robot("planar_2r")), encoding="utf-8")
    first.write_text(to_urdf(load_robot("planar_pr")), encoding="utf-8")
    page, session = shots.open_tab(lab, browser, str(first), tab="Robot")
    try:
        assert session.robot_name == str(first) and session.robot.bodies[0].joint.type == "prismatic"
        with page.expect_file_chooser() as chooser:
            page.get_by_role("button", name="Open a robot file").click()
        chooser.value.set_files(str(path))
        shots.wait_until(lambda: session.robot.source.endswith("arm.urdf") and session.numeric is not None,
                         what="the URDF robot loaded")
        shots.wait_ready(page, session.robot_name)
        assert session.robot.coordinates == ("q1", "q2") and "m_link2" in session.robot.parameters
        shots.select_tab(page, "Model")
        page.wait_for_selector(".r2-math math", state="visible")
        M = session.numeric.M(session.q)
        assert np.allclose(M, NumericModel(load_robot("planar_2r")).M(session.q), atol=1e-12)
    finally:
        shots.close_tab(page)
