"""The suite's rule on random numbers (tests/conftest.py): a generator without a seed is refused, and
the seeds a test used are recorded for its failure report."""
import random

import numpy as np
import pytest


def test_a_generator_without_a_seed_is_refused():
    with pytest.raises(AssertionError, match="without a seed"):
        np.random.default_rng()
    with pytest.raises(AssertionError, match="without a seed"):
        random.Random()


def test_the_seeds_a_test_uses_are_recorded(request):
    np.random.default_rng(2024).uniform()
    random.Random(7).random()
    assert request.node.random_seeds == [2024, 7]
