"""``python -m app export ROBOT --urdf FILE``: a robot written in another format.

URDF (app/core/urdf.py) at the robot file's parameter values; ``-`` writes to standard output.
A robot that URDF cannot express (springs, elastic joints, a joint moved by a map of the
coordinates) is refused with the reason (exit code 2).
"""
from __future__ import annotations

import sys

NAME = "export"
HELP = "write a robot in another format (URDF)"


def add_arguments(p):
    p.add_argument("robot", help="a shipped robot's name or a path to a robot file")
    p.add_argument("--urdf", required=True, metavar="FILE", help="write the robot as URDF to FILE ('-': standard output)")


def run(args) -> int:
    from app.core.errors import UserError
    from app.core.robot import load_robot
    from app.core.urdf import to_urdf

    robot = load_robot(args.robot)
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
