"""``python -m app export ROBOT --urdf FILE`` / ``--mesh FILE [--q ...]``: a robot written in another format.

URDF (app/core/urdf.py) at the robot file's parameter values; ``-`` writes to standard output.
A robot that URDF cannot express (springs, elastic joints, a joint moved by a map of the
coordinates) is refused with the reason (exit code 2). ``--mesh`` writes the page's drawing of the
robot at ``--q`` (default: the page's start pose) as one coloured mesh through trimesh, in the
format of the file's suffix (.stl, .obj, .ply, .glb ...): for slides, Blender or a 3D printer.
"""
from __future__ import annotations

import sys

NAME = "export"
HELP = "write a robot in another format (URDF, or its drawing as a mesh file)"


def add_arguments(p):
    p.add_argument("robot", help="a shipped robot's name or a path to a robot file")
    p.add_argument("--urdf", metavar="FILE", help="write the robot as URDF to FILE ('-': standard output)")
    p.add_argument("--mesh", metavar="FILE", help="write the drawing as a mesh file (.stl, .obj, .ply, .glb ...)")
    p.add_argument("--q", metavar="Q1,Q2,...", help="--mesh: the coordinates drawn (default: the page's start pose)")


def run(args) -> int:
    from app.core.errors import UserError
    from app.core.robot import load_robot
    from app.core.urdf import to_urdf

    if not (args.urdf or args.mesh):
        raise UserError("export: give --urdf FILE or --mesh FILE")
    robot = load_robot(args.robot)
    if args.mesh:
        _write_mesh(robot, args.mesh, args.q)
        if not args.urdf:
            return 0
    text = to_urdf(robot)
    if args.urdf == "-":
        sys.stdout.write(text)
        return 0
    try:
        with open(args.urdf, "w", encoding="utf-8") as fh:
            fh.write(text)
    except OSError as exc:
        raise UserError(f"--urdf {args.urdf}: {exc.strerror or exc}") from None
    mimic = ", mimic=True" if "<mimic" in text else ""
    print(f"wrote {args.urdf}: pinocchio.buildModelFromUrdf({args.urdf!r}{mimic}) loads it")
    return 0


def _write_mesh(robot, path: str, q_text) -> None:
    from pathlib import Path

    import numpy as np

    from app.core.errors import UserError
    from app.core.expressions import parse_number
    from app.scene import RobotDrawing, default_q

    drawing = RobotDrawing(robot)
    if q_text:
        q = np.array([parse_number(v, "--q") for v in str(q_text).split(",") if v.strip()])
        if q.size != robot.n:
            raise UserError(f"--q: {robot.name} has {robot.n} coordinates, got {q.size}")
    else:
        q = default_q(robot)
    suffix = Path(path).suffix.lower().lstrip(".")
    mesh = drawing.mesh_at(q)
    try:
        mesh.export(path, file_type=suffix or None)
    except (ValueError, KeyError, NotImplementedError) as exc:
        raise UserError(f"--mesh {path}: cannot write this format ({exc})") from None
    except OSError as exc:
        raise UserError(f"--mesh {path}: {exc.strerror or exc}") from None
    print(f"wrote {path}: {len(mesh.faces)} triangles, {len(drawing.parts)} parts, q = "
          f"{', '.join(f'{v:g}' for v in q)}")
