"""The 3D drawing (app/scene.py) and the viewer's helpers that need no browser."""
import math
import threading
import time

import numpy as np
import pytest

from app.core.numeric import NumericModel, ParameterError
from app.core.robot import list_robot_names, load_robot
from app.scene import RobotDrawing, camera_pose, default_q, quaternion_wxyz
from app.viewer import Coalescer, parse_parameter


def world(drawing, part, q, local):
    T = drawing.poses(q)[part.attach]
    return T[:3, :3] @ np.asarray(local, float) + T[:3, 3]


def bars(drawing, body):
    return [p for p in drawing.parts if p.role == "link" and p.body == body]


def test_planar_2r_links_have_their_lengths_and_follow_the_kinematics():
    robot = load_robot("planar_2r")
    drawing = RobotDrawing(robot)
    (b1,), (b2,) = bars(drawing, "link1"), bars(drawing, "link2")
    assert np.linalg.norm(b1.segment[1] - b1.segment[0]) == pytest.approx(1.0)    # l1
    assert np.linalg.norm(b2.segment[1] - b2.segment[0]) == pytest.approx(0.8)    # l2
    num = NumericModel(robot)
    ee, _ = num.named_point("ee")
    rng = np.random.default_rng(1)
    for _ in range(5):
        q = rng.uniform(-3, 3, 2)
        assert np.allclose(world(drawing, b2, q, b2.segment[1]), ee(q))
        assert np.allclose(world(drawing, b1, q, b1.segment[1]), world(drawing, b2, q, b2.segment[0]))


def test_parameters_change_the_drawing():
    robot = load_robot("planar_2r")
    drawing = RobotDrawing(robot, {"l1": 1.5})
    (b1,) = bars(drawing, "link1")
    assert np.linalg.norm(b1.segment[1] - b1.segment[0]) == pytest.approx(1.5)
    assert drawing.poses([0.0, 0.0])["link2"][0, 3] == pytest.approx(1.5)


def test_prismatic_rod_always_passes_through_its_sleeve():
    robot = load_robot("rp_2004_03_25")
    drawing = RobotDrawing(robot)
    sleeve = next(p for p in drawing.parts if p.name == "sleeve")
    (rod,) = bars(drawing, "link2")
    lo, hi = drawing.ranges["q2"]
    for q2 in np.linspace(lo, hi, 7):
        q = [0.4, q2]
        center = world(drawing, sleeve, q, np.zeros(3))
        a, b = (world(drawing, rod, q, e) for e in rod.segment)
        t = np.dot(center - a, b - a) / np.dot(b - a, b - a)
        assert 0.0 < t < 1.0 and np.linalg.norm(a + t * (b - a) - center) < 1e-9


def test_dh_link_with_an_offset_along_the_joint_axis_is_an_l_shape():
    robot = load_robot("viewer_demo_spatial_3r")
    drawing = RobotDrawing(robot)
    link1 = bars(drawing, "link1")
    total = sum(np.linalg.norm(p.segment[1] - p.segment[0]) for p in link1)
    assert total == pytest.approx(robot.parameters["d1"].value)
    link2 = bars(drawing, "link2")
    assert sum(np.linalg.norm(p.segment[1] - p.segment[0]) for p in link2) == pytest.approx(0.6)


def project(position, look_at, up, fov, aspect, points):
    forward = (look_at - position) / np.linalg.norm(look_at - position)
    right = np.cross(forward, up)
    right /= np.linalg.norm(right)
    true_up = np.cross(right, forward)
    rel = np.asarray(points) - position
    depth = rel @ forward
    t = math.tan(fov / 2)
    return np.stack([(rel @ right) / depth / (t * aspect), (rel @ true_up) / depth / t], axis=1)


@pytest.mark.parametrize("name", ["planar_2r", "rp_2004_03_25", "throwing_arm", "viewer_demo_spatial_3r"])
def test_camera_frames_the_robot_and_sees_planar_robots_square_on(name):
    robot = load_robot(name)
    drawing = RobotDrawing(robot)
    fov, aspect = math.radians(28), 16 / 9
    position, look_at, up = camera_pose(drawing.framing(), fov=fov, aspect=aspect, occluded_right=0.3)
    if robot.is_planar:
        direction = (position - look_at) / np.linalg.norm(position - look_at)
        assert np.allclose(direction, [0, 0, 1])
        if np.linalg.norm(np.asarray(robot.gravity.subs({s: 1 for s in robot.gravity.free_symbols}), float)):
            assert np.dot(up, drawing.gravity) < 0      # gravity points down the screen
    q = default_q(robot)
    points = [world(drawing, p, q, e) for p in drawing.parts if p.role == "link" for e in p.segment]
    ndc = project(position, look_at, up, fov, aspect, points)
    assert np.all(np.abs(ndc[:, 1]) < 1.0)
    assert np.all(ndc[:, 0] > -1.0) and np.all(ndc[:, 0] < 1.0 - 2 * 0.3)   # left of the side panel


@pytest.mark.parametrize("name", list_robot_names())
def test_every_shipped_robot_can_be_drawn(name):
    robot = load_robot(name)
    drawing = RobotDrawing(robot)
    q = default_q(robot)
    for n, (lo, hi) in drawing.ranges.items():
        assert lo < hi
    poses = drawing.poses(q)
    assert all(np.all(np.isfinite(T)) for T in poses.values())
    for body in robot.bodies:
        roles = {p.role for p in drawing.parts if p.body == body.name}
        if body.joint.type != "fixed":
            assert "joint" in roles, body.name
    assert drawing.framing(q).radius > 0


def test_quaternion_matches_rotation():
    rng = np.random.default_rng(0)
    for _ in range(20):
        A = np.linalg.qr(rng.normal(size=(3, 3)))[0]
        R = A * np.sign(np.linalg.det(A))
        w, x, y, z = quaternion_wxyz(R)
        back = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                         [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                         [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])
        assert np.allclose(back, R)


@pytest.mark.parametrize("text, ok", [("2.5", 2.5), ("1/4", 0.25), ("pi/2", math.pi / 2), ("-1", None),
                                      ("", None), ("heavy", None), ("1e400", None), ("__import__('os')", None)])
def test_parameter_fields_accept_numbers_only(text, ok):
    robot = load_robot("planar_2r")
    if ok is None:
        with pytest.raises(ParameterError):
            parse_parameter(robot, "m1", text)
    else:
        assert parse_parameter(robot, "m1", text) == pytest.approx(ok)


def test_negative_lengths_are_allowed_but_not_negative_inertias():
    robot = load_robot("planar_2r")
    assert parse_parameter(robot, "d1", "-0.2") == pytest.approx(-0.2, abs=1e-15)
    with pytest.raises(ParameterError):
        parse_parameter(robot, "I1", "-0.2")


def test_coalescer_merges_a_burst_and_ends_with_the_latest_state():
    seen, state = [], {"value": 0}
    done = threading.Event()

    def work():
        seen.append(state["value"])
        time.sleep(0.01)
        if state["value"] == 199:
            done.set()

    job = Coalescer(work)
    for k in range(200):
        state["value"] = k
        job.request()
    assert done.wait(5)
    time.sleep(0.05)
    assert seen[-1] == 199 and len(seen) < 50


def test_the_meshes_are_closed_face_outwards_and_have_their_volumes():
    """app/scene.py makes its meshes itself (no trimesh): every edge is shared by two faces that
    run it in opposite directions (closed, consistently wound), and the enclosed volume is positive
    (faces outwards) and near the solid's."""
    from app.scene import box_mesh, capsule_mesh, cone_mesh, cylinder_mesh, icosphere_mesh
    pi = np.pi
    for mesh, volume in [(capsule_mesh(2.0, 0.5, count=[24, 12]), pi * 0.25 * 2 + 4 / 3 * pi * 0.125),
                         (cylinder_mesh(1.0, 2.0, 32), 2 * pi), (cone_mesh(1.0, 2.0, 24), 2 * pi / 3),
                         (icosphere_mesh(2, 1.0), 4 / 3 * pi), (box_mesh([1.0, 2.0, 3.0]), 6.0)]:
        edges = [(int(a), int(b)) for f in mesh.faces for a, b in ((f[0], f[1]), (f[1], f[2]), (f[2], f[0]))]
        assert len(set(edges)) == len(edges) and set(edges) == {(b, a) for a, b in edges}
        assert mesh.volume == pytest.approx(volume, rel=0.05)


def test_the_drawing_as_a_mesh_file_is_the_drawing_at_that_pose(tmp_path):
    """``export ROBOT --mesh``: every part placed at q, its colour kept, written and read back by trimesh."""
    import trimesh
    drawing = RobotDrawing(load_robot("planar_2r"))
    q = np.array([0.5, 0.3])
    mesh = drawing.mesh_at(q)
    lo, hi = drawing.bounds([q])                      # the framing's (conservative) box holds it
    assert np.all(mesh.bounds[0] >= lo - 1e-9) and np.all(mesh.bounds[1] <= hi + 1e-9)
    link2 = next(p for p in drawing.parts if p.name == "bar0" and p.attach == "link2")
    tip = drawing.poses(q)["link2"] @ np.append(link2.segment[1], 1.0)
    assert np.min(np.linalg.norm(mesh.vertices - tip[:3], axis=1)) < np.ptp(link2.mesh.bounds) / 2
    path = tmp_path / "planar_2r.ply"
    mesh.export(path)
    back = trimesh.load(path, force="mesh", process=False)
    assert len(back.faces) == sum(len(p.mesh.faces) for p in drawing.parts)
    assert {tuple(c[:3]) for c in back.visual.face_colors} >= {tuple(p.color) for p in drawing.parts}
