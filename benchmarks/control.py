"""Real-time factor of closed-loop simulation: computed torque at 1 kHz (zero-order hold, one RK4
step of the plant per period, a sinusoidal reference) on the planar 2R, the planar 3R and the
throwing arm (all three joints actuated for this benchmark; its wrist spring stays in the plant).

Measured in the same process, interleaved, best of several repetitions (the machine may be shared):
- ``simulate``: app.core.sim.simulate, the loop only (set-up excluded) and the whole call;
- ``symbolic``: the same with the lambdified sympy model instead of pinocchio (``backend="symbolic"``);
- ``plain``: the baseline, a bare Python loop around ``pinocchio.rnea`` (the control law) and
  ``pinocchio.aba`` (RK4) with the same gains, reference and spring: what one would write by hand.
The two pinocchio loops must give the same trajectory (checked).

Run: ``python -m benchmarks.control``.
"""
from __future__ import annotations

import time

import numpy as np

from app.core.numeric import ModelTerms, PinocchioTwin
from app.core.robot import load_robot
from app.core.sim import simulate
from app.core.trajectories import parse_reference

ROBOTS = ["planar_2r", "planar_3r", "throwing_arm"]
DURATION = 1.0
RATE = 1000.0
REFERENCE = "sine amplitude=0.3 f=0.5"
KP, KD = 100.0, 20.0
REPEATS = 12


def plain_loop(robot, q0):
    """The baseline: computed torque with rnea, RK4 with aba, minimal Python. Returns (q, seconds)."""
    import pinocchio as pin
    terms = ModelTerms(robot)
    model = PinocchioTwin(robot, terms.values).model
    data = model.createData()
    n = robot.n
    spring = terms.spring
    ref = parse_reference(REFERENCE, q0)
    N = int(DURATION * RATE)
    t = np.arange(N + 1) / RATE
    QD, DQD, DDQD = ref.sample(t)
    h = 1.0 / RATE
    h2, h6 = h / 2, h / 6
    aba, rnea = pin.aba, pin.rnea
    q, dq = q0.copy(), np.zeros(n)
    start = time.perf_counter()
    for k in range(N):
        tau = rnea(model, data, q, dq, DDQD[k] + KD * (DQD[k] - dq) + KP * (QD[k] - q)) + spring(q)
        a1 = aba(model, data, q, dq, tau - spring(q))
        q2, v2 = q + h2 * dq, dq + h2 * a1
        a2 = aba(model, data, q2, v2, tau - spring(q2))
        q3, v3 = q + h2 * v2, dq + h2 * a2
        a3 = aba(model, data, q3, v3, tau - spring(q3))
        q4, v4 = q + h * v3, dq + h * a3
        a4 = aba(model, data, q4, v4, tau - spring(q4))
        q = q + h6 * (dq + 2.0 * (v2 + v3) + v4)
        dq = dq + h6 * (a1 + 2.0 * (a2 + a3) + a4)
    return q, time.perf_counter() - start


def run_ours(robot, q0, backend="auto"):
    t0 = time.perf_counter()
    res = simulate(robot, "computed_torque", reference=REFERENCE, q0=q0, duration=DURATION, rate=RATE,
                   gains={"Kp": KP, "Kd": KD}, passive=[], backend=backend)
    total = time.perf_counter() - t0
    assert res.completed, res.message
    return res, res.loop_time, total


def measure(name):
    robot = load_robot(name)
    q0 = np.array([robot.defaults.get(c, 0.0) for c in robot.coordinates])
    run_ours(robot, q0)                        # warm caches (derivation, lambdify, pinocchio model)
    run_ours(robot, q0, "symbolic")
    best = {"loop": np.inf, "total": np.inf, "symbolic": np.inf, "plain": np.inf}
    for _ in range(REPEATS):
        res, loop, total = run_ours(robot, q0)
        q_plain, plain = plain_loop(robot, q0)
        _, sym, _ = run_ours(robot, q0, "symbolic")
        best["loop"] = min(best["loop"], loop)
        best["total"] = min(best["total"], total)
        best["plain"] = min(best["plain"], plain)
        best["symbolic"] = min(best["symbolic"], sym)
        assert np.allclose(res.q[-1], q_plain, atol=1e-9), (res.q[-1], q_plain)
    return {key: DURATION / value for key, value in best.items()}


def main():
    print(f"computed torque, {RATE:g} Hz, RK4, {DURATION:g} s simulated; real-time factor = simulated / wall time "
          f"(best of {REPEATS})\n")
    print("| robot | joints | simulate (loop) | simulate (whole call) | symbolic backend (loop) | plain pinocchio loop | simulate / plain |")
    print("|---|---|---|---|---|---|---|")
    for name in ROBOTS:
        r = measure(name)
        n = load_robot(name).n
        print(f"| {name} | {n} | {r['loop']:.0f}x | {r['total']:.0f}x | {r['symbolic']:.0f}x | {r['plain']:.0f}x | "
              f"{r['loop'] / r['plain']:.2f} |", flush=True)


if __name__ == "__main__":
    main()
