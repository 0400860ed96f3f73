"""Landing spread of a closed-loop throw: a seeded Monte-Carlo study over plants drawn from a
plant file's uncertainty ranges, simulated as one vectorized batch per controller.

Every controller meets the same plants and the same sensor noise (common random numbers), so their
distributions can be compared directly.

>>> from app.core.throw.arm import ThrowingArm
>>> from app.core.throw.config import load_throw_config
>>> from app.core.throw.plants import load_plant
>>> arm = ThrowingArm()
>>> throw = arm.solve(load_throw_config("optimized_thesis").spec)
>>> study = monte_carlo(throw, load_plant("heavier"), ["open"], plants=4, seed=1)
>>> study.results["open"].distance.shape
(4,)
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Dict, List, Optional, Sequence

import numpy as np

from ..errors import UserError
from .closed_loop import CONTROLLERS, ClosedLoopRun, Controller, Gains, simulate_closed_loop
from .config import Progress
from .plants import Plant, PlantBatch, plant_batch
from .reduced import Throw

#: quantiles of the summary (fractions)
QUANTILES = (0.05, 0.25, 0.5, 0.75, 0.95)
#: plants per vectorized batch (fixed, so that results do not depend on progress reporting)
CHUNK = 250


def draw_plants(throw: Throw, plant: Plant, count: int, seed: int = 0) -> PlantBatch:
    """``count`` plants around ``plant``: each uncertain parameter times a factor uniform in
    [1 - r, 1 + r], friction uniform in its range (one seeded generator, parameters in a fixed order)."""
    if count < 1:
        raise UserError("the Monte-Carlo study needs at least one plant")
    arm, k = throw.arm, throw.spec.k
    base = plant.values(arm.values, k)
    rng = np.random.default_rng(seed)
    values = [dict(base) for _ in range(count)]
    for name in sorted(plant.uncertainty):
        if name in ("viscous", "coulomb"):
            continue
        r = float(plant.uncertainty[name])
        factors = rng.uniform(1.0 - r, 1.0 + r, count)
        for v, f in zip(values, factors):
            v[name] = base[name] * f
    friction = {}
    for name in ("viscous", "coulomb"):
        nominal = getattr(plant, name)
        lo, hi = plant.uncertainty.get(name, (nominal, nominal))
        friction[name] = rng.uniform(lo, hi, count) if hi > lo else np.full(count, float(lo))
    return plant_batch(arm, k, values, friction["viscous"], friction["coulomb"])


@dataclass
class Study:
    """A Monte-Carlo study: the planned throw's landing point and, per controller, every plant's run."""
    planned_distance: float          # the plan's landing distance from the base, true velocity [m]
    planned_speed: float             # the plan's release speed |J q'| [m/s]
    plants: int
    seed: int
    results: Dict[str, ClosedLoopRun]

    def summary(self, controller: str) -> dict:
        """mean, std and quantiles of the landing distance (released balls), the landing error
        |distance - planned|, release speeds, and the rates of limit violations (docs/cli.md)."""
        run = self.results[controller]
        ok = run.released
        d = run.distance[ok]
        err = np.abs(d - self.planned_distance)
        speed = run.release_speed[ok]
        stats = lambda a: {"mean": float(np.mean(a)), "std": float(np.std(a))} if a.size else \
            {"mean": None, "std": None}
        return {
            "plants": int(run.size),
            "released_rate": float(np.mean(ok)),
            "distance": {**stats(d), "quantiles": {f"{q:g}": float(np.quantile(d, q)) if d.size else None
                                                   for q in QUANTILES}},
            "landing_error": {**stats(err), "max": float(err.max()) if err.size else None},
            "release_speed": stats(speed),
            "violation_rate": float(np.mean(run.violation)),
            "speed_violation_rate": float(np.mean(np.any(run.max_speed_ratio > 1 + 1e-9, axis=0))),
            "torque_saturation_rate": float(np.mean(np.any(run.max_torque_ratio > 1 + 1e-9, axis=0))),
            "position_violation_rate": float(np.mean(run.position_violation)),
        }


def monte_carlo(throw: Throw, plant: Plant, controllers: Sequence[str] = CONTROLLERS, plants: int = 500,
                seed: int = 0, gains: Optional[Gains] = None, progress: Progress = None) -> Study:
    """Simulate ``plants`` plants drawn from ``plant`` (``draw_plants``) under each controller.

    Batches of ``CHUNK`` plants are integrated together; the sensor noise of batch j comes from
    the seed sequence (seed, j), so the result does not depend on how progress is reported."""
    for c in controllers:
        if c not in CONTROLLERS:
            raise UserError(f"unknown controller '{c}' (one of {', '.join(CONTROLLERS)})")
    batch = draw_plants(throw, plant, plants, seed)
    results: Dict[str, ClosedLoopRun] = {}
    chunks = [np.arange(i, min(i + CHUNK, plants)) for i in range(0, plants, CHUNK)]
    total = len(controllers) * len(chunks)
    done = 0
    for name in controllers:
        ctl = Controller(throw, name, gains)
        runs: List[ClosedLoopRun] = []
        for j, idx in enumerate(chunks):
            def sub(frac, msg, _done=done):
                if progress:
                    progress((_done + frac) / total, f"{name}: plants {idx[0] + 1}-{idx[-1] + 1} of {plants}, {msg}")
            noise_seed = int(np.random.SeedSequence([seed, j]).generate_state(1)[0])
            runs.append(simulate_closed_loop(throw, ctl, plant, batch.take(idx), seed=noise_seed, progress=sub))
            done += 1
        results[name] = _concatenate(runs)
    if progress:
        progress(1.0, "done")
    return Study(throw.release.distance_from_base, throw.release.speed, plants, seed, results)


def _concatenate(runs: List[ClosedLoopRun]) -> ClosedLoopRun:
    if len(runs) == 1:
        return runs[0]
    first = runs[0]
    cat = lambda name, axis=0: np.concatenate([getattr(r, name) for r in runs], axis=axis)
    return ClosedLoopRun(first.controller, cat("released"), cat("release_time"), cat("theta_dot_e"),
                         cat("release_speed"), cat("release_position", 1), cat("release_velocity", 1),
                         cat("distance"), cat("distance_thesis"), cat("max_speed_ratio", 1),
                         cat("max_torque_ratio", 1), cat("position_violation"), cat("violation"),
                         first.t, first.q, first.tau)


def histogram(values: np.ndarray, bins: int = 30, span: Optional[tuple] = None):
    """Counts and bin edges of the finite values (for the page's histogram)."""
    v = values[np.isfinite(values)]
    if not v.size:
        return np.zeros(bins, dtype=int), np.linspace(0.0, 1.0, bins + 1)
    lo, hi = span or (float(v.min()), float(v.max()))
    if not hi > lo:
        lo, hi = lo - 0.01, hi + 0.01
    counts, edges = np.histogram(v, bins=bins, range=(lo, hi))
    return counts, edges


def format_summary(study: Study) -> str:
    """The study as a few lines of text (CLI)."""
    lines = [f"Monte-Carlo: {study.plants} plants (seed {study.seed}); planned landing {study.planned_distance:.4f} m, "
             f"release speed {study.planned_speed:.4f} m/s"]
    for name in study.results:
        s = study.summary(name)
        d, e = s["distance"], s["landing_error"]
        if d["mean"] is None:
            lines.append(f"  {name:10s} no ball released")
            continue
        q = d["quantiles"]
        lines.append(f"  {name:10s} distance {d['mean']:.4f} +- {d['std']:.4f} m (5 % {q['0.05']:.4f}, median "
                     f"{q['0.5']:.4f}, 95 % {q['0.95']:.4f}); landing error mean {e['mean']:.4f} m; released "
                     f"{100 * s['released_rate']:.1f} %; limits violated {100 * s['violation_rate']:.1f} % "
                     f"(speed {100 * s['speed_violation_rate']:.1f} %, torque {100 * s['torque_saturation_rate']:.1f} %)")
    return "\n".join(lines)

