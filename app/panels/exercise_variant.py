"""Variants of an exercise and a shared cache of solutions, for the Exercises panel.

A variant changes the numbers of an exercise: entries of its ``given`` data, the coordinates of
its ``configuration`` and the values of the robot's parameters (these go into ``given``, where
the numeric tasks read them). ``fields(exercise, robot)`` lists what can be changed with the
text shown in the page; ``parse_field`` checks what the student typed (a number, an expression
such as ``pi/4``, or a list with the shape of the original) and raises ``UserError`` with a
clear message otherwise. Nothing typed is ever evaluated: expressions go through the lab's
whitelist parser.

>>> from app.core.exercise import load_exercise
>>> from app.core.robot import load_robot
>>> ex = load_exercise("2020-06-05#1")
>>> f = {x.key: x for x in fields(ex, load_robot(ex.robot_ref))}
>>> f["given:V"].text
'[1, 1.5, 2]'
>>> parse_field(f["given:V"], "[1, 1.2, 2]")          # exact: the numbers typed
[1.0, 1.2, 2.0]
>>> parse_field(f["given:V"], "[1, 2]")
Traceback (most recent call last):
...
app.core.errors.UserError: V: expected a list of 3 entries, like [1, 1.5, 2]
"""
from __future__ import annotations

import dataclasses
import json
import threading
from collections import OrderedDict
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Dict, List, Mapping, Optional, Tuple

import numpy as np
import yaml

from app.core.errors import UserError
from app.core.exercise import Exercise, Solution, solve
from app.core.expressions import ExpressionError, parse_expression, parse_number
from app.core.numeric import ParameterError
from app.viewer import in_worker


@dataclass(frozen=True)
class Field:
    """One changeable number of an exercise."""
    key: str            # "given:<name>", "configuration:<q>" or "parameter:<name>"
    name: str           # what the student sees
    original: Any       # the exercise's (or robot file's) value
    text: str           # the original as typed text
    unit: str = ""
    doc: str = ""

    @property
    def section(self) -> str:
        return self.key.split(":", 1)[0]


def format_value(value) -> str:
    """Text of a given value for a field: numbers short, lists in brackets.

    >>> format_value([[1, 0.5], ["pi/2", 2.0]])
    '[[1, 0.5], [pi/2, 2]]'
    """
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, (int, float, np.floating, np.integer)):
        return f"{float(value):.6g}"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(format_value(v) for v in value) + "]"
    return str(value)


def fields(exercise: Exercise, robot) -> List[Field]:
    """The numbers a student may change: the given data (scalars and lists of numbers or
    expressions), the configuration, then the robot parameters not already given."""
    out: List[Field] = []
    for name, value in exercise.given.items():
        if not _editable(value):
            continue
        p = robot.parameters.get(name)
        out.append(Field(f"given:{name}", name, value, format_value(value),
                         p.unit if p is not None else "", p.doc if p is not None else "given by the exercise"))
    given_coords = {c for c in robot.coordinates if c in exercise.given}
    for c in robot.coordinates:
        if c in exercise.configuration and c not in given_coords:
            out.append(Field(f"configuration:{c}", c, exercise.configuration[c],
                             format_value(exercise.configuration[c]), "", "configuration of the exercise"))
    for name, p in robot.parameters.items():
        if name in exercise.given:
            continue
        out.append(Field(f"parameter:{name}", name, p.value, format_value(p.value), p.unit or "", p.doc or p.kind))
    return out


def _editable(value) -> bool:
    if isinstance(value, bool):
        return False
    if isinstance(value, (int, float, str)):
        return True
    if isinstance(value, list):
        return all(_editable(v) for v in value)
    return False


def parse_field(field: Field, text: str, robot=None):
    """The value typed into a field, checked against the original's kind and shape."""
    text = (text or "").strip()
    if not text:
        raise UserError(f"{field.name}: empty value; type a number")
    if field.section == "parameter" or (robot is not None and field.name in robot.parameters):
        if robot is not None:
            from app.viewer import parse_parameter
            try:
                return parse_parameter(robot, field.name, text)
            except ParameterError as exc:
                raise UserError(str(exc)) from None
    if isinstance(field.original, list):
        try:
            value = yaml.safe_load(text)
        except yaml.YAMLError:
            raise UserError(f"{field.name}: '{text}' is not a list; type it like {field.text}") from None
        return _leaf_or_list(field, field.original, value, text)
    return _leaf(field, field.original, text)


def _leaf_or_list(field: Field, original, value, text):
    if isinstance(original, list):
        if not isinstance(value, list) or len(value) != len(original):
            raise UserError(f"{field.name}: expected a list of {len(original)} entries, like {field.text}")
        return [_leaf_or_list(field, o, v, text) for o, v in zip(original, value)]
    if isinstance(value, (list, dict)):
        raise UserError(f"{field.name}: '{text}' does not have the shape of {field.text}")
    return _leaf(field, original, value)


def _leaf(field: Field, original, value):
    """A number (float) when the entry is constant; an expression text when the original was an
    expression of other names."""
    if isinstance(value, bool) or value is None:
        raise UserError(f"{field.name}: '{value}' is not a number")
    try:
        number = parse_number(value if isinstance(value, str) else float(value))
    except (ExpressionError, TypeError, ValueError):
        number = None
    if number is not None:
        if not np.isfinite(number):
            raise UserError(f"{field.name}: expected a finite number, got '{value}'")
        return number
    if isinstance(original, str):           # an expression of names, like the original
        try:
            parse_expression(value)
        except ExpressionError as exc:
            raise UserError(f"{field.name}: {exc}") from None
        return str(value).strip()
    raise UserError(f"{field.name}: '{value}' is not a number")


def apply_variant(exercise: Exercise, values: Mapping[str, Any]) -> Tuple[Exercise, Dict[str, Any]]:
    """(exercise with the variant's configuration, given overrides) for ``solve``; ``values``
    maps field keys to parsed values."""
    given, conf = {}, dict(exercise.configuration)
    for key, value in values.items():
        section, name = key.split(":", 1)
        if section == "configuration":
            conf[name] = value
        else:
            given[name] = value
    return dataclasses.replace(exercise, configuration=conf), given


# ---------------------------------------------------------------------- cache of solutions
class SolutionCache:
    """Solutions by (exercise file and its date, variant), least recently used dropped first;
    shared by every browser tab (a solution is never modified after solving)."""

    def __init__(self, size: int = 48):
        self.size = size
        self._items: "OrderedDict[str, Solution]" = OrderedDict()
        self._lock = threading.Lock()

    @staticmethod
    def key(exercise: Exercise, values: Mapping[str, Any]) -> str:
        stamp = 0.0
        if exercise.source and Path(exercise.source).exists():
            stamp = Path(exercise.source).stat().st_mtime
        return json.dumps([exercise.source or exercise.id, stamp, sorted(values.items())], default=str)

    def get(self, exercise: Exercise, values: Mapping[str, Any]) -> Optional[Solution]:
        k = self.key(exercise, values)
        with self._lock:
            sol = self._items.get(k)
            if sol is not None:
                self._items.move_to_end(k)
            return sol

    def solve(self, exercise: Exercise, values: Mapping[str, Any],
              progress: Optional[Callable[[float, str], None]] = None) -> Solution:
        """The cached solution, or solve now (``values``: parsed field values of a variant)."""
        cached = self.get(exercise, values)
        if cached is not None:
            return cached
        ex, given = apply_variant(exercise, values)
        sol = in_worker(solve, ex, given=given, progress=progress)     # in the server: a worker process
        with self._lock:
            self._items[self.key(exercise, values)] = sol
            while len(self._items) > self.size:
                self._items.popitem(last=False)
        return sol


SOLUTIONS = SolutionCache()
