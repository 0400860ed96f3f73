"""The robot files of the derivation scaling benchmark (benchmarks/robots/chain_*.yaml) are what
``benchmarks.scaling`` writes, and each loads (the mass check included: M positive definite at the
file's values), so that the table in README measures the chains it names."""
import pytest

from app.core import compact, steps, trig
from app.core.dynamics import forget_derivations
from app.core.robot import load_robot
from benchmarks import scaling

CHAINS = scaling.PLANAR + scaling.SPATIAL + scaling.PUMA


@pytest.mark.parametrize("name", CHAINS)
def test_chain_file_is_the_generated_one_and_loads(name):
    path = scaling.HERE / f"{name}.yaml"
    assert path.read_text() == scaling.robot_texts()[name]
    robot = load_robot(path)
    joints = 6 if name.startswith("chain_puma_6r") else int(name.rsplit("_", 1)[1][:-1])
    assert robot.n == joints
    assert len(robot.bodies) == joints


def test_forget_derivations_empties_every_memory_a_cold_benchmark_must_not_reuse():
    compact._NICE_CACHE[("x", ())] = 1
    compact._FACTOR_CACHE["x"] = 1
    steps._ENTRY_LATEX[("x",)] = "x"
    trig._SPARSE["x"] = None
    forget_derivations()
    assert not compact._NICE_CACHE and not compact._FACTOR_CACHE and not steps._ENTRY_LATEX and not trig._SPARSE
