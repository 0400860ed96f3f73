"""Derivation speed of the engine against sympy.physics.mechanics, and numeric evaluation of
M, C, g against pinocchio, measured in the same process.

Baselines (derivation): ``LagrangesMethod`` on the same robot (same kinematics), alone and followed by
``simplify`` of the mass matrix and the forcing vector (what a user of sympy.physics.mechanics does
to get a readable model). Ours: ``derive`` without the disk cache, which produces M, Christoffel
symbols, C, c, g, the minimal regressor, the adaptive regressor and the steps. Cold means cold:
before every run, of ours and of the baselines alike, our in-memory derivations and displayed
coefficients and sympy's own cache are emptied. CPU time (``time.process_time``) beside wall time;
the median of 3 runs interleaved round by round (ours, plain, simplify; ours, ...).

Run: ``python -m benchmarks.derive``.
"""
from __future__ import annotations

import statistics
import time
from pathlib import Path

import numpy as np
import sympy as sp
from sympy.physics import mechanics as me

from sympy.core.cache import clear_cache

from app.core.dynamics import derive, forget_derivations
from app.core.kinematics import Kinematics
from app.core.numeric import NumericModel, PinocchioTwin
from app.core.robot import load_robot

HERE = Path(__file__).resolve().parent / "robots"
ROBOTS = ["bench_2r", "bench_3r", "bench_spatial_3r"]


def mechanics_baseline(robot, simplify: bool = True) -> None:
    """sympy.physics.mechanics's M and forcing for the robot (simplified when ``simplify``)."""
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
    if simplify:
        sp.simplify(lm.mass_matrix)
        sp.simplify(lm.forcing)


def cold(run) -> tuple:
    """(CPU, wall) seconds of ``run()`` with every memory emptied first: our derivations and
    displayed coefficients (``forget_derivations``) and sympy's own cache, for every contender."""
    forget_derivations()
    clear_cache()
    c0, w0 = time.process_time(), time.perf_counter()
    run()
    return time.process_time() - c0, time.perf_counter() - w0


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


def figures() -> list:
    """(name, wall s, CPU s, None, note, "cpu"): one cold derivation of each benchmark robot beside
    LagrangesMethod alone and + simplify, interleaved (``main``: the median of 3 and the numeric part)."""
    out = []
    for name in ROBOTS:
        robot = load_robot(HERE / f"{name}.yaml")
        c, w = cold(lambda: derive(robot, use_cache=False))
        plain = cold(lambda: mechanics_baseline(robot, simplify=False))[0]
        full = cold(lambda: mechanics_baseline(robot, simplify=True))[0]
        out.append((f"derive {name} (cold, in process)", w, c, None,
                    f"{full / c:.0f}x faster than LagrangesMethod + simplify ({full:.1f} s CPU), "
                    f"{plain / c:.1f}x than LagrangesMethod alone ({plain:.2f} s)", "cpu"))
    return out


def main(repeats: int = 3) -> None:
    print("Derivation, cold: our memories and sympy's cache emptied before every run; CPU seconds (wall "
          "in brackets), median of %d runs interleaved round by round" % repeats)
    print(f"{'robot':<18}{'ours':>16}{'mechanics':>16}{'+ simplify':>16}{'speed-up':>9}{'(plain)':>9}")
    for name in ROBOTS:
        robot = load_robot(HERE / f"{name}.yaml")
        runs = {"ours": [], "plain": [], "simplify": []}
        for _ in range(repeats):
            runs["ours"].append(cold(lambda: derive(robot, use_cache=False)))
            runs["plain"].append(cold(lambda: mechanics_baseline(robot, simplify=False)))
            runs["simplify"].append(cold(lambda: mechanics_baseline(robot, simplify=True)))
        med = {k: (statistics.median(c for c, _ in v), statistics.median(w for _, w in v)) for k, v in runs.items()}
        cells = "".join(f"{f'{c:.2f} ({w:.2f})':>16}" for c, w in med.values())
        print(f"{name:<18}{cells}{med['simplify'][0] / med['ours'][0]:>8.1f}x{med['plain'][0] / med['ours'][0]:>8.1f}x",
              flush=True)
    print("\nNumeric M, C, g per call (microseconds)")
    print(f"{'robot':<18}{'ours':>8}{'pin (mapped)':>14}{'pin raw':>9}{'ours/raw':>10}")
    for name in ROBOTS:
        robot = load_robot(HERE / f"{name}.yaml")
        a, b, c = numeric_ratio(robot)
        print(f"{name:<18}{a:>8.1f}{b:>14.1f}{c:>9.1f}{a / c:>9.1f}x")


if __name__ == "__main__":
    main()
