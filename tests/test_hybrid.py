"""Natural/artificial constraints of a task frame and the hybrid selection matrices."""
import itertools

import numpy as np
import pytest

from app.core.contact import FORCE_NAMES, PAIRS, VELOCITY_NAMES, task_frame_constraints
from app.core.exercise import ExerciseError, parse_exercise, solve


@pytest.mark.parametrize("pair, axis", list(itertools.product(sorted(PAIRS), range(3))))
def test_constraints_are_complementary_and_selections_orthogonal(pair, axis):
    for commandable in (None, [0, 1, 2, 5], [0, 1, 5]):
        c = task_frame_constraints(PAIRS[pair](axis), commandable)
        natural = c.natural_velocities + c.natural_forces
        artificial = c.force_controlled + c.velocity_controlled + c.uncontrolled
        assert len(natural) == 6 and len(artificial) == 6
        for i in range(6):      # each direction: exactly one of v, F is natural, the other artificial
            assert (VELOCITY_NAMES[i] in natural) != (FORCE_NAMES[i] in natural)
            assert (VELOCITY_NAMES[i] in artificial) != (FORCE_NAMES[i] in artificial)
        assert np.allclose(c.S_f.T @ c.S_v, 0)
        cmd = np.diag([1.0 if x else 0.0 for x in c.commandable])
        assert np.allclose(c.S_f @ c.S_f.T + c.S_v @ c.S_v.T, cmd)


def test_a_reference_on_a_natural_constraint_is_refused():
    ex = parse_exercise({"id": "t", "robot": "kin_scara", "question": "q",
                         "tasks": [{"kind": "hybrid_constraints", "contact": {"pair": "planar", "axis": "z"},
                                    "references": {"v_z": "v_zd"}}]})
    with pytest.raises(ExerciseError):
        solve(ex)
