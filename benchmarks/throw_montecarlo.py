"""Monte-Carlo landing spread (app/core/throw/montecarlo.py): plants simulated per second, the
vectorized batch against a plain loop of one-plant full-dynamics simulations (the same RK4 integrator,
the same plant and controller), in the same process, CPU time beside wall time.

    python -m benchmarks.throw_montecarlo
"""
from __future__ import annotations

import time

from app.core.throw.closed_loop import Controller, simulate_closed_loop
from app.core.throw.plants import load_plant
from app.core.throw.montecarlo import draw_plants, format_summary, monte_carlo
from app.core.throw.arm import ThrowingArm
from app.core.throw.config import load_throw_config


def _timed(fn):
    t0, c0 = time.perf_counter(), time.process_time()
    out = fn()
    return out, time.perf_counter() - t0, time.process_time() - c0


def main(plants: int = 500, loop_plants: int = 20) -> None:
    cfg = load_throw_config("optimized_thesis")
    arm = ThrowingArm(params=cfg.model)
    throw = arm.solve(cfg.spec)
    plant = load_plant("heavier")
    print(f"Monte-Carlo of the closed-loop throw 'optimized_thesis' on plant 'heavier' ({plant.title})")
    print(f"{'controller':12s} {'method':44s} {'plants/s (wall)':>16s} {'plants/s (CPU)':>15s} {'ratio (CPU)':>12s}")
    batch = draw_plants(throw, plant, plants, seed=0)
    for name in ("open", "vhc", "transverse"):
        ctl = Controller(throw, name)
        _, wall_l, cpu_l = _timed(lambda: [simulate_closed_loop(throw, ctl, plant, batch.take([j]), seed=j)
                                           for j in range(loop_plants)])
        _, wall_b, cpu_b = _timed(lambda: simulate_closed_loop(throw, ctl, plant, batch, seed=0))
        loop_rate, batch_rate = loop_plants / cpu_l, plants / cpu_b
        print(f"{name:12s} {f'plain loop, one plant at a time ({loop_plants} plants)':44s} "
              f"{loop_plants / wall_l:16.1f} {loop_rate:15.1f} {'1':>12s}")
        print(f"{name:12s} {f'vectorized batch of {plants} plants':44s} {plants / wall_b:16.1f} {batch_rate:15.1f} "
              f"{batch_rate / loop_rate:11.0f}x")
    study, wall, cpu = _timed(lambda: monte_carlo(throw, plant, plants=plants, seed=0))
    print(f"\nthe whole study, three controllers x {plants} plants: {wall:.1f} s wall, {cpu:.1f} s CPU")
    print(format_summary(study))


if __name__ == "__main__":
    main()
