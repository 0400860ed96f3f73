"""Static equilibria with passive coordinates and (nonlinear) springs, and the input that holds them.

``static_equilibrium``: at rest the model reduces to g(q) + k(q) = S u (k: spring forces, any
expression in the robot file, e.g. a linear and a cubic spring k delta + k_n delta^3 on
delta = theta - q). Options: ``fixed`` (coordinate -> value or expression: the known coordinates,
e.g. a motor position or a desired link position), ``solve_for`` (the unknown coordinates;
default those not fixed), ``rows`` (coordinates whose generalized force must vanish; default the
passive ones, then as many as unknowns), ``guess`` (coordinate -> number: where a numeric root is
searched), ``substitute`` (parameter -> value). The rows are solved in closed form when sympy
finds a unique real solution at the exercise's numbers; otherwise, when every number is given,
numerically from ``guess``. Answers: ``equations`` (the rows, = 0), ``equilibrium`` (values of
``solve_for``), ``equilibrium_at`` (numbers), ``u_hold`` (g + k on the actuated coordinates at
the equilibrium), ``u_hold_at`` (numbers).

>>> from app.core.exercise import parse_exercise, solve
>>> ex = parse_exercise({"id": "x", "robot": "elastic_1link", "question": "?", "tasks": [
...     {"kind": "static_equilibrium", "fixed": {"theta": 0.5}}]})
>>> ans = solve(ex).answers
>>> ans["equilibrium"], ans["u_hold"]
(Matrix([[1/2]]), Matrix([[0]]))
"""
from __future__ import annotations

import numpy as np
import sympy as sp

from ..exercise import ExerciseError
from ..expressions import symbol
from ..numeric import numeric_function
from . import task
from .context import TaskView
from .underactuated import _given_values


def _real_solution(eqs, unknowns, numbers):
    """The unique real closed-form solution at the numbers, or None."""
    try:
        if len(unknowns) == 1 and len(eqs) == 1 and eqs[0].is_polynomial(unknowns[0]):
            sols = [{unknowns[0]: r} for r in sp.roots(sp.Poly(eqs[0], unknowns[0]), cubics=True, quartics=True)]
        else:
            sols = sp.solve(eqs, unknowns, dict=True)
    except (NotImplementedError, ValueError, sp.PolynomialError):
        return None
    real = []
    for s in sols:
        if set(s) != set(unknowns):
            continue
        vals = [complex(sp.N(s[u].subs(numbers))) for u in unknowns]
        if all(abs(v.imag) < 1e-9 * max(1.0, abs(v.real)) for v in vals):
            real.append(s)
    return real[0] if len(real) == 1 else None


@task("static_equilibrium")
def static_equilibrium_task(ctx, spec):
    """Equilibria with passive coordinates and springs, and the holding input (module docstring)."""
    from scipy.optimize import fsolve
    m = TaskView(ctx)
    fixed = {k: sp.nsimplify(v, rational=True) if v.is_Float else v
             for k, v in m.mapping(spec.get("fixed"), "static_equilibrium.fixed").items()}
    params = m.mapping_of_parameters(spec.get("substitute"), "static_equilibrium.substitute")
    unknowns = ([m.q[i] for i in m.indices(spec["solve_for"], "static_equilibrium.solve_for")] if "solve_for" in spec
                else [qk for qk in m.q if qk not in fixed])
    if not unknowns:
        raise ExerciseError("static_equilibrium: nothing to solve for (every coordinate is fixed)")
    passive = [i for i, a in enumerate(m.robot.actuated) if not a]
    rows = (m.indices(spec["rows"], "static_equilibrium.rows") if "rows" in spec
            else (passive + [i for i in range(len(m.coords)) if i not in passive])[:len(unknowns)])
    static = (m.dyn.g + m.dyn.spring).subs(params).subs(fixed)
    eqs = [sp.expand(static[i]) for i in rows]
    numbers = {p.symbol: p.value for p in m.robot.parameters.values()}
    numbers.update(_given_values(ctx))
    numbers.update(params)
    sol = _real_solution(eqs, unknowns, numbers)
    values = None
    if sol is not None:
        values = sp.Matrix([sol[u] for u in unknowns])
        how = "closed form (the only real solution at the exercise's numbers)"
    else:
        f = numeric_function([unknowns], [e.subs(numbers) for e in eqs], "numpy")
        guess = m.mapping(spec.get("guess"), "static_equilibrium.guess")
        x0 = [float(guess.get(u, 0.0)) for u in unknowns]
        try:
            x, info, ok, msg = fsolve(lambda x: np.asarray(f(list(x)), dtype=float), x0, full_output=True, xtol=1e-13)
        except (TypeError, ValueError):
            raise ExerciseError("static_equilibrium: no closed form, and not every number is given for a numeric "
                                "solution (give the parameters and the fixed coordinates in given)") from None
        if ok != 1 or np.max(np.abs(info["fvec"])) > 1e-9:
            raise ExerciseError(f"static_equilibrium: no equilibrium found from the guess {x0} ({msg.strip()})")
        values = sp.Matrix([sp.Float(v) for v in x])
        how = f"numerically from {x0}"
    at = dict(zip(unknowns, values))
    act = [i for i, a in enumerate(m.robot.actuated) if a]
    u = sp.Matrix([static[i].subs(at) for i in act])
    u = u.applyfunc(lambda e: sp.nsimplify(e) if e.is_number else e)
    L = m.L
    ctx.step("Equilibrium equations", r",\quad ".join(rf"{L(e)} = 0" for e in eqs),
             f"At rest g(q) + k(q) = S u; the rows of {', '.join(m.coords[i] for i in rows)} carry no input "
             f"(or must vanish), with {', '.join(f'{k} = {v}' for k, v in fixed.items()) or 'nothing'} fixed.",
             bodies=m.bodies_of(range(len(m.coords))))
    ctx.step("Equilibrium", r",\quad ".join(rf"{L(k)} = {L(v)}" for k, v in at.items()), f"Solved: {how}.")
    ctx.step("Input that holds it", rf"u = {L(u)}", "The static forces on the actuated coordinates at the equilibrium.",
             joints=[m.robot.bodies[i].name for i in act if i < len(m.robot.bodies)])
    ctx.answer("equations", sp.Matrix(eqs))
    ctx.answer("equilibrium", values)
    ctx.answer("u_hold", u)
    try:
        ctx.answer("equilibrium_at", np.array(values.subs(numbers).evalf(), dtype=float).reshape(-1))
        ctx.answer("u_hold_at", np.array(u.subs(numbers).evalf(), dtype=float).reshape(-1))
    except (TypeError, ValueError):
        pass
