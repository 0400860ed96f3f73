"""Minimum time along a path: run time and accuracy against the grid size.

For a single link under gravity (kin_pendulum, |tau| <= 20 N m, 0 -> 2 rad) the reference is the
bang-bang motion found by shooting (integrate +U then -U, switch time by root finding); for the
planar 2R arm (torque and velocity bounds, straight joint path) the run time only.

Run: ``python -m benchmarks.time_optimal``.
"""
from __future__ import annotations

import math
import time

import numpy as np

from app.core.numeric import NumericModel
from app.core.robot import load_robot
from app.core.time_optimal import JointPath, minimum_time_along_path, pendulum_bang_bang_shooting


def main():
    num = NumericModel(load_robot("kin_pendulum"))
    U, goal = 20.0, 2.0
    ref, _ = pendulum_bang_bang_shooting(num.M([0.0])[0, 0], num.g([math.pi / 2])[0], U, goal)
    print(f"single link under gravity, shooting reference T = {ref:.9f} s")
    for nodes in (100, 300, 1000, 3000):
        t0 = time.perf_counter()
        res, _ = minimum_time_along_path(JointPath.line([0.0], [goal]), num, torque=([-U], [U]), nodes=nodes)
        dt = time.perf_counter() - t0
        print(f"  {nodes:5d} intervals: T = {res.T:.9f} s, error {res.T - ref:+.2e} s, {dt * 1000:7.1f} ms")
    num2 = NumericModel(load_robot("planar_2r"))
    bounds = np.array([200.0, 60.0])
    for nodes in (300, 1000):
        t0 = time.perf_counter()
        res, _ = minimum_time_along_path(JointPath.line([0.0, 0.0], [1.5, -1.0]), num2, torque=(-bounds, bounds),
                                         velocity=[2.0, 3.0], nodes=nodes)
        dt = time.perf_counter() - t0
        print(f"planar 2R, {nodes} intervals: T = {res.T:.6f} s, {len(res.arcs)} arcs, {dt * 1000:.1f} ms")


if __name__ == "__main__":
    main()
