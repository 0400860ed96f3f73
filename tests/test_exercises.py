"""Every shipped exercise is solved by the engine and every expected answer is checked."""
from pathlib import Path

import pytest
import yaml

from app.core.compare import parallel, same
from app.core.exercise import expected_path, list_exercises

EXERCISES = list_exercises()


def test_there_are_exercises():
    assert len(EXERCISES) >= 1


@pytest.mark.parametrize("exercise", EXERCISES, ids=[e.id for e in EXERCISES])
def test_exercise_answers(exercise, solved):
    path = expected_path(exercise)
    assert path.exists(), f"{exercise.id} has no expected answers file {path.name}"
    data = yaml.safe_load(path.read_text())
    solution = solved(exercise)
    defs = data.get("definitions") or {}
    assert data["answers"], "an expected-answers file must check something"
    for name, spec in data["answers"].items():
        assert name in solution.answers, f"{exercise.id}: the engine gave no answer '{name}'"
        tol = spec.get("tol", 1e-9)
        if spec.get("up_to_scale"):     # a direction (null-space vector): any non-zero multiple
            assert parallel(spec["value"], solution.answers[name], definitions=defs), (
                f"{exercise.id}: {name} ({spec.get('source', '')}): not parallel to {spec['value']}, "
                f"engine {solution.answers[name]}")
            continue
        assert same(spec["value"], solution.answers[name], tol=tol, definitions=defs), (
            f"{exercise.id}: {name} ({spec.get('source', '')}): expected {spec['value']}, "
            f"engine {solution.answers[name]}")
