"""Cartesian impedance control of a robot with elastic joints, with the motor inertia reduced by
joint-torque feedback.

``elastic_impedance``: link dynamics M q'' + S q' + g = tau_J + J^T F, motor dynamics
B theta'' + tau_J = tau, tau_J = K (theta - q) (the robot file's motor/link pairs). The law
tau = (I - B B0^-1) tau_J + B B0^-1 (u - D0 theta') turns the motors into B0 theta'' + D0 theta'
+ tau_J = u; with tau_J ~ u the impedance law u = J^T (K_m (x_d - x) - D_m x') + g(q) completes the
design. Options: ``point`` (default ee), ``components`` (default x, y), ``Km``, ``Dm`` (diagonal),
``x_d``, ``force`` (the constant external force F on the end-effector), ``guess`` (configuration
where the search for the equilibrium starts; default the exercise's). Symbols B0_i, D0_i.
Answers: ``tau`` (the motor torque law, symbolic), ``motor_loop_residual`` (B0 theta'' + D0 theta'
+ tau_J - u under the law: zero), ``u`` (the impedance law), and at the equilibrium of the whole
elastic robot under F (solved numerically, robot file's numbers): ``q_E``, ``theta_E``, ``x_E``,
``x_E_check`` (|x_E - (x_d + K_m^-1 F)|), ``u_E``, ``u_E_check`` (|u_E - (g(q_E) - J^T F)|),
``tau_E_check`` (|tau_E - u_E|).

Example (2022-06-10#3):

    - {kind: elastic_impedance, Km: [500, 800], Dm: [40, 60], x_d: [0.55, 0.35], force: [10, -20]}
"""
from __future__ import annotations

import numpy as np
import sympy as sp

from .. import jacobians as jac
from ..errors import UserError
from ..exercise import ExerciseError
from ..expressions import symbol
from ..latex import num, vec
from ..numeric import NumericModel, numeric_function
from . import task
from .context import TaskView
from .underactuated import _elastic_pairs, _linear_stiffness


@task("elastic_impedance")
def elastic_impedance_task(ctx, spec):
    """Cartesian impedance of an elastic-joint robot (see the module docstring)."""
    m = TaskView(ctx)
    d = TaskView(ctx)
    pairs = _elastic_pairs(m)
    if not pairs:
        raise ExerciseError("elastic_impedance: the robot has no elastic joints (motor and link coordinates)")
    links = [p[0] for p in pairs]
    motors = [p[1] for p in pairs]
    Kj = [_linear_stiffness(p[2]) for p in pairs]
    n = len(links)
    comps = list(spec.get("components", ["x", "y"]))
    try:
        x = jac.task_function(m.robot, spec.get("point", "ee"), comps)
    except UserError as exc:
        raise ExerciseError(f"elastic_impedance.point: {exc}") from None
    qL = sp.Matrix([m.q[i] for i in links])
    dqL = sp.Matrix([m.dq[i] for i in links])
    th, dth, ddth = (sp.Matrix([v[i] for i in motors]) for v in (m.q, m.dq, m.ddq))
    J = x.jacobian(qL).applyfunc(sp.expand)
    if J.rows != n:
        raise ExerciseError(f"elastic_impedance.components: {n} components (a square task Jacobian)")
    g = sp.Matrix([m.dyn.g[i] for i in links])
    B = sp.diag(*[m.M[i, i] for i in motors])
    B0 = sp.diag(*[symbol(f"B0_{k + 1}") for k in range(n)])
    D0 = sp.diag(*[symbol(f"D0_{k + 1}") for k in range(n)])
    K = sp.diag(*Kj)
    tau_J = K * (th - qL)
    u = sp.Matrix([symbol(f"u{k + 1}") for k in range(n)])
    tau = (sp.eye(n) - B * B0.inv()) * tau_J + B * B0.inv() * (u - D0 * dth)
    residual = (B0 * B.inv() * (tau - tau_J - B * ddth) + B0 * ddth + D0 * dth + tau_J - u)
    residual = residual.applyfunc(lambda e_: sp.simplify(e_))
    ctx.answer("tau", tau.applyfunc(sp.expand))
    ctx.answer("motor_loop_residual", residual)
    Km = sp.diag(*[ctx.expr(v, "elastic_impedance.Km") for v in spec.get("Km", [f"Km{k + 1}" for k in range(n)])])
    Dm = sp.diag(*[ctx.expr(v, "elastic_impedance.Dm") for v in spec.get("Dm", [f"Dm{k + 1}" for k in range(n)])])
    x_d = sp.Matrix([ctx.expr(v, "elastic_impedance.x_d") for v in spec.get("x_d", [f"x_d{k + 1}" for k in range(n)])])
    u_law = (J.T * (Km * (x_d - x) - Dm * J * dqL) + g).applyfunc(sp.expand)
    ctx.answer("u", u_law)
    bodies = [b.name for b in m.robot.bodies]
    ctx.step("Motor inertia reduction", rf"\tau = (I - B B_0^{{-1}})\tau_J + B B_0^{{-1}}(u - D_0\dot\theta) = {m.L(tau)}",
             r"Substituted in $B \ddot\theta + \tau_J = \tau$ it gives $B_0 \ddot\theta + D_0 \dot\theta + \tau_J = u$: "
             r"fast motors, $\tau_J$ close to $u$.",
             joints=bodies)
    ctx.step("Cartesian impedance on the links", rf"u = J^T(K_m(x_d - x) - D_m \dot x) + g(q) = {m.L(u_law)}",
             r"With $\tau_J = u$ the link dynamics follow the impedance model with the natural Cartesian inertia.")
    if "force" not in spec:
        return
    F = np.asarray(d.array(spec["force"], "elastic_impedance.force"), float).reshape(-1)
    _equilibrium(ctx, m, d, spec, links, motors, K, x, J, g, u_law, tau, Km, x_d, F)


def _equilibrium(ctx, m, d, spec, links, motors, K, x, J, g, u_law, tau, Km, x_d, F):
    """The rest configuration of the whole elastic robot under the law and the force F: link statics
    g(q) = K (theta - q) + J^T F and motor statics K (theta - q) = tau(q, theta) (B0 = 1 there: the
    equilibrium does not depend on it)."""
    n = len(links)
    params = {sp.Symbol(k, real=True): v for k, v in d.params.items()}
    params.update({symbol(f"B0_{k + 1}"): 1.0 for k in range(n)})
    qL = [m.q[i] for i in links]
    th = [m.q[i] for i in motors]
    rest = {v: 0 for v in list(m.dq) + list(m.ddq)}
    u_syms = {symbol(f"u{k + 1}"): u_law[k] for k in range(n)}
    tau_q = tau.xreplace(u_syms).xreplace(rest).xreplace(params)
    f_x = numeric_function([qL], x.xreplace(params), "numpy")
    f_J = numeric_function([qL], J.xreplace(params), "numpy")
    f_g = numeric_function([qL], g.xreplace(params), "numpy")
    f_u = numeric_function([qL], u_law.xreplace(rest).xreplace(params), "numpy")
    f_tau = numeric_function([qL + th], tau_q, "numpy")
    Kn = np.array(K.xreplace(params), float)
    guess = d.configuration(spec.get("guess"))
    z0 = np.array([guess[i] for i in links] + [guess[i] for i in motors])

    def statics(z):
        q, theta = z[:n], z[n:]
        tau_J = Kn @ (theta - q)
        link = np.asarray(f_g(q), float).ravel() - tau_J - np.asarray(f_J(q), float).T @ F
        motor = tau_J - np.asarray(f_tau(z), float).ravel()
        return np.concatenate([link, motor])
    from scipy.optimize import fsolve
    z, info, ok, msg = fsolve(statics, z0, xtol=1e-13, full_output=True)
    if ok != 1 or np.max(np.abs(statics(z))) > 1e-8:
        raise ExerciseError(f"elastic_impedance: no equilibrium found from the guess ({msg})")
    qE, thetaE = z[:n], z[n:]
    uE = np.asarray(f_u(qE), float).ravel()
    xE = np.asarray(f_x(qE), float).ravel()
    JE = np.asarray(f_J(qE), float)
    gE = np.asarray(f_g(qE), float).ravel()
    tauE = np.asarray(f_tau(z), float).ravel()
    Kmn = np.array(Km.xreplace(params), float)
    xdn = np.array(x_d.xreplace(params), float).ravel()
    answers = {"q_E": qE, "theta_E": thetaE, "x_E": xE,
               "x_E_check": float(np.max(np.abs(xE - (xdn + np.linalg.solve(Kmn, F))))),
               "u_E": uE, "u_E_check": float(np.max(np.abs(uE - (gE - JE.T @ F)))),
               "u_E_printed_gap": float(np.max(np.abs(uE - (gE + JE.T @ F)))),
               "tau_E_check": float(np.max(np.abs(tauE - uE)))}
    for k_, v in answers.items():
        ctx.answer(k_, v)
    ctx.step("Equilibrium under a constant force", rf"q_E = {vec(qE)},\ x_E = {vec(xE)} = x_d + K_m^{{-1}}\bar F,\quad "
             rf"u_E = {vec(uE)} = g(q_E) - J^T(q_E)\bar F,\quad \tau_E = u_E",
             "Solved on the whole elastic model at rest; the impedance spring balances the external force, "
             r"$K_m (x_d - x_E) = -\bar F$, so the gravity torque is reduced by $J^T \bar F$.",
             configuration={c: float(v) for c, v in zip([m.coords[i] for i in links + motors], list(qE) + list(thetaE))})
