"""``python -m app solve EXERCISE [--json] [--out FILE.md] [--set name=value ...]``

EXERCISE is a shipped exercise id (e.g. 2004-03-25#1) or a path to an exercise file (which may
name its robot file by a path relative to itself). Prints the steps and the final answers.

JSON output (a stable contract): one object with keys "id", "title", "robot", "steps" (list of
{"title", "latex", "text", "highlight"}), "answers" (name -> string that ``sympy.sympify`` parses
back, a number, or nested lists of those) and "notes".
"""
from __future__ import annotations

import json
import sys

import numpy as np
import sympy as sp

NAME = "solve"
HELP = "solve an exercise step by step (shipped id or exercise file)"


def add_arguments(p):
    p.add_argument("exercise", help="exercise id (see `python -m app exercises`) or a path to an exercise file")
    p.add_argument("--json", action="store_true", help="print one JSON object (stable format)")
    p.add_argument("--out", help="write the solution as Markdown (with LaTeX) to this file")
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                   help="change a given value (a variant); repeatable")


def jsonable(value):
    """Answers -> JSON: sympy objects become strings, matrices nested lists, numbers stay numbers."""
    if isinstance(value, sp.MatrixBase):
        if value.cols == 1:
            return [jsonable(e) for e in value]
        return [[jsonable(value[i, j]) for j in range(value.cols)] for i in range(value.rows)]
    if isinstance(value, np.ndarray):
        return jsonable(value.tolist())
    if isinstance(value, (list, tuple)):
        return [jsonable(v) for v in value]
    if isinstance(value, dict):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return float(value)
    if isinstance(value, sp.Basic):
        if value.is_Integer:
            return int(value)
        if value.is_Float:
            return float(value)
        return str(value)
    return value if isinstance(value, str) or value is None else str(value)


def run(args) -> int:
    from app.core.errors import UserError
    from app.core.exercise import load_exercise, solve
    from app.core.expressions import parse_number

    ex = load_exercise(args.exercise)
    given = {}
    for item in args.set:
        if "=" not in item:
            raise UserError(f"--set expects NAME=VALUE, got {item!r}")
        name, value = item.split("=", 1)
        given[name.strip()] = parse_number(value, name.strip())
    sol = solve(ex, given)
    if args.out:
        with open(args.out, "w", encoding="utf-8") as fh:
            fh.write(sol.markdown())
    if args.json:
        out = {"id": ex.id, "title": ex.title, "robot": sol.robot.name,
               "steps": [s.as_dict() for s in sol.steps],
               "answers": {k: jsonable(v) for k, v in sol.answers.items()}, "notes": sol.notes}
        json.dump(out, sys.stdout)
        sys.stdout.write("\n")
        return 0
    print(f"{ex.id}: {ex.title}\nrobot: {sol.robot.title}\n")
    print(ex.question.strip(), "\n")
    for k, st in enumerate(sol.steps, 1):
        print(f"{k}. {st.title}" + (f" — {st.text}" if st.text else ""))
    print("\nanswers:")
    for name, value in sol.answers.items():
        print(f"  {name} = {jsonable(value)}")
    for n in sol.notes:
        print(f"note: {n}")
    return 0
