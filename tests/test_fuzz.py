"""Fuzzing the command line (issue 15) with hypothesis: robot files, exercise files, throw
configurations and options, mutated from the shipped files or drawn from the formats' grammar by
the generators of benchmarks/fuzz.py, each run in-process through ``app.cli.main`` with a limit
of 8 s of CPU time.

Property: a success whose result holds up (M symmetric positive definite at the file's values,
finite JSON) or a refusal (exit code 2, one line ``error: ...``); never a traceback, never a hang.
Hypothesis draws the seeds deterministically (``derandomize``); a failure names the seed and the
command, and ``python -m benchmarks.fuzz`` runs thousands of such cases.
"""
import random

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from benchmarks.fuzz import make_case, run_case

# cases per family: together about 20 s of CPU with a warm derivation cache (the shipped robots'
# derivations are shared with the other tests; a mutated robot's are derived afresh)
EXAMPLES = {"robot": 4, "exercise": 3, "throw": 4, "options": 10}


@pytest.mark.parametrize("family", sorted(EXAMPLES))
def test_hostile_input_is_refused_in_one_line_or_succeeds_correctly(family):
    @settings(max_examples=EXAMPLES[family], derandomize=True, deadline=None, database=None,
              suppress_health_check=list(HealthCheck))
    @given(seed=st.integers(min_value=0, max_value=2 ** 32 - 1))
    def case_holds(seed):
        case = make_case(random.Random(seed), family)
        outcome = run_case(case, limit_s=8.0, seed=seed, cpu_clock=True)
        assert outcome.verdict in ("refusal", "success"), \
            f"seed {seed}: {outcome.verdict}: {case.describe()} -> {outcome.detail}"

    case_holds()
