"""``python -m app solve EXERCISE [--json] [--out FILE.md] [--latex FILE.tex] [--set name=value ...]``

EXERCISE is a shipped exercise id (e.g. 2004-03-25#1) or a path to an exercise file (which may
name its robot file by a path relative to itself). Prints the steps and the final answers.

JSON output (a stable contract): one object with keys "id", "title", "robot", "steps" (list of
{"title", "latex", "text", "highlight", "notes"}: "notes" lists the notes on the printed solution
that concern that step), "answers" (name -> string that ``sympy.sympify`` parses back, a number, or
nested lists of those; full precision) and "notes" (every note, in the file's order).

Without ``--json`` the terminal gets every step: title, explanation and formulas in Unicode math
(matrices laid out over several lines), numbers rounded to meaningful digits. ``--latex FILE``
writes the solution as a LaTeX fragment (amsmath; app/core/tex.py; ``-``: standard output).
"""
from __future__ import annotations

import json
import math
import sys

NAME = "solve"
HELP = "solve an exercise step by step (shipped id or exercise file)"


def add_arguments(p):
    p.add_argument("exercise", help="exercise id (see `python -m app exercises`) or a path to an exercise file")
    p.add_argument("--json", action="store_true", help="print one JSON object (stable format)")
    p.add_argument("--out", help="write the solution as Markdown (with LaTeX) to this file")
    p.add_argument("--latex", metavar="FILE",
                   help="write the solution as a LaTeX fragment (amsmath) to FILE ('-': standard output)")
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                   help="change a given value (a variant); repeatable")


def jsonable(value):
    """Answers -> JSON: sympy objects become strings, matrices nested lists, numbers stay numbers."""
    import numpy as np
    import sympy as sp
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
    """The solution as text or JSON (from app.core.output_cache, without sympy, when this exercise
    file was solved so before), or written as Markdown / LaTeX."""
    if args.out or args.latex:
        return _run(args)[0]
    from app.core import output_cache
    options = {"json": args.json, "set": list(args.set),
               "width": None if args.json else output_cache.terminal_width()}
    return output_cache.run_cached("solve", output_cache.exercise_file(args.exercise), options, lambda: _run(args))


def _run(args):
    """(exit code, [(reference, path)] of the robot file the solution read)."""
    from app.commands._options import assignments
    from app.core.exercise import load_exercise, solve
    from app.core.expressions import parse_number

    ex = load_exercise(args.exercise)
    variant = assignments(args.set)
    given = {name: parse_number(text, name) for name, text in variant.items()}
    sol = solve(ex, given)
    if args.out:
        with open(args.out, "w", encoding="utf-8") as fh:
            fh.write(sol.markdown())
    if args.latex:
        from app.commands.derive import write_text
        from app.core.tex import solution_tex
        write_text(args.latex, solution_tex(sol, variant), "--latex", quiet=args.json)
        if not args.json:
            return 0, ()
    if args.json:
        out = {"id": ex.id, "title": ex.title, "robot": sol.robot.name,
               "steps": [{**s.as_dict(), "notes": sol.step_notes(k)} for k, s in enumerate(sol.steps)],
               "answers": {k: jsonable(v) for k, v in sol.answers.items()}, "notes": sol.notes}
        json.dump(out, sys.stdout)
        sys.stdout.write("\n")
        return 0, [(ex.robot_ref, sol.robot.source)]
    print(terminal_text(sol))
    return 0, [(ex.robot_ref, sol.robot.source)]


def terminal_text(sol) -> str:
    """The solution for a terminal: each step's title, explanation and formulas in Unicode math,
    the notes on the printed solution under the step they concern, then the answers (rounded)."""
    from app.core.mathtext import latex_to_unicode, to_unicode
    from app.core.formula_layout import split_top_level
    ex = sol.exercise
    out = [f"{ex.id}: {ex.title}", f"robot: {sol.robot.title}", "", ex.question.strip(), ""]
    for k, st in enumerate(sol.steps):
        out.append(f"{k + 1}. {to_unicode(st.title)}")
        if st.text:
            out.append(_indent(to_unicode(st.text)))
        for part in (split_top_level(st.latex) if st.latex else []):
            out.append(_indent(latex_to_unicode(part, display=True)))
        out += [_indent("⚠ Note on the printed solution: " + to_unicode(n)) for n in sol.step_notes(k)]
        out.append("")
    out.append("answers:")
    for name, value in sol.answers.items():
        out.append(_indent(f"{name} = " + answer_text(value, sol.robot.coordinates), "  ", hanging=len(name) + 3))
    out += ["", *("note: " + to_unicode(n) for n in sol.general_notes())]
    return "\n".join(out).rstrip() + "\n"


def _indent(text: str, prefix: str = "   ", hanging: int = 0) -> str:
    lines = text.splitlines() or [""]
    return "\n".join(prefix + (" " * hanging if i else "") + line for i, line in enumerate(lines))


def answer_text(value, coordinates=()) -> str:
    """An answer for reading: numbers to 6 significant digits (no 6e-17 noise), symbolic answers
    and matrices in Unicode math.

    >>> import numpy as np
    >>> answer_text(6.123e-17), answer_text(np.array([0.5, 1/3])), answer_text(True)
    ('0', '⎛ 0.5      ⎞\\n⎝ 0.333333 ⎠', 'yes')
    """
    import numpy as np
    import sympy as sp

    from app.core.mathtext import latex_to_unicode
    from app.core.steps import to_latex
    if isinstance(value, (bool, np.bool_)):
        return "yes" if value else "no"
    if isinstance(value, (float, np.floating)):
        return _number(float(value))
    if isinstance(value, (int, np.integer, str)) or value is None:
        return str(value)
    if isinstance(value, (list, tuple, np.ndarray)):
        try:
            arr = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            return str(jsonable(value))
        if arr.ndim == 0:
            return _number(float(arr))
        rows = arr.reshape(-1, 1) if arr.ndim == 1 else arr.reshape(arr.shape[0], -1)
        body = r"\\".join(" & ".join(_number(float(x)) for x in row) for row in rows)
        return latex_to_unicode(r"\begin{pmatrix}" + body + r"\end{pmatrix}", display=True)
    if isinstance(value, (sp.Basic, sp.MatrixBase)):
        return latex_to_unicode(to_latex(value, list(coordinates)), display=True)
    return str(jsonable(value))


def _number(x: float) -> str:
    if not math.isfinite(x):
        return str(x)
    if abs(x) < 1e-12:
        return "0"
    return f"{x:.6g}"
