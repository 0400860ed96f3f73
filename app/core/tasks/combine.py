"""Combining and evaluating earlier answers.

``combine``: an expression of earlier answers (matrices or scalars) and symbols, e.g. the
difference of two control laws ``u_fbl - u_glb``, simplified, and evaluated at given values.
Options: ``name``, ``expression``, ``at`` (symbol -> value or expression, which may name other given symbols), ``at_vectors``
(earlier vector answer -> the symbols its entries give values to, e.g. ``{q_d_at: [q1_d, q2_d]}``).
Answers: ``<name>`` (symbolic), ``<name>_at`` (with ``at``/``at_vectors``: the expression at
those values, exact), ``<name>_at_num`` (numbers, when no symbol is left).

>>> from app.core.exercise import parse_exercise, solve
>>> ex = parse_exercise({"id": "x", "robot": "planar_2r", "question": "?", "tasks": [
...     {"kind": "dynamics"}, {"kind": "combine", "name": "h", "expression": "2*g - g", "at": {"q2": 0}}]})
>>> ans = solve(ex).answers
>>> (ans["h"] - ans["g"]).applyfunc(sp.simplify).is_zero_matrix, ans["h_at"][1]
(True, d2*g0*m2*cos(q1))
"""
from __future__ import annotations

import numpy as np
import sympy as sp

from ..exercise import ExerciseError
from ..expressions import ExpressionError, parse_expression, symbol
from ..numeric import numeric_function
from ..steps import to_latex
from . import task


@task("combine")
def combine_task(ctx, spec):
    """An expression of earlier answers, simplified and evaluated (see the module docstring)."""
    name = str(spec.get("name", "combined"))
    text = spec.get("expression")
    try:
        expr = parse_expression(text)
    except (ExpressionError, TypeError) as exc:
        raise ExerciseError(f"combine.expression: {exc}") from None
    names = sorted(expr.free_symbols, key=lambda x: x.name)
    used = [s for s in names if s.name in ctx.answers]
    if not used:
        raise ExerciseError("combine.expression: it names no earlier answer")
    values = [ctx.answers[s.name] if not isinstance(ctx.answers[s.name], (list, np.ndarray))
              else sp.Matrix(ctx.answers[s.name]) for s in used]
    value = numeric_function(used, expr, "sympy")(*values)
    value = value.applyfunc(sp.expand) if isinstance(value, sp.MatrixBase) else sp.expand(value)
    L = lambda e: to_latex(e, list(ctx.robot.coordinates))
    ctx.step(f"{name}", rf"{text.replace('_', ' ')} = {L(value)}", "Combined from the earlier answers.")
    ctx.answer(name, value)
    sub = {symbol(str(k)): ctx.expr(v, f"combine.at.{k}") for k, v in (spec.get("at") or {}).items()}
    for ans, syms in (spec.get("at_vectors") or {}).items():
        vec = ctx.answers.get(ans)
        if vec is None or not isinstance(syms, list) or len(np.ravel(np.asarray(vec, dtype=object))) != len(syms):
            raise ExerciseError(f"combine.at_vectors.{ans}: an earlier vector answer and one symbol per entry")
        sub.update({symbol(str(x)): sp.nsimplify(v, [sp.pi]) if isinstance(v, float) else sp.sympify(v)
                    for x, v in zip(syms, np.ravel(np.asarray(vec, dtype=object)))})
    if not sub:
        return
    at = sp.sympify(value)
    for _ in range(4):          # values may name other symbols (e1: q1_d - q1): substitute until stable
        nxt = at.subs(sub)
        if nxt == at:
            break
        at = nxt
    at = at.applyfunc(sp.simplify) if isinstance(at, sp.MatrixBase) else sp.simplify(at)
    ctx.step(f"{name} at the given values", rf"{L(at)}", "The given values substituted.")
    ctx.answer(f"{name}_at", at)
    if not sp.sympify(at).free_symbols:
        ctx.answer(f"{name}_at_num", np.array(sp.N(at), dtype=float).reshape(-1))
