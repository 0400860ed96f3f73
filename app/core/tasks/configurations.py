"""Configurations that solve equations: singular configurations of a matrix (det = 0, e.g. of a
task Jacobian together with the task's own constraints, or of [J^T | e_i]), equilibria, or the
configurations where a term vanishes.

``configurations``: Options: ``equation`` (one expression of the coordinates = 0, or the name of an
earlier scalar answer; a system of equations is the ``equilibria`` task's job) or ``matrix`` (an earlier matrix answer, a given matrix, or
``{hstack: [...]}`` / ``{vstack: [...]}`` of answers (``J^T`` for a transpose) and literal
lists; square: det = 0, otherwise det(A A^T) = 0 for a wide A), ``substitute`` (parameter ->
expression, e.g. equal link lengths), ``name`` (answer prefix, default ``configurations``).
The equation is rewritten as a product (sums of sines and cosines turned into products) and
every factor that depends on the coordinates is solved for its last coordinate, angles in
(-pi, pi]. Answers: ``<name>_det`` (with ``matrix``: the factored determinant), ``<name>_factors``
(the factors that can vanish), ``<name>_solutions`` (rows [coordinate, value]: each a family
of configurations).

>>> from app.core.exercise import parse_exercise, solve
>>> ex = parse_exercise({"id": "x", "robot": "planar_2r", "question": "?", "configuration": {"q1": 0, "q2": 1}, "tasks": [
...     {"kind": "jacobian", "point": "ee"}, {"kind": "configurations", "matrix": "J"}]})
>>> solve(ex).answers["configurations_solutions"]
Matrix([
[q2,  0],
[q2, pi]])
"""
from __future__ import annotations

from typing import List

import sympy as sp
from sympy.simplify.fu import TR9

from ..exercise import ExerciseError
from ..expressions import symbol
from ..steps import to_latex
from . import task
from .context import tidy_cancelled, wrap_angle


def _matrix(ctx, raw, where: str) -> sp.Matrix:
    """An answer, a given matrix, a literal list, or {hstack|vstack: [items]} (item ``X^T``: transpose)."""
    if isinstance(raw, dict) and len(raw) == 1 and next(iter(raw)) in ("hstack", "vstack"):
        key, items = next(iter(raw.items()))
        parts = [_matrix(ctx, it, f"{where}.{key}") for it in items]
        try:
            return sp.Matrix.hstack(*parts) if key == "hstack" else sp.Matrix.vstack(*parts)
        except sp.ShapeError as exc:
            raise ExerciseError(f"{where}: blocks of different sizes ({exc})") from None
    if isinstance(raw, str):
        name, transpose = (raw[:-2], True) if raw.endswith("^T") else (raw, False)
        value = ctx.answers.get(name, ctx.given.get(name))
        if value is None:
            raise ExerciseError(f"{where}: '{name}' is neither an earlier answer nor a given matrix")
        m = sp.Matrix(value) if not isinstance(value, list) else _matrix(ctx, value, where)
        return m.T if transpose else m
    if isinstance(raw, list):
        rows = [r if isinstance(r, list) else [r] for r in raw]
        return sp.Matrix([[ctx.expr(e, where) for e in r] for r in rows])
    raise ExerciseError(f"{where}: expected a matrix (answer name, list of rows, or {{hstack: [...]}})")


def _product_form(expr) -> sp.Expr:
    """The canonical trigonometric form, its sums of sines/cosines as products (sum-to-product),
    then factored."""
    return sp.factor(TR9(tidy_cancelled(expr)))


def _solve_factor(factor, coords: List[sp.Symbol], angles, numbers) -> List[List[sp.Expr]]:
    """[coordinate, value] rows solving factor = 0 for its last coordinate (roots that are not real
    at the robot's numbers, with the other coordinates at 0.3, are dropped)."""
    last = [c for c in coords if c in factor.free_symbols][-1]
    try:
        roots = sp.solve(factor, last)
    except NotImplementedError:
        roots = []
    rows = []
    probe = {**numbers, **{c: sp.Float(0.3) for c in coords}}
    for r in roots:
        v = complex(sp.N(r.subs(probe)))
        if r.is_real is False or abs(v.imag) > 1e-9 * max(1.0, abs(v.real)):
            continue
        if last in angles:
            r = wrap_angle(sp.expand(r)) if r.is_number else sp.expand(r)
        if [last, r] not in rows:
            rows.append([last, r])
    return rows


@task("configurations")
def configurations_task(ctx, spec):
    """Configurations solving equations or making a matrix singular (see the module docstring)."""
    robot = ctx.robot
    coords = [symbol(c) for c in robot.coordinates]
    angles = {symbol(c) for b in robot.bodies if b.joint.type == "revolute"
              for c in robot.coordinates if symbol(c) in b.joint.value.free_symbols}
    name = spec.get("name", "configurations")
    sub = {symbol(str(k)): ctx.expr(v, f"configurations.substitute.{k}") for k, v in (spec.get("substitute") or {}).items()}
    L = lambda e: to_latex(e, list(robot.coordinates))
    if "matrix" in spec:
        A = _matrix(ctx, spec["matrix"], "configurations.matrix").subs(sub)
        sq = A if A.rows == A.cols else (A * A.T if A.rows < A.cols else None)
        if sq is None:
            raise ExerciseError(f"configurations.matrix: {A.rows}x{A.cols} has more rows than columns: give a square or wide matrix")
        det = _product_form(sq.det())
        ctx.step("Determinant", rf"\det {'A' if sq is A else 'A A^T'} = {L(det)},\quad A = {L(A)}",
                 "The matrix loses rank exactly where this determinant vanishes.")
        ctx.answer(f"{name}_det", det)
        eqs = [det]
    elif "equation" in spec:
        e = spec["equation"]
        e = sp.sympify(ctx.answers[e]) if isinstance(e, str) and e in ctx.answers else ctx.expr(e, "configurations.equation")
        if isinstance(e, sp.MatrixBase):
            raise ExerciseError("configurations.equation: one scalar equation (a system: the equilibria task)")
        eqs = [_product_form(e.subs(sub))]
    else:
        raise ExerciseError("configurations: give an equation or a matrix")
    numbers = {p.symbol: p.value for p in robot.parameters.values()}
    factors, rows = [], []
    for e in eqs:
        for f, _mult in sp.factor_list(e)[1]:
            if f.free_symbols & set(coords) and f not in factors:
                factors.append(f)
                rows += [r for r in _solve_factor(f, coords, angles, numbers) if r not in rows]
    if not factors:
        raise ExerciseError("configurations: the equations do not depend on the coordinates (never or always satisfied)")
    rows.sort(key=lambda r: (coords.index(r[0]), sp.default_sort_key(r[1])))
    ctx.step("Factors that can vanish", r",\quad ".join(rf"{L(f)} = 0" for f in factors),
             "Each factor gives a family of configurations.")
    ctx.step("Configurations", r",\quad ".join(rf"{L(c)} = {L(v)}" for c, v in rows),
             "Angles in (-pi, pi]; a value that depends on other coordinates is a one-parameter family.")
    ctx.answer(f"{name}_factors", factors)
    ctx.answer(f"{name}_solutions", sp.Matrix(rows) if rows else sp.zeros(0, 2))
