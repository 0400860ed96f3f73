"""The robust objective of the throw optimizer: a throw judged by its closed-loop throws on N plants.

A candidate throw (the same Bezier VHC vector as ``optimize.ThrowOptimizer``) is thrown in full dynamics
under a controller (``closed_loop``) on N plants drawn, seeded, from a plant file's uncertainty
ranges (``montecarlo.monte_carlo``; the same N plants and sensor noise for every candidate:
common random numbers). Its value:

- ``distance_q05``: the 5 % quantile of the landing distance from the base over the N plants (a ball
  never released counts as landing at the base, 0 m);
- ``held_rate``: the fraction of plants in which every limit held (joint speeds, commanded torques,
  joint ranges, a release);
- the throw is *robust* when ``held_rate >= 0.95``; its score is then ``distance_q05``;
- otherwise the score is ``distance_q05 - 10 m x (shortfall)``, the shortfall being how far the 95 %
  quantile of the plants' worst limit ratio (max |q'|/limit, max |tau|/limit) is above 1 plus how far
  the held rate is below 0.95: a smooth measure that guides the search towards robust throws even
  while every plant still breaks a limit.

Search (``RobustOptimizer.run``): a seeded (1+1) evolution strategy with the one-fifth success rule,
in the optimizer's bounds, from a given throw (default: the shipped ``optimized_thesis``). The budget
is counted in robust evaluations (one candidate thrown on the N plants), so the same seed gives the
same throw on any machine.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import List, Optional, Tuple

import numpy as np

from ..errors import UserError
from .arm import ThrowingArm
from .closed_loop import CONTROLLERS
from .config import Progress, ThrowSpec, VHCError
from .montecarlo import monte_carlo
from .optimize import ThrowOptimizer
from .plants import Plant
from .reduced import Throw

#: the quantile of the distance that is maximized, and the share of plants that must hold every limit
QUANTILE = 0.05
HELD = 0.95
PENALTY = 10.0          # m of score per unit of limit-ratio shortfall
DEFAULT_PLANTS = 50
DEFAULT_ROBUST_EVALUATIONS = 60


@dataclass
class RobustValue:
    """One candidate judged on the N plants."""
    score: float
    distance_q05: float          # [m]
    held_rate: float             # fraction of plants with every limit held
    ratio_q95: float             # 95 % quantile over plants of the worst limit ratio
    robust: bool                 # held_rate >= 0.95
    message: str = ""            # why the candidate could not be judged ('' when it was)


@dataclass
class RobustResult:
    spec: ThrowSpec
    throw: Throw
    value: RobustValue
    start: RobustValue           # the starting throw's value
    evaluations: int             # robust evaluations spent (each: N closed-loop throws)
    plants: int
    controller: str
    seed: int
    evaluation_history: List[Tuple[int, float]] = field(default_factory=list)   # (evaluations, best score)


class RobustOptimizer:
    """Robust objective and its search (see the module's docstring)."""

    def __init__(self, arm: ThrowingArm, plant: Plant, controller: str = "transverse", plants: int = DEFAULT_PLANTS,
                 seed: int = 0, degree: int = 6):
        if controller not in CONTROLLERS:
            raise UserError(f"unknown controller '{controller}' ({', '.join(CONTROLLERS)})")
        if not plant.uncertainty:
            raise UserError(f"the plant '{plant.title}' has no uncertainty ranges: the robust objective needs them "
                            "(e.g. --plant heavier)")
        if not 1 <= plants <= 10000:
            raise UserError("the robust objective needs from 1 to 10000 plants")
        self.arm, self.plant, self.controller, self.plants, self.seed = arm, plant, controller, int(plants), int(seed)
        self.space = ThrowOptimizer(arm, degree=degree)      # vectors and bounds of the nominal optimizer
        self.evaluations = 0

    def value_of_throw(self, throw: Throw) -> RobustValue:
        """The robust value of a solved throw (one robust evaluation)."""
        self.evaluations += 1
        study = monte_carlo(throw, self.plant, [self.controller], self.plants, seed=self.seed)
        run = study.results[self.controller]
        dist = np.where(run.released, np.nan_to_num(run.distance, nan=0.0), 0.0)
        ratio = np.maximum(run.max_speed_ratio.max(axis=0), run.max_torque_ratio.max(axis=0))
        ratio = np.where(run.released & ~run.position_violation, ratio, np.maximum(ratio, 2.0))
        held = float(np.mean(~run.violation))
        d05 = float(np.quantile(dist, QUANTILE))
        r95 = float(np.quantile(ratio, HELD))
        robust = held >= HELD
        score = d05 if robust else d05 - PENALTY * (max(r95 - 1.0, 0.0) + (HELD - held))
        return RobustValue(score, d05, held, r95, robust)

    def value(self, x: np.ndarray) -> Tuple[RobustValue, Optional[Throw]]:
        """The robust value of an optimizer vector; a throw that cannot be carried out scores -inf."""
        try:
            throw = self.arm.solve(self.space.to_spec(x))
        except VHCError as exc:
            self.evaluations += 1
            return RobustValue(-math.inf, math.nan, 0.0, math.inf, False, str(exc)), None
        return self.value_of_throw(throw), throw

    def run(self, start: ThrowSpec, evaluations: int = DEFAULT_ROBUST_EVALUATIONS, step: float = 0.02,
            progress: Progress = None) -> RobustResult:
        """(1+1)-ES from ``start`` for ``evaluations`` robust evaluations (the start included); ``step``:
        the first mutation's standard deviation as a fraction of each variable's range."""
        if not evaluations >= 1:
            raise UserError(f"the robust budget must be at least one evaluation (got {evaluations})")
        if not 0 < step <= 0.5:
            raise UserError(f"the mutation step must be in (0, 0.5] of the ranges (got {step})")
        self.evaluations = 0
        rng = np.random.default_rng(self.seed)
        lo, hi = self.space.lower, self.space.upper
        span = hi - lo
        x = np.clip(self.space.to_vector(start), lo, hi)
        best, throw = self.value(x)
        if throw is None:
            raise UserError(f"the starting throw cannot be carried out: {best.message}")
        first = best
        history = [(self.evaluations, best.score)]
        sigma = step
        while self.evaluations < evaluations:
            y = np.clip(x + sigma * span * rng.normal(size=x.size), lo, hi)
            v, t = self.value(y)
            if t is not None and v.score > best.score:
                x, best, throw = y, v, t
                sigma = min(0.5, sigma * math.exp(1.0 / 3.0))
                history.append((self.evaluations, best.score))
            else:
                sigma = max(1e-4, sigma * math.exp(-1.0 / 12.0))
            if progress:
                progress(self.evaluations / evaluations,
                         f"{self.evaluations} robust evaluations: 5 % quantile {best.distance_q05:.4f} m, "
                         f"limits held in {100 * best.held_rate:.0f} % of the plants")
        return RobustResult(self.space.to_spec(x), throw, best, first, self.evaluations, self.plants, self.controller,
                            self.seed, history)
