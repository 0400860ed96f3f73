"""Equilibria of a robot's model in closed form.

Task kind (options -> answers):

- ``equilibria``: all solutions of g(q) + k(q) = 0 in closed form, angles in (-pi, pi]; each
  coefficient multiplying a trigonometric function is assumed nonzero (generic parameters).
  Options: ``springs`` (include spring forces, default true). Answers: ``equilibria`` (one row per
  configuration, sorted by their values at the parameters' numbers), ``equilibria_count``.
  Also accepts ``suffix`` and ``substitute`` (parameter -> expression, applied to the model first).

>>> from app.core.exercise import parse_exercise, solve
>>> ex = parse_exercise({"id": "x", "robot": "planar_2r", "question": "?",
...                      "tasks": [{"kind": "equilibria"}]})
>>> solve(ex).answers["equilibria"]
Matrix([
[-pi/2,  0],
[-pi/2, pi],
[ pi/2,  0],
[ pi/2, pi]])
"""
from __future__ import annotations

import itertools
import math
from typing import Dict, List, Optional, Sequence, Tuple

import sympy as sp

from ..exercise import ExerciseError
from ..mathtext import symbols_text
from ..trig import TrigPoly
from . import task
from .context import TaskView, wrap_angle


def _primitive(freqs: List[Dict[sp.Symbol, int]]) -> Optional[Tuple[Dict[sp.Symbol, int], List[int]]]:
    """A primitive frequency v with every frequency an integer multiple of it, and the multiples."""
    base = freqs[0]
    g = 0
    for n in base.values():
        g = math.gcd(g, abs(n))
    v = {s: n // g for s, n in base.items()}
    first = next(iter(sorted(v, key=lambda s: s.name)))
    if v[first] < 0:
        v = {s: -n for s, n in v.items()}
    multiples = []
    for f in freqs:
        if set(f) != set(v):
            return None
        k = sp.Rational(f[first], v[first])
        if not k.is_Integer or any(f[s] != k * v[s] for s in v):
            return None
        multiples.append(int(k))
    return v, multiples


def _solve_angle(tp: TrigPoly, t: sp.Symbol) -> List[sp.Expr]:
    """Solutions in (-pi, pi] of a trigonometric polynomial of one angle t (A cos t + B sin t = 0
    in closed form, anything else through sympy)."""
    A = B = C0 = sp.Integer(0)
    simple = True
    for (freq, kind), coeff in tp.terms.items():
        if not freq:
            C0 += coeff
        elif dict(freq).get(t) == 1 and len(freq) == 1:
            if kind == "c":
                A += coeff
            else:
                B += coeff
        else:
            simple = False
    if simple and C0 == 0:
        if B == 0:
            sols = [-sp.pi / 2, sp.pi / 2]
        elif A == 0:
            sols = [sp.Integer(0), sp.pi]
        else:
            t0 = sp.atan(sp.cancel(-A / B))
            sols = [t0, t0 + sp.pi]
    else:
        sols = sp.solve(tp.to_expr(), t)
        sols = [s for s in sols if s.is_real is not False]
    out = []
    for s in sols:
        s = wrap_angle(sp.simplify(s))
        if s not in out:
            out.append(s)
    return out


class EquilibriumSolver:
    """Closed-form solutions of a system of trigonometric-polynomial equations in the coordinates.

    At each stage it takes the equation with the fewest unknowns that either depends on one
    integer combination of angles only (solved for that combination, which fixes the last
    coordinate in it) or is a polynomial in a single coordinate; otherwise it splits a product."""

    def __init__(self, unknowns: Sequence[sp.Symbol], angles: Sequence[sp.Symbol], log):
        self.unknowns = list(unknowns)
        self.angles = set(angles)
        self.log = log          # callback(kind, equation, variable, values)
        self.counter = itertools.count()
        self.opaque: Dict[sp.Symbol, sp.Expr] = {}   # placeholder -> sin/cos of parameters only

    def hide(self, expr) -> sp.Expr:
        """Replace sines and cosines of parameters (e.g. sin(alpha)) by placeholder symbols, so
        that only the unknowns count as angles."""
        expr = sp.sympify(expr)
        unknowns = set(self.unknowns)
        mixed = {f: sp.expand_trig(f) for f in expr.atoms(sp.sin, sp.cos)
                 if f.free_symbols & unknowns and f.free_symbols - unknowns}
        expr = sp.expand(expr.xreplace(mixed)) if mixed else expr
        repl = {}
        for f in expr.atoms(sp.sin, sp.cos):
            if not f.free_symbols & set(self.unknowns):
                for ph, orig in self.opaque.items():
                    if orig == f:
                        repl[f] = ph
                        break
                else:
                    ph = sp.Dummy(f"trig{len(self.opaque)}")
                    self.opaque[ph] = f
                    repl[f] = ph
        return expr.xreplace(repl)

    def reveal(self, expr) -> sp.Expr:
        return sp.sympify(expr).xreplace(self.opaque)

    def solve(self, equations: List[Tuple[int, sp.Expr]], assigned: Dict[sp.Symbol, sp.Expr]) -> List[Dict]:
        """Solutions of the (row index, expression) equations given the values ``assigned``."""
        eqs = []
        for row, e in equations:
            tp = TrigPoly.from_expr(sp.expand(self.hide(e))).expand()
            if tp.is_zero():
                continue
            if not self._unknowns_in(tp):
                return []          # a nonzero constant: no solution on this branch
            eqs.append((row, tp))
        if not eqs:
            return [assigned]
        options = []
        for idx, (_row, tp) in enumerate(eqs):
            kind = self._classify(tp)
            if kind is not None:
                options.append((len(self._unknowns_in(tp)), 0 if kind[0] == "angle" else 1, idx, kind))
        if not options:
            for idx, (row, tp) in enumerate(eqs):
                factors = self._factors(tp)
                if len(factors) > 1:
                    rest = [(r, e.to_expr()) for j, (r, e) in enumerate(eqs) if j != idx]
                    out = []
                    self.log("factor", row, self.reveal(tp.to_expr()), None, [self.reveal(f) for f in factors])
                    for f in factors:
                        out += self.solve([(row, f)] + rest, dict(assigned))
                    return out
            raise ExerciseError("equilibria: the equations " + ", ".join(str(self.reveal(e.to_expr())) for _r, e in eqs)
                                + " have no closed-form solution the engine can find")
        _n, _pref, idx, kind = min(options, key=lambda o: o[:3])
        row, tp = eqs[idx]
        rest = [(r, e.to_expr()) for j, (r, e) in enumerate(eqs) if j != idx]
        out = []
        if kind[0] == "angle":
            v, multiples = kind[1], kind[2]
            t = sp.Dummy(f"t{next(self.counter)}")
            shifted = TrigPoly({(((t, m),) if freq else (), k): c
                                for ((freq, k), c), m in zip(tp.terms.items(), multiples)})
            values = _solve_angle(shifted, t)
            combo = sp.Add(*[n * s for s, n in v.items()])
            target = max((s for s in v if abs(v[s]) == 1), key=self.unknowns.index)
            self.log("angle", row, self.reveal(tp.to_expr()), combo, [self.reveal(v) for v in values])
            for val in values:
                expr = sp.expand((val - (combo - v[target] * target)) / v[target])
                new = {s: sp.expand(e.subs(target, expr)) for s, e in assigned.items()}
                new[target] = expr
                out += self.solve([(r, sp.expand(e.subs(target, expr))) for r, e in rest], new)
        else:
            var = kind[1]
            values = [s for s in sp.solve(tp.to_expr(), var) if s.is_real is not False]
            self.log("poly", row, self.reveal(tp.to_expr()), var, [self.reveal(v) for v in values])
            for val in values:
                new = {s: sp.expand(e.subs(var, val)) for s, e in assigned.items()}
                new[var] = val
                out += self.solve([(r, sp.expand(e.subs(var, val))) for r, e in rest], new)
        return out

    def _unknowns_in(self, tp: TrigPoly) -> set:
        out = set()
        for (freq, _k), c in tp.terms.items():
            out |= {s for s, _ in freq} | (c.free_symbols & set(self.unknowns))
        return out & set(self.unknowns)

    def _classify(self, tp: TrigPoly):
        in_coeffs = set()
        freqs = []
        for (freq, _k), c in tp.terms.items():
            in_coeffs |= c.free_symbols & set(self.unknowns)
            if freq:
                freqs.append(dict(freq))
        if not in_coeffs and freqs:
            prim = _primitive([f for f in freqs])
            if prim is not None and any(abs(n) == 1 for n in prim[0].values()):
                multiples = []
                it = iter(prim[1])
                for (freq, _k) in tp.terms:
                    multiples.append(next(it) if freq else 0)
                return ("angle", prim[0], multiples)
        if not freqs and len(in_coeffs) == 1:
            return ("poly", next(iter(in_coeffs)))
        if not freqs and in_coeffs:
            # linear in some unknown with a coefficient free of unknowns (a chain of springs): solve for
            # the last such unknown
            expr = tp.to_expr()
            for var in sorted(in_coeffs, key=self.unknowns.index, reverse=True):
                coeff = sp.expand(expr).coeff(var, 1)
                if sp.degree(expr, var) == 1 and coeff != 0 and not coeff.free_symbols & set(self.unknowns):
                    return ("poly", var)
        return None

    def _factors(self, tp: TrigPoly) -> List[sp.Expr]:
        factored = sp.factor(tp.to_expr())
        parts = [f for f in sp.Mul.make_args(factored) if f.free_symbols & set(self.unknowns)]
        parts = [f.base if f.is_Pow and f.exp.is_Integer and f.exp > 0 else f for f in parts]
        return parts


@task("equilibria")
def equilibria_task(ctx, spec):
    """Configurations with g(q) + k(q) = 0 (see the module docstring)."""
    a = TaskView(ctx, spec, "equilibria")
    rhs = a.g + (a.k if spec.get("springs", True) else sp.zeros(len(a.coords), 1))
    a.ctx.step("Equilibrium condition", rf"g(q) {'+ k(q) ' if a.robot.springs and spec.get('springs', True) else ''}= {a.L(rhs)} = 0",
               "At rest and without inputs the robot stays still exactly where the potential forces vanish.",
               bodies=[b.name for b in a.robot.bodies])
    def log(kind, row, equation, variable, values):
        vals = ", ".join(a.L(v) for v in values)
        if kind == "angle":
            coords = [s for s in a.q if s in variable.free_symbols]
            bodies = [b.name for b in a.robot.bodies if any(b.name in a.bodies_moved_by(s) for s in coords)]
            a.ctx.step(f"Row {row + 1}: solve for ${a.L(variable)}$", rf"{a.L(equation)} = 0 \;\Rightarrow\; {a.L(variable)} \in \{{{vals}\}}",
                       "This equation depends on one combination of angles only (its coefficient is assumed nonzero).",
                       bodies=bodies)
        elif kind == "poly":
            a.ctx.step(f"Row {row + 1}: solve for ${a.L(variable)}$", rf"{a.L(equation)} = 0 \;\Rightarrow\; {a.L(variable)} \in \{{{vals}\}}",
                       "Solved for one coordinate: the equation is a polynomial in it once the angles (and the coordinates solved later) are fixed.",
                       bodies=a.bodies_moved_by(variable))
        else:
            a.ctx.step(f"Row {row + 1}: split a product", rf"{a.L(equation)} = 0 \;\Rightarrow\; "
                       + r"\;\text{or}\; ".join(f"{a.L(f)} = 0" for f in values),
                       "A product vanishes when one of its factors does: each factor is a branch.")

    solver = EquilibriumSolver(list(a.q), a.angle_coordinates(), log)
    branches = solver.solve(list(enumerate(rhs)), {})
    rows = []
    for sol in branches:
        row = []
        for s in a.q:
            value = sol.get(s, s)
            for _ in range(len(a.q)):
                value = sp.expand(value.subs(sol))
            value = solver.reveal(value)
            value = wrap_angle(value) if s in solver.angles else sp.simplify(value)
            row.append(value)
        if row not in rows:
            rows.append(row)
    values = a.parameter_values()

    def key(row):
        out = []
        for e in row:
            try:
                out.append(round(float(e.subs(values)), 9))
            except TypeError:
                out.append(0.0)
        return out

    rows.sort(key=key)
    table = sp.Matrix(rows) if rows else sp.zeros(0, len(a.coords))
    a.ctx.step("Equilibria", rf"q_e \in {a.L(table)}" if rows else r"\text{none}",
               f"{len(rows)} equilibrium configuration(s), one per row "
               f"({symbols_text(a.coords)}); coordinates that do not appear stay free.",
               bodies=[b.name for b in a.robot.bodies])
    a.answer("equilibria", table)
    a.answer("equilibria_count", len(rows))
