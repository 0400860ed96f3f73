"""Models given as formulas: can they be a robot's, under which conditions, and which robot?
(core: app.core.definiteness).

``model_check``: a matrix M(q) (and optionally g(q)) of coefficients and coordinates, given by the
  exercise. Options: ``name`` (answer prefix, default M), ``matrix`` (list of rows of expressions),
  ``gravity`` (list), ``coordinates`` (default the robot's), ``positive`` (coefficients taken
  positive), ``inputs`` (generalized forces for q'' = M^-1 (u - g) at rest), ``single_input: true``
  (which coordinate alone can hold every equilibrium).
  Answers ``<name>_symmetric``, ``<name>_depends_on_first`` (M may not depend on q1: the base frame
  is arbitrary), ``<name>_relative`` (T^T M T in relative coordinates p1 = q1, p_k = q_k - q_(k-1),
  when M depends on q1), ``<name>_blocks`` (1-based index lists), ``<name>_minors`` (leading minors
  of each block), ``<name>_minima`` (their minima over q: all positive <=> M > 0 for every q),
  ``<name>_diagonal_minima``, ``<name>_conditions`` (the minima and diagonal minima, each > 0,
  without repetitions), ``<name>_positive_definite`` (True / False when decided with ``positive``),
  ``<name>_det``, ``<name>_det_max``, ``<name>_ddq_rest``, ``<name>_equilibrium_inputs``
  (1-based), ``<name>_u_equilibrium``.
``identify_robot``: does the exercise's robot have this model, and for which values?
  ``M``, ``g`` (expressions of the robot's coordinates and of unknowns), ``unknowns`` (names to
  solve for: coefficients of the given model or free parameters of the robot, e.g. a twist angle).
  Answers ``<name>_det`` (det of the robot's M), ``<name>_matches`` (True when a solution makes both models equal for every q),
  ``<name>_<unknown>`` (its value, or the list of values), ``<name>_count`` (number of solutions).

Example (2019-06-17#2): ``{kind: model_check, matrix: [[a1 + (a2*cos(q2) + a3*cos(q2 + q3))**2, 0, 0],
[0, a4 + a5 + 2*a6*cos(q3), a5 + a6*cos(q3)], [0, a5 + a6*cos(q3), a5]]}`` gives the conditions
a1, a4 + a5 - 2|a6|, a4 a5 - a6^2, a5 > 0.
"""
from __future__ import annotations

from typing import List

import sympy as sp

from .. import definiteness as df
from ..exercise import ExerciseError
from ..expressions import symbol
from ..steps import to_latex
from . import task
from .context import is_zero, wrap_angle


def _fail(ctx, kind: str, what: str) -> ExerciseError:
    return ExerciseError(f"{ctx.exercise.source or ctx.exercise.id}: {kind}.{what}")


def _matrix(ctx, raw, kind: str, where: str) -> sp.Matrix:
    if not isinstance(raw, list) or not raw:
        raise _fail(ctx, kind, f"{where}: expected a list of rows")
    rows = raw if isinstance(raw[0], list) else [[x] for x in raw]
    if len({len(r) for r in rows}) != 1:
        raise _fail(ctx, kind, f"{where}: rows of different lengths")
    return sp.Matrix([[ctx.expr(v, f"{kind}.{where}") for v in r] for r in rows])


def _decide(values: List[sp.Expr], positive) -> object:
    """True when every value is positive under the assumptions, False when one is never positive."""
    pos = {s: sp.Symbol(s.name, positive=True) for s in positive}
    signs = [sp.simplify(v.xreplace(pos)) for v in values]
    if all(s.is_positive for s in signs):
        return True
    if any(s.is_nonpositive for s in signs):
        return False
    return None


@task("model_check")
def model_check_task(ctx, spec):
    """Can this matrix be a robot's inertia matrix, and when (see the module docstring)?"""
    kind = "model_check"
    name = str(spec.get("name", "M"))
    M = _matrix(ctx, spec.get("matrix"), kind, "matrix")
    n = M.rows
    if M.cols != n:
        raise _fail(ctx, kind, "matrix: an inertia matrix is square")
    coords = [symbol(c) for c in (spec.get("coordinates") or ctx.robot.coordinates[:n])]
    if len(coords) != n:
        raise _fail(ctx, kind, f"coordinates: expected {n} names")
    positive = [symbol(p) for p in (spec.get("positive") or [])]
    L = lambda X: to_latex(X, [c.name for c in coords])
    ans = lambda key, value: ctx.answer(f"{name}_{key}", value)
    symmetric = all(is_zero(M[i, j] - M[j, i]) for i in range(n) for j in range(i + 1, n))
    first = any(coords[0] in e.free_symbols for e in M)
    ctx.step(f"Structure of ${L(sp.Symbol(name))}$", rf"{name}(q) = {L(M)}",
             ("Symmetric" if symmetric else "Not symmetric: not an inertia matrix") + "; "
             + (f"it depends on {coords[0]}, the coordinate of the first joint: a robot's inertia matrix cannot, "
                "since the choice of the base frame (and of the zero of q1) is arbitrary." if first
                else f"it does not depend on {coords[0]}, as it must (the base frame is arbitrary)."))
    ans("symmetric", symmetric)
    ans("depends_on_first", first)
    if first and n > 1:
        p = [symbol(f"p{i + 1}") for i in range(n)]
        Mp = df.relative_form(M, coords, p)
        still = any(p[0] in e.free_symbols for e in Mp)
        ctx.step("In relative coordinates", rf"p_1 = q_1,\ p_k = q_k - q_{{k-1}}:\quad T^T {name} T = {to_latex(Mp, [s.name for s in p])}",
                 ("It still depends on p1: no robot has this inertia matrix." if still else
                  "It depends on the differences only: the matrix of a robot written in absolute coordinates "
                  "(e.g. a parallelogram arm), which becomes a function of p2, ... only."))
        ans("relative", Mp)
        ans("relative_depends_on_first", still)
    groups = blocks = df.blocks(M)
    minors, minima, diag_minima = [], [], []
    try:
        for g in groups:
            B = M.extract(g, g)
            for m in df.leading_minors(B):
                minors.append(m)
                minima.append(df.minimum(m, coords, positive))
        for i in range(n):
            diag_minima.append(df.minimum(M[i, i], coords, positive))
    except df.DefinitenessError as exc:
        raise _fail(ctx, kind, f"matrix: {exc} (no closed-form condition for every q)") from None
    conditions = []
    for c in minima + diag_minima:
        if not any(is_zero(c - d) for d in conditions):
            conditions.append(c)
    ctx.step("Leading minors of each block", r",\quad ".join(rf"\Delta_{{{k + 1}}} = {L(m)}" for k, m in enumerate(minors)),
             f"Blocks {', '.join(str([i + 1 for i in g]) for g in blocks)}: M > 0 for every q iff each of these stays positive (Sylvester).")
    ctx.step("Their smallest values over q", r",\quad ".join(rf"\min_q \Delta_{{{k + 1}}} = {L(m)}" for k, m in enumerate(minima)),
             r"A function of one cosine (or sine) reaches its extremes at $\cos = \pm 1$ (or at the vertex); a square reaches 0.")
    ctx.step("Conditions on the coefficients", r",\quad ".join(f"{L(c)} > 0" for c in conditions),
             "Necessary and sufficient for a positive definite M at every configuration (the diagonal entries too, necessarily).")
    ans("blocks", [[i + 1 for i in g] for g in blocks])
    ans("minors", sp.Matrix(minors))
    ans("minima", sp.Matrix(minima))
    ans("diagonal_minima", sp.Matrix(diag_minima))
    ans("conditions", sp.Matrix(conditions))
    det = sp.factor(M.det())
    ans("det", det)
    try:
        det_max = df.maximum(sp.expand(det), coords, positive)
        ans("det_max", det_max)
    except df.DefinitenessError:
        det_max = None
    if positive:
        decided = _decide(conditions, positive)
        nowhere = det_max is not None and _decide([det_max], positive) is False
        if nowhere:
            decided = False
        if decided is not None:
            ans("positive_definite", decided)
            ctx.step("Verdict", rf"\det {name} = {L(det)}" + (rf",\ \max_q \det {name} = {L(det_max)}" if nowhere else ""),
                     "Positive definite for every q with the stated positive coefficients." if decided else
                     (r"$\det M \le 0$ at every configuration: $M$ is positive definite nowhere, not the inertia matrix of a robot."
                      if nowhere else "Not positive definite for every q: not the inertia matrix of a robot."))
    _forces(ctx, spec, M, coords, name, L)


def _forces(ctx, spec, M, coords, name, L):
    kind = "model_check"
    n = M.rows
    if spec.get("gravity") is None:
        return
    g = _matrix(ctx, spec["gravity"], kind, "gravity")
    if g.shape != (n, 1):
        raise _fail(ctx, kind, f"gravity: expected {n} entries")
    ctx.step("Gravity", rf"g(q) = {L(g)}", "")
    if spec.get("single_input"):
        ok = [i + 1 for i in range(n) if all(is_zero(g[j]) for j in range(n) if j != i)]
        ctx.step("One input at an equilibrium", rf"g(q) = S u_a \Rightarrow" + (
                 r",\ ".join(rf"\ u_a\ \text{{on}}\ {L(coords[i - 1])} = {L(g[i - 1])}" for i in ok) if ok else r"\ \text{none}"),
                 r"At rest ($\ddot q = \dot q = 0$) the input must balance gravity, so every unactuated row of $g$ must vanish.")
        ctx.answer(f"{name}_equilibrium_inputs", ok)
        if len(ok) == 1:
            ctx.answer(f"{name}_u_equilibrium", g[ok[0] - 1])
    if spec.get("inputs") is not None:
        u = _matrix(ctx, spec["inputs"], kind, "inputs")
        ddq = M.LUsolve(u - g).applyfunc(lambda e: sp.factor(sp.cancel(e)))
        ctx.step("Accelerations from rest", rf"\ddot q = {name}^{{-1}} (u - g) = {L(ddq)}", "")
        ctx.answer(f"{name}_ddq_rest", ddq)


@task("identify_robot")
def identify_robot_task(ctx, spec):
    """Values that make the exercise's robot have a given model (see the module docstring)."""
    kind = "identify_robot"
    name = str(spec.get("name", "model"))
    dyn = ctx.dynamics()
    robot = ctx.robot
    M = _matrix(ctx, spec.get("M"), kind, "M")
    if M.shape != dyn.M.shape:
        raise _fail(ctx, kind, f"M: the robot has {robot.n} coordinates")
    eqs = [M[i, j] - dyn.M[i, j] for i in range(M.rows) for j in range(i, M.cols)]
    if spec.get("g") is not None:
        g = _matrix(ctx, spec["g"], kind, "g")
        eqs += [g[i] - (dyn.g + dyn.spring)[i] for i in range(robot.n)]
    unknowns = [symbol(u) for u in (spec.get("unknowns") or [])]
    conditions = []
    for e in eqs:                      # each coefficient of each function of q must match
        e = sp.expand(e)
        qs = [s for s in robot.q if s in e.free_symbols]
        if not qs:
            conditions.append(e)
            continue
        terms = sp.collect(e, [f for f in e.atoms(sp.sin, sp.cos) if f.free_symbols & set(robot.q)] + qs, evaluate=False)
        conditions += [c for c in terms.values()]
    conditions = [c for c in (sp.simplify(c) for c in conditions) if c != 0]
    sols = sp.solve(conditions, unknowns, dict=True) if conditions else [{}]
    if unknowns and sols:
        sols = [s for s in sols if all(s.get(u, u).is_real is not False for u in unknowns)]
    matches = bool(sols)
    L = lambda X: to_latex(X, robot.coordinates)
    ctx.step("The robot's model", rf"M(q) = {L(dyn.M)},\quad g(q) = {L(dyn.g + dyn.spring)}",
             f"From the robot file ({robot.title}).", bodies=[b.name for b in robot.bodies])
    ctx.step("Matching the given model", r",\quad ".join(f"{L(c)} = 0" for c in conditions) if conditions else r"\text{identical}",
             "Every coefficient of each function of q must agree.")
    det = sp.factor(sp.expand(dyn.M.det()))
    ctx.step("Determinant of the robot's inertia matrix", rf"\det M = {L(det)}", "")
    ctx.answer(f"{name}_det", det)
    ctx.answer(f"{name}_matches", matches)
    ctx.answer(f"{name}_count", len(sols))
    for u in unknowns:
        vals = [wrap_angle(sp.simplify(s[u])) for s in sols if u in s]
        vals = sorted(set(vals), key=lambda v: float(v) if v.is_number else 0.0)
        if vals:
            ctx.answer(f"{name}_{u.name}", vals[0] if len(vals) == 1 else sp.Matrix(vals))
    if matches:
        text = ", ".join(f"{L(u)} = {', '.join(L(s[u]) for s in sols if u in s)}" for u in unknowns) or "no free value"
        ctx.step("The robot has this model", text, "The given model is that of this robot with these values.")
    else:
        ctx.step("Not this robot", r"\text{no solution}", "No values of the unknowns make the two models equal for every q.")
