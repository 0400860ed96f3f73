"""Exam sheets: the chosen exercises with new numbers (a seeded variant per exercise), each variant
re-solved by the engine and kept only when it is physically valid and tells the same story.

A variant multiplies each number the exercise gives (its ``given`` entries: robot parameters and
task data; a list as a whole, so a rank-one Jacobian stays rank one and a direction stays a
direction) and each coordinate of its configuration by a "nice" factor drawn from ``FACTORS``
with a generator seeded by (seed, exercise id). Gravity, yes/no flags and expressions such as
``pi/6`` are kept. The variant is solved; it is refused, and another one drawn (at most
``ATTEMPTS``), when the engine refuses it (negative mass, unreachable point, infeasible bounds:
a ``UserError``), when an answer is not finite, or when a yes/no or whole-number answer (a rank, a
count, feasibility) differs from the exam's, i.e. when the variant would be another exercise.
When no number of the exercise changes any answer (the answers are symbolic), or no valid
variant is found, the exercise is reprinted as is and the sheet says so.

>>> sheet = make_sheet(["2009-09-10#2"], seed=1)
>>> entry = sheet.entries[0]
>>> entry.status, sorted(entry.changes)
('variant', ['U'])
"""
from __future__ import annotations

import dataclasses
import hashlib
import math
import random
from dataclasses import dataclass, field
from typing import Any, Dict, List, Optional, Sequence

import numpy as np
import sympy as sp

from .errors import UserError
from .exercise import Exercise, Solution, load_exercise, solve

#: multipliers of a variant's numbers (kept "nice": the new numbers stay short)
FACTORS = (0.5, 0.6, 0.75, 0.8, 1.2, 1.25, 1.5, 2.0)
ATTEMPTS = 8
_FIXED_KINDS = ("gravity",)


@dataclass
class SheetEntry:
    exercise: Exercise
    solution: Solution               # of the variant (or of the exercise as is)
    status: str                      # "variant" or "as is"
    changes: Dict[str, Any] = field(default_factory=dict)        # given name -> new value
    configuration: Dict[str, float] = field(default_factory=dict)  # configuration -> new value
    reason: str = ""                 # why it is reprinted as is
    attempts: int = 0

    @property
    def given(self) -> Dict[str, Any]:
        """The overrides to pass to ``solve`` (with ``exercise()``) to reproduce the variant."""
        return dict(self.changes)

    def varied_exercise(self) -> Exercise:
        conf = {**self.exercise.configuration, **self.configuration}
        return dataclasses.replace(self.exercise, configuration=conf)


@dataclass
class Sheet:
    seed: int
    entries: List[SheetEntry]


def _rng(seed: int, exercise_id: str) -> random.Random:
    digest = hashlib.sha256(f"{seed}:{exercise_id}".encode()).hexdigest()
    return random.Random(int(digest[:16], 16))


def _nice(x: float) -> float:
    """Round to 3 significant digits (a number a student can copy)."""
    if x == 0 or not math.isfinite(x):
        return x
    digits = 3 - int(math.floor(math.log10(abs(x)))) - 1
    return round(x, digits)


def _scale(value, factor: float):
    if isinstance(value, bool) or isinstance(value, str):
        return value
    if isinstance(value, (int, float)):
        return _nice(float(value) * factor)
    if isinstance(value, list):
        return [_scale(v, factor) for v in value]
    return value


def _variable(exercise: Exercise, robot) -> List[str]:
    """The given entries a variant may change: numbers (or lists with numbers) that are not
    gravity and not flags."""
    out = []
    for name, value in exercise.given.items():
        p = robot.parameters.get(name)
        if p is not None and p.kind in _FIXED_KINDS:
            continue
        if _has_number(value):
            out.append(name)
    return out


def _has_number(value) -> bool:
    if isinstance(value, bool):
        return False
    if isinstance(value, (int, float)):
        return value != 0
    if isinstance(value, list):
        return any(_has_number(v) for v in value)
    return False


def _signature(solution: Solution) -> Dict[str, Any]:
    """The answers that must not change in a variant: yes/no and whole numbers."""
    out = {}
    for name, value in solution.answers.items():
        if isinstance(value, (bool, np.bool_)):
            out[name] = bool(value)
        elif isinstance(value, (int, np.integer)) and not isinstance(value, bool):
            out[name] = int(value)
        elif isinstance(value, sp.Integer):
            out[name] = int(value)
    return out


def _finite(value) -> bool:
    try:
        if isinstance(value, (sp.Basic, sp.MatrixBase)):
            if isinstance(value, sp.MatrixBase) or not value.is_number:
                return not any(getattr(e, "has", lambda *a: False)(sp.nan, sp.zoo, sp.oo, -sp.oo)
                               for e in (value if isinstance(value, sp.MatrixBase) else [value]))
            return bool(sp.Abs(value).is_finite)
        arr = np.asarray(value, dtype=float)
        return bool(np.all(np.isfinite(arr)))
    except (TypeError, ValueError):
        return True


def _same_answers(a: Solution, b: Solution) -> bool:
    from .compare import same
    for name, value in a.answers.items():
        other = b.answers.get(name)
        if other is None:
            return False
        try:
            if not same(value, other, tol=1e-9):
                return False
        except Exception:
            return False
    return True


def make_variant(exercise: Exercise, seed: int, original: Optional[Solution] = None) -> SheetEntry:
    """A valid seeded variant of ``exercise`` (see the module docstring), or the exercise as is."""
    robot = exercise.load_robot()
    original = original or solve(exercise)
    names = _variable(exercise, robot)
    coords = [c for c in exercise.configuration if c not in exercise.given and exercise.configuration[c] != 0]
    if not names and not coords:
        return SheetEntry(exercise, original, "as is", reason="the exercise gives no numbers: its answers are symbolic")
    rng = _rng(seed, exercise.id)
    want = _signature(original)
    last_error = ""
    for attempt in range(1, ATTEMPTS + 1):
        changes = {n: _scale(exercise.given[n], rng.choice(FACTORS)) for n in names}
        conf = {c: _nice(float(exercise.configuration[c]) * rng.choice(FACTORS)) for c in coords}
        varied = dataclasses.replace(exercise, configuration={**exercise.configuration, **conf})
        try:
            sol = solve(varied, given=changes)
        except UserError as exc:
            last_error = str(exc)
            continue
        except (ArithmeticError, ValueError, TypeError, np.linalg.LinAlgError) as exc:
            last_error = f"{type(exc).__name__}: {exc}"
            continue
        if not all(_finite(v) for v in sol.answers.values()):
            last_error = "an answer is not finite"
            continue
        if _signature(sol) != want:
            last_error = "a yes/no or whole-number answer changed (another exercise)"
            continue
        if _same_answers(original, sol):
            return SheetEntry(exercise, original, "as is", reason="changing its numbers changes no answer "
                              "(the answers are symbolic)", attempts=attempt)
        return SheetEntry(exercise, sol, "variant", changes, conf, attempts=attempt)
    return SheetEntry(exercise, original, "as is", reason=f"no valid variant in {ATTEMPTS} draws ({last_error})",
                      attempts=ATTEMPTS)


def make_sheet(exercise_ids: Sequence[str], seed: int = 0, progress=None) -> Sheet:
    """One entry per exercise, in the order given; the same seed gives the same sheet."""
    if not exercise_ids:
        raise UserError("give at least one exercise")
    entries = []
    for k, ex_id in enumerate(exercise_ids):
        if progress:
            progress(k / len(exercise_ids), str(ex_id))
        entries.append(make_variant(load_exercise(ex_id), seed))
    return Sheet(seed, entries)
