"""Derivation speed of the engine against sympy.physics.mechanics, and numeric evaluation of
M, C, g against pinocchio, measured in the same process.

Baseline (derivation): ``LagrangesMethod`` on the same robot (same kinematics), then
``simplify`` of the mass matrix and the forcing vector: what a user of sympy.physics.mechanics
does to get a readable model. Ours: ``derive`` cold (no cache), which produces M, Christoffel
symbols, C, c, g, the minimal regressor, the adaptive regressor and the steps.

Run: ``python -m benchmarks.derive``.
"""
from __future__ import annotations

import statistics
import time
from pathlib import Path

import numpy as np
import sympy as sp
from sympy.physics import mechanics as me

from app.core.dynamics import derive
from app.core.kinematics import Kinematics
from app.core.numeric import NumericModel, PinocchioTwin
from app.core.robot import load_robot

HERE = Path(__file__).resolve().parent / "robots"
ROBOTS = ["bench_2r", "bench_3r", "bench_spatial_3r"]


def mechanics_baseline(robot) -> float:
    """Seconds for sympy.physics.mechanics to give simplified M and forcing for the robot."""
    t0 = time.perf_counter()
    kin = Kinematics(robot)
    qs = me.dynamicsymbols(" ".join(robot.coordinates))
    qs = qs if isinstance(qs, (list, tuple)) else [qs]
    to_t = dict(zip(robot.q, qs))
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    bodies = []
    potential = 0
    t = me.dynamicsymbols._t
    for i, body in enumerate(robot.bodies):
        R = kin.rotation(body.name).xreplace(to_t)
        B = me.ReferenceFrame(f"B{i}")
        B.orient_explicit(N, R)          # B's axes expressed in N
        pc = kin.com_position(body.name).xreplace(to_t)
        P = me.Point(f"P{i}")
        P.set_pos(O, pc[0] * N.x + pc[1] * N.y + pc[2] * N.z)
        P.set_vel(N, P.pos_from(O).dt(N))
        I = body.inertia
        dyad = me.inertia(B, I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[1, 2], I[0, 2])
        rb = me.RigidBody(f"body{i}", P, B, body.mass, (dyad, P))
        g = robot.gravity
        rb.potential_energy = -body.mass * (g[0] * pc[0] + g[1] * pc[1] + g[2] * pc[2])
        bodies.append(rb)
    L = me.Lagrangian(N, *bodies)
    lm = me.LagrangesMethod(L, qs)
    lm.form_lagranges_equations()
    sp.simplify(lm.mass_matrix)
    sp.simplify(lm.forcing)
    return time.perf_counter() - t0


def ours(robot) -> float:
    t0 = time.perf_counter()
    derive(robot, use_cache=False)
    return time.perf_counter() - t0


def numeric_ratio(robot, calls: int = 20000):
    """Per-call time (us) of our lambdified M + C q' + g against pinocchio crba + nle + gravity."""
    num = NumericModel(robot)
    twin = PinocchioTwin(robot, num.values)
    rng = np.random.default_rng(0)
    q, dq = rng.uniform(-1, 1, robot.n), rng.uniform(-1, 1, robot.n)
    num.M(q), num.C(q, dq), num.g(q)
    t0 = time.perf_counter()
    for _ in range(calls):
        num.M(q); num.C(q, dq); num.g(q)
    t_ours = (time.perf_counter() - t0) / calls * 1e6
    t0 = time.perf_counter()
    for _ in range(calls):
        twin.terms(q, dq)
    t_pin = (time.perf_counter() - t0) / calls * 1e6
    import pinocchio as pin
    th = np.asarray(twin._theta(q), dtype=float).reshape(-1)
    t0 = time.perf_counter()
    for _ in range(calls):
        pin.crba(twin.model, twin.data, th)
        pin.nonLinearEffects(twin.model, twin.data, th, dq)
        pin.computeGeneralizedGravity(twin.model, twin.data, th)
    t_raw = (time.perf_counter() - t0) / calls * 1e6
    return t_ours, t_pin, t_raw


def main(repeats: int = 3) -> None:
    print("Derivation, cold (seconds; median of %d)" % repeats)
    print(f"{'robot':<18}{'ours':>8}{'sympy.mechanics':>17}{'speed-up':>10}")
    for name in ROBOTS:
        robot = load_robot(HERE / f"{name}.yaml")
        t_ours = statistics.median(ours(robot) for _ in range(repeats))
        t_base = statistics.median(mechanics_baseline(robot) for _ in range(repeats))
        print(f"{name:<18}{t_ours:>8.2f}{t_base:>17.2f}{t_base / t_ours:>9.1f}x")
    print("\nNumeric M, C, g per call (microseconds)")
    print(f"{'robot':<18}{'ours':>8}{'pin (mapped)':>14}{'pin raw':>9}{'ours/raw':>10}")
    for name in ROBOTS:
        robot = load_robot(HERE / f"{name}.yaml")
        a, b, c = numeric_ratio(robot)
        print(f"{name:<18}{a:>8.1f}{b:>14.1f}{c:>9.1f}{a / c:>9.1f}x")


if __name__ == "__main__":
    main()
