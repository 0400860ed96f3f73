"""The throw optimizer's robust objective (app/core/throw/robust.py): the 5 % quantile of the landing
distance over N seeded plants, limits held in >= 95 % of them; budget in robust evaluations."""
import json

import numpy as np
import pytest

from app.cli import main
from app.core.throw.plants import load_plant
from app.core.throw.montecarlo import monte_carlo
from app.core.throw.robust import HELD, PENALTY, RobustOptimizer
from app.core.throw.arm import ThrowingArm
from app.core.throw.config import load_throw_config


def test_robust_value_is_the_quantile_over_the_plants_and_the_search_repeats():
    """A tiny budget (2 robust evaluations of 4 plants): the start's value is the Monte-Carlo study's
    5 % quantile, penalized because no plant of `heavier` keeps the wrist within its speed limit under
    the transverse stabilizer; the same seed gives the same throw; the search never gets worse."""
    cfg = load_throw_config("optimized_thesis")
    arm = ThrowingArm(params=cfg.model)
    plant = load_plant("heavier")
    runs = [RobustOptimizer(arm, plant, "transverse", plants=4, seed=3).run(cfg.spec, evaluations=2)
            for _ in range(2)]
    a, b = runs
    assert a.evaluations == 2 and a.plants == 4
    assert a.spec.to_config() == b.spec.to_config() and a.value.score == pytest.approx(b.value.score, abs=1e-12)
    assert a.value.score >= a.start.score
    study = monte_carlo(arm.solve(cfg.spec), plant, ["transverse"], 4, seed=3)
    s = study.summary("transverse")
    assert a.start.distance_q05 == pytest.approx(s["distance"]["quantiles"]["0.05"], abs=1e-12)
    assert a.start.held_rate == pytest.approx(1.0 - s["violation_rate"], abs=1e-12)
    assert a.start.held_rate < HELD and not a.start.robust and a.start.ratio_q95 > 2.0
    assert a.start.score == pytest.approx(a.start.distance_q05 - PENALTY * (a.start.ratio_q95 - 1.0 + HELD
                                                                            - a.start.held_rate), abs=1e-12)


def test_robust_option_refuses_bad_input(capsys):
    assert main(["throw", "throw1", "--robust"]) == 2
    assert "--robust needs --optimize" in capsys.readouterr().err
    assert main(["throw", "--optimize", "--robust", "--plant", "exact"]) == 2
    assert "no uncertainty ranges" in capsys.readouterr().err
    assert main(["throw", "--optimize", "--robust", "--closed-loop", "all"]) == 2
    assert "one controller" in capsys.readouterr().err
