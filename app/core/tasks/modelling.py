"""Modelling tasks: the Lagrangian model, its factorizations and linear parametrizations.

Answers produced (names used by the expected-answer files):
- ``dynamics``: M, C, c, g, spring, friction, C1..Cn (Christoffel matrices, c_i = dq^T C_i dq),
  T_<body> (kinetic energy per body), U (potential energy), p_<body> (CoM positions),
  v_<body> (CoM velocities), w_<body> (angular velocity in the body frame).
- ``regressor``: Y, a, regressor_count (and Y_r, the adaptive regressor; y0, the terms with no
  unknown parameter, when there are any: tau = Y a + y0).
"""
from __future__ import annotations

import sympy as sp

from ..mathtext import symbols_text
from ..steps import to_latex
from . import task


@task("dynamics")
def dynamics_task(ctx, spec):
    """Derive the model; ``show`` limits the steps shown (default: all the derivation steps)."""
    dyn = ctx.dynamics()
    show = spec.get("show")
    first = len(ctx.steps)
    for st in dyn.steps:
        if st.title in ("Linear parametrization", "Adaptive regressor"):
            continue
        if show and not any(st.title.lower().startswith(s.lower()) for s in show):
            continue
        ctx.steps.append(st)
    ctx.answer("M", dyn.M)
    ctx.answer("C", dyn.C)
    ctx.answer("c", dyn.c)
    ctx.answer("g", dyn.g)
    ctx.answer("spring", dyn.spring)
    ctx.answer("friction", dyn.friction)
    for i, Ci in enumerate(dyn.christoffel, 1):
        ctx.answer(f"C{i}", Ci)
    for body, T in dyn.kinetic.items():
        ctx.answer(f"T_{body}", T)
    ctx.answer("U", sum(dyn.potential.values(), sp.Integer(0)))
    for body, p in dyn.com_positions.items():
        ctx.answer(f"p_{body}", p)
    for body, v in dyn.com_velocities.items():
        ctx.answer(f"v_{body}", v)
    for body, w in dyn.angular_velocities.items():
        ctx.answer(f"w_{body}", w)
    _tie_answers_to_steps(ctx, dyn, first)


def _tie_answers_to_steps(ctx, dyn, first: int) -> None:
    """Each answer of the model belongs to the derivation step that shows it (notes on the printed
    solution that name an answer are shown with that step)."""
    titles = {"M": "Inertia matrix", "g": "Gravity vector", "c": "Coriolis", "C": "Factorization",
              "U": "Potential energy", "spring": "Spring forces", "friction": "Friction"}
    titles.update({f"C{i}": f"Christoffel matrix $C_{{{i}}}$" for i in range(1, len(dyn.christoffel) + 1)})
    for body in dyn.kinetic:
        shown = body.replace("_", " ")
        titles[f"T_{body}"] = f"Kinetic energy of {shown}"
        for kind in ("p", "v", "w"):
            titles[f"{kind}_{body}"] = f"Kinematics of {shown}"
    for name, title in titles.items():
        hits = [k for k in range(first, len(ctx.steps)) if ctx.steps[k].title.startswith(title)]
        if name in ctx.answers and hits:
            ctx.answer_steps[name] = hits[0]


@task("regressor")
def regressor_task(ctx, spec):
    """Minimal linear parametrization tau = Y a; ``known`` lists the parameters taken as known."""
    dyn = ctx.dynamics(known=spec.get("known"))
    par = dyn.parametrization
    L = lambda e: to_latex(e, ctx.robot.coordinates)
    ctx.step("Dynamic coefficients",
             r"a = " + L(sp.Matrix(par.a)),
             f"Collect the model in products of unknown parameters; columns that are combinations of "
             f"others merge, leaving {par.count} independent coefficients (known: {symbols_text(par.known)}).")
    ctx.step("Regressor", r"Y(q,\dot q,\ddot q) = " + L(par.Y), r"$Y a$ reproduces $M \ddot q + c + g$ (plus springs and friction).")
    ctx.answer("Y", par.Y)
    ctx.answer("a", sp.Matrix(par.a))
    ctx.answer("regressor_count", par.count)
    ctx.answer("Y_r", par.Y_ref)
    if any(e != 0 for e in par.known_terms):
        ctx.step("Known terms", r"\tau = Y a + y_0,\quad y_0 = " + L(par.known_terms),
                 "Terms with no unknown parameter (a spring of known stiffness, say) stay outside Y a.")
        ctx.answer("y0", par.known_terms)
    if spec.get("adaptive"):
        ctx.step("Adaptive regressor", r"Y(q,\dot q,\dot q_r,\ddot q_r) = " + L(par.Y_ref),
                 r"With $\dot q_r = \dot q_d + \Lambda e$: $u = Y_r \hat a + K_D (\dot q_r - \dot q)$, $\dot{\hat a} = \Gamma Y_r^T (\dot q_r - \dot q)$.")
