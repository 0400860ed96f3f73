"""Contact and force tasks (numeric, at a configuration): static torques, contact-force estimation
and isolation, collision detection by energy and momentum residuals, impedance gains.
Values follow the conventions of ``context`` (TaskView).

``static_torque``: tau = g(q) (with ``gravity: true``) + sum_k J_k^T F_k for ``forces``, a list of
  {label, point, force} or {label, point, stiffness, target} (a Cartesian spring at rest:
  F = K (p_target - p(q))), each with an optional ``sign`` (-1: the torque -J^T F that balances F). Answers ``<name>`` (default tau), ``<name>_gravity``, and per force
  ``F_<label>``, ``p_<label>``, ``J_<label>``.
``contact_force``: estimate a contact force from the joint torque it produces. ``torque`` (tau_c),
  ``sign`` (+1: tau_c = J_c^T F, the default; -1: tau = -J_c^T F balances F), ``link`` (a body
  name, or ``auto``: isolation from the last nonzero torque), ``distance`` (of the contact point
  along the link; ``estimate`` (default) solves for it when enough joints precede the link and
  otherwise takes the link midpoint), ``subtract_gravity`` (tau_c = tau - g(q)). Answers
  ``<name>`` (base frame), ``<name>_local`` (link frame), ``<name>_link`` (1-based index),
  ``<name>_distance``, ``<name>_jacobian``, ``<name>_jacobian_local``, ``<name>_norm``.
``external_torque``: joint torque of external forces at a static equilibrium where the
  controller applies ``torque``: tau_ext = g(q) - tau. Answers ``<name>`` and ``<name>_residual``
  (the steady state of the momentum residual, equal to tau_ext), ``<name>_link`` (isolation).
``collision_analysis``: ``contacts`` [{label, point, force}] at (q, ``velocity``): answers per
  label ``v_<label>`` (contact point velocity), ``power_<label>`` (v^T F, what the energy residual
  sees), ``tau_<label>`` (J_c^T F, the momentum residual at steady state), ``J_<label>``,
  ``energy_detects_<label>`` and ``momentum_detects_<label>`` (1 or 0), ``link_<label>``
  (isolated link index, 0 if undetected).
``impedance_gains``: ``mass`` (number, expression, list, or ``inertia`` for a constant diagonal
  M(q)), and either ``omega`` and ``zeta`` or ``eigenvalue`` (double real eigenvalue -lambda); symbols
  without a value in ``given`` stay symbolic. Answers ``K_d``, ``D_d``, ``M_d`` (+ ``_<suffix>``).
``hybrid_constraints``: natural and artificial constraints of a task in a task frame, and the
  selection matrices of hybrid force/velocity control. The environment is described by ``contact``
  ({pair: point | planar | prismatic | cylindrical | revolute | spherical, axis: x | y | z}: the
  motions the contact leaves free) or by ``free`` (a list among v_x, v_y, v_z, w_x, w_y, w_z);
  ``references``: desired values of the artificial constraints (e.g. {F_z: F_zd, v_x: v_xd}; the
  others are 0); ``directions``: what the robot commands, ``all`` (default, six dof), a list, or
  ``jacobian`` (the task-frame rows of the geometric Jacobian of ``point`` that are not zero at
  ``q``; the task frame is the base frame). Answers (prefixed ``<name>_``, default hf):
  ``natural_velocities``, ``natural_forces``, ``force_controlled``, ``force_references``,
  ``velocity_controlled``, ``velocity_references``, ``uncontrolled``, ``automatic`` (uncontrolled
  constraints with reference 0 that the structure satisfies by itself), ``S_f``, ``S_v``,
  ``force_loops``, ``velocity_loops``, ``specifications`` (the constraints the robot imposes).
``residual_response``: time response of the momentum residual r = K (p - p(0) - int (tau + C^T q' - g
  + r) dt), checked by simulating the robot. A disturbance acts from ``t_c`` (default 0): a
  generalized force ``torque`` (M q'' + c + g = tau + tau_d), a ``fault`` u_f on the commands
  (tau_d = -u_f) or a ``force`` on a ``point`` (tau_d = J^T(q) F). The command is tau = g(q) (+ a
  PD hold of the initial configuration with ``hold: {kp, kd}``), from rest at ``q`` (or
  ``velocity``). ``gains`` K (diagonal), ``duration``, ``at`` (sample times). Theory: r' = K (tau_d
  - r), so r(t) = (1 - exp(-K (t - t_c))) tau_d for a constant tau_d. Answers (prefix
  ``<name>_``, default r): ``at`` (simulated residual, one row per time), ``filter_at`` (first-order
  filter of the simulated tau_d), ``closed_form_at`` (constant tau_d(t_c)), ``deviation`` (largest
  |residual - filter| along the run), ``steady`` (tau_d(t_c)), and with a fault ``fault_at``
  (-r, the residual with the sign that estimates u_f).
``hybrid_control``: hybrid force/velocity law for a robot whose end-effector Jacobian J is constant
  and invertible (Cartesian robots) in contact with a frictionless, compliant surface, in a planar
  task frame rotated by ``angle`` (t: tangent, n: normal, the force-controlled axis). Symbolic: the
  model M q'' = tau + tau_f becomes M_bar v' = tau_bar + f in the task frame (v = R^T J q',
  f = (0, f_n)); the law tau_bar = M_bar (K_v (v_d - v_t), K_f ((f_d - f_n) - K_d v_n)) - f decouples
  the two axes. Answers ``R``, ``M_bar`` (R^T J^-T M J^-1 R), ``tau_bar`` (R^T J^-T tau), ``tau_f``
  (J^T R f), ``u`` (the joint torque law), ``closed_loop`` (v_t', v_n'), ``M_f`` (1/K_f, the
  apparent mass of the normal impedance M_f d'' + K_d d' + K_n d = f_d), ``f_n_steady`` (f_d).
``force_capability``: ``point``, ``torque`` bounds, ``q``: the largest ||F|| sustainable in every
  direction, min_i T_i / ||J_i||. Answers ``force_max``, ``force_limiting_joint``, ``column_norms``.
"""
from __future__ import annotations

import numpy as np
import sympy as sp

from .. import contact as con
from .. import jacobians as jac
from ..errors import UserError
from ..latex import mat, num, sig, vec
from . import task
from .context import TaskView


def _point_name(point) -> str:
    """A point for a sentence: its name, or "the point at (x, y, z) of link2"."""
    if isinstance(point, dict):
        at = point.get("at")
        where = f" at $({', '.join(str(v) for v in at)})$" if at else ""
        return f"the point{where} of {point.get('body', 'the last link')}"
    return str(point).replace("_", " ")


def _names(names) -> str:
    """Velocity/force component names for a sentence, typeset (``v_x`` -> ``$v_{x}$``)."""
    return ", ".join(f"${sp.latex(sp.Symbol(n))}$" for n in names)


def _planar_rows(robot):
    return ["x", "y"] if robot.is_planar else ["x", "y", "z"]


def _point_jacobian(d, point, q):
    comps = _planar_rows(d.robot)
    try:
        J = jac.jacobian(d.robot, point, comps)
        r = jac.task_function(d.robot, point, comps)
    except UserError as exc:
        raise d._fail(str(exc)) from None
    return (np.atleast_2d(jac.evaluate(d.robot, J, q, d.params)),
            np.asarray(jac.evaluate(d.robot, r, q, d.params), float).reshape(-1))


def _gravity(d, q):
    return np.asarray(d.ctx.numeric.g(q), float).reshape(-1)


def _highlight_force(label, p, F):
    return {"label": label, "origin": (list(p) + [0.0])[:3], "vector": (list(F) + [0.0])[:3], "role": "force"}


@task("static_torque")
def static_torque_task(ctx, spec):
    """tau = g(q) + sum J^T F at a static configuration."""
    d = TaskView(ctx)
    name = spec.get("name", "tau")
    q = d.configuration(spec.get("q"))
    n = d.robot.n
    tau = np.zeros(n)
    conf = {c: float(v) for c, v in zip(d.robot.coordinates, q)}
    if spec.get("gravity"):
        g = _gravity(d, q)
        tau += g
        ctx.step("Gravity torque", "g(q) = " + vec(g), "Balances the weight of the links at rest.", configuration=conf)
        ctx.answer(f"{name}_gravity", g)
    for k, f in enumerate(spec.get("forces") or [], 1):
        label = str(f.get("label", f"F{k}"))
        J, p = _point_jacobian(d, f.get("point", "ee"), q)
        if "force" in f:
            F = d.array(f["force"], f"forces.{label}").reshape(-1)
            how = "Given force."
        else:
            K = d.array(f["stiffness"], f"forces.{label}.stiffness")
            target = d.array(f["target"], f"forces.{label}.target").reshape(-1)
            K = np.diag(K * np.ones(p.size)) if K.ndim < 2 else K
            F = K @ (target - p)
            how = f"Cartesian spring $F = K (p_d - p)$ with $p = {vec(p)}$."
        t = float(f.get("sign", 1)) * con.static_torque(J, F)
        tau += t
        ctx.step(f"Force {label}", rf"F_{{{label}}} = {vec(F)},\quad J^T = {mat(J.T)},\quad J^T F = {vec(t)}", how,
                 vectors=[_highlight_force(label, p, F)], configuration=conf)
        ctx.answer(f"F_{label}", F)
        ctx.answer(f"p_{label}", p)
        ctx.answer(f"J_{label}", J)
    ctx.step("Joint torque", rf"\tau = {vec(tau)}", "Sum of the contributions [N m].")
    ctx.answer(name, tau)


@task("external_torque")
def external_torque_task(ctx, spec):
    """tau_ext = g(q) - tau at a static equilibrium under the control torque tau."""
    d = TaskView(ctx)
    name = spec.get("name", "tau_ext")
    q = d.configuration(spec.get("q"))
    tau = d.array(spec["torque"], "torque").reshape(-1)
    g = _gravity(d, q)
    ext = g - tau
    link = con.isolate(ext)
    ctx.step("Balance at rest", r"g(q) = \tau + \tau_{ext}\ \Rightarrow\ \tau_{ext} = g(q) - \tau = " + vec(ext),
             "At a static equilibrium the model reduces to the balance of gravity, control and external torques.")
    ctx.step("Momentum residual", r"\dot r = K_I(\tau_{ext} - r)\ \Rightarrow\ r_\infty = \tau_{ext} = " + vec(ext),
             f"The residual converges to the external torque; its last nonzero component isolates link {link}.",
             bodies=[d.robot.bodies[link - 1].name] if link else [])
    ctx.answer(name, ext)
    ctx.answer(f"{name}_residual", ext)
    ctx.answer(f"{name}_link", link)


def _link_length(d, body):
    """Length of a link: the offset of the next joint along x, or the farthest named point on it."""
    for b in d.robot.bodies:
        if b.parent == body.name:
            return float(jac.evaluate(d.robot, b.joint.pre.p[0], np.zeros(d.robot.n), d.params))
    xs = [float(jac.evaluate(d.robot, p.position[0], np.zeros(d.robot.n), d.params))
          for p in d.robot.points.values() if p.body == body.name]
    if xs:
        return max(xs)
    raise d._fail(f"cannot find the length of {body.name}: give distance explicitly")


@task("contact_force")
def contact_force_task(ctx, spec):
    """Contact force (and point) from the joint torques it produces."""
    d = TaskView(ctx)
    robot = d.robot
    name = spec.get("name", "Fc")
    q = d.configuration(spec.get("q"))
    tau = d.array(spec["torque"], "torque").reshape(-1)
    if spec.get("subtract_gravity"):
        tau = tau - _gravity(d, q)
    sign = float(spec.get("sign", 1))
    tau_c = sign * tau
    link_spec = spec.get("link", "auto")
    if link_spec == "auto":
        idx = con.isolate(tau_c)
        if idx == 0:
            raise d._fail("contact_force: every joint torque is zero, no contact to estimate")
        body = robot.bodies[idx - 1]
        ctx.step("Isolation", rf"\tau_c = {vec(tau_c)}",
                 f"The last nonzero component is joint {idx}: the force acts on {body.name}.", bodies=[body.name])
    else:
        try:
            body = robot.body(link_spec)
        except KeyError:
            raise d._fail(f"contact_force.link: no body '{link_spec}'") from None
        idx = robot.bodies.index(body) + 1
    comps = _planar_rows(robot)
    Jo = np.atleast_2d(jac.evaluate(robot, jac.jacobian(robot, {"body": body.name, "at": [0, 0, 0]}, comps), q, d.params))
    J1 = np.atleast_2d(jac.evaluate(robot, jac.jacobian(robot, {"body": body.name, "at": [1, 0, 0]}, comps), q, d.params))
    Ju = J1 - Jo
    R = np.asarray(jac.evaluate(robot, jac.rotation(robot, body.name), q, d.params), float)[:len(comps), :len(comps)]
    dist = spec.get("distance", "estimate")
    unknowns_ok = idx >= len(comps) + 1
    if dist == "estimate" and not unknowns_ok:
        dist = _link_length(d, body) / 2
        ctx.step("Contact point", rf"l_c = {num(dist)}",
                 f"Only {idx} joint torque(s) see a force on {body.name}: force and point cannot both be found; the midpoint is taken.")
    if dist == "estimate":
        try:
            est = con.estimate_contact(Jo, Ju, tau_c)
        except UserError as exc:
            raise d._fail(f"contact_force: {exc}") from None
        ctx.step("Force and contact point", rf"\tau_c = (J_o + l\,J_u)^T F\ \Rightarrow\ l = {num(est.distance)},\quad F = {vec(est.force)}",
                 "$J_c$ is affine in the distance $l$ along the link: with enough joint torques both are found.")
    else:
        l = d.number(dist, "distance")
        est = con.estimate_contact(Jo, Ju, tau_c, distance=l)
        ctx.step("Contact force", rf"J_c = {mat(est.jacobian)},\quad F = (J_c^T)^\# \tau_c = {vec(est.force)}",
                 "Minimum-norm force: components that produce no joint torque (e.g. along the link when only joint 1 sees it) are set to zero.")
    F_local = R.T @ est.force
    p = np.asarray(jac.evaluate(robot, jac.task_function(robot, {"body": body.name, "at": [0, 0, 0]}, comps), q, d.params), float).reshape(-1)
    p_c = p + est.distance * R[:, 0]
    ctx.step("Force in the link frame", rf"^{{{idx}}}F = R_{idx}^T F = {vec(F_local)},\quad ^{{{idx}}}J_c = {mat(R.T @ est.jacobian)}",
             "Tangential and normal components with respect to the link.",
             vectors=[_highlight_force(name, p_c, est.force)], bodies=[body.name],
             configuration={c: float(v) for c, v in zip(robot.coordinates, q)})
    ctx.answer(name, est.force)
    ctx.answer(f"{name}_local", F_local)
    ctx.answer(f"{name}_link", idx)
    ctx.answer(f"{name}_distance", est.distance)
    ctx.answer(f"{name}_jacobian", est.jacobian)
    ctx.answer(f"{name}_jacobian_local", R.T @ est.jacobian)
    ctx.answer(f"{name}_norm", float(np.linalg.norm(est.force)))


@task("collision_analysis")
def collision_analysis_task(ctx, spec):
    """Energy- and momentum-based detection and isolation for given contact forces."""
    d = TaskView(ctx)
    q = d.configuration(spec.get("q"))
    dq = d.array(spec.get("velocity", [0] * d.robot.n), "velocity").reshape(-1)
    for k, c in enumerate(spec.get("contacts") or [], 1):
        label = str(c.get("label", f"c{k}"))
        J, p = _point_jacobian(d, c.get("point", "ee"), q)
        F = d.array(c["force"], f"contacts.{label}.force").reshape(-1)
        v = J @ dq
        power = float(v @ F)
        tau = con.static_torque(J, F)
        link = con.isolate(tau)
        e_det, m_det = int(abs(power) > 1e-9), int(link > 0)
        ctx.step(f"Collision {label}",
                 rf"v_c = J_c \dot q = {vec(v)},\quad v_c^T F = {num(power)},\quad \tau_c = J_c^T F = {vec(tau)}",
                 ("Energy residual: detected. " if e_det else "Energy residual: not detected (no power exchanged). ")
                 + (f"Momentum residual: detected, isolated on link {link}." if m_det else
                    "Momentum residual: not detected ($F$ lies in the null space of $J_c^T$)."),
                 vectors=[_highlight_force(label, p, F)], configuration={cc: float(x) for cc, x in zip(d.robot.coordinates, q)})
        ctx.answer(f"v_{label}", v)
        ctx.answer(f"power_{label}", power)
        ctx.answer(f"tau_{label}", tau)
        ctx.answer(f"J_{label}", J)
        ctx.answer(f"energy_detects_{label}", e_det)
        ctx.answer(f"momentum_detects_{label}", m_det)
        ctx.answer(f"link_{label}", link)


@task("impedance_gains")
def impedance_gains_task(ctx, spec):
    """Stiffness and damping of a desired impedance from its time behaviour (symbolic or numeric)."""
    d = TaskView(ctx)
    mass = spec.get("mass", 1)

    def value(x, where):
        expr = d.expression(x, where) if isinstance(x, str) else sp.nsimplify(x)
        subs = {}
        for sym in expr.free_symbols:
            if sym.name in ctx.given:
                subs[sym] = sp.nsimplify(d.number(sym.name, where))
        return expr.xreplace(subs)

    if isinstance(mass, str) and mass == "inertia":
        M = ctx.dynamics().M
        if any(M[i, j] != 0 for i in range(M.rows) for j in range(M.cols) if i != j) or M.free_symbols & set(d.robot.q):
            raise d._fail("impedance_gains: mass 'inertia' needs a constant diagonal inertia matrix")
        m = [M[i, i] for i in range(M.rows)]
    else:
        m = [value(x, "mass") for x in (mass if isinstance(mass, list) else [mass])]
    m = sp.Matrix(m)
    if "eigenvalue" in spec:
        lam = value(spec["eigenvalue"], "eigenvalue")
        K, D = m * lam ** 2, 2 * lam * m
        how = rf"(s + \lambda)^2:\ D_d = 2 M_d \lambda,\ K_d = M_d \lambda^2"
    else:
        w, z = value(spec["omega"], "omega"), value(spec["zeta"], "zeta")
        K, D = m * w ** 2, 2 * z * w * m
        how = rf"s^2 + 2\zeta\omega_n s + \omega_n^2:\ \omega_n = {sp.latex(w)},\ \zeta = {sp.latex(z)}"
    K, D = K.applyfunc(sp.expand), D.applyfunc(sp.expand)
    ctx.step("Impedance gains", how + rf",\quad M_d = {sp.latex(m.T)},\ K_d = {sp.latex(K.T)},\ D_d = {sp.latex(D.T)}",
             r"$M_d \ddot x + D_d \dot x + K_d x = F$ along each direction.")
    one = lambda X: X[0] if X.rows == 1 else X
    suffix = f"_{spec['suffix']}" if spec.get("suffix") else ""
    ctx.answer("M_d" + suffix, one(m))
    ctx.answer("K_d" + suffix, one(K))
    ctx.answer("D_d" + suffix, one(D))


@task("force_capability")
def force_capability_task(ctx, spec):
    """Largest force norm a point can sustain in every direction under joint torque bounds."""
    d = TaskView(ctx)
    q = d.configuration(spec.get("q"))
    J, p = _point_jacobian(d, spec.get("point", "ee"), q)
    T = d.array(spec["torque"], "torque") * np.ones(d.robot.n)
    norms = np.linalg.norm(J, axis=0)
    limits = np.where(norms > 1e-12, T / np.where(norms > 1e-12, norms, 1.0), np.inf)
    r = float(limits.min())
    joint = int(np.argmin(limits)) + 1
    ctx.step("Force capability", rf"|\tau_i| = |J_i^T F| \le \|J_i\|\,\|F\| \le T_i\ \Rightarrow\ \|F\| \le \min_i \frac{{T_i}}{{\|J_i\|}} = {num(r)}",
             f"Column norms of $J$: {', '.join(num(x) for x in norms)}; joint {joint} limits the force (equality for $F$ along its column).",
             configuration={c: float(v) for c, v in zip(d.robot.coordinates, q)})
    ctx.answer("force_max", r)
    ctx.answer("force_limiting_joint", joint)
    ctx.answer("column_norms", norms)


@task("hybrid_constraints")
def hybrid_constraints_task(ctx, spec):
    """Natural/artificial constraints in a task frame and the hybrid selection matrices."""
    d = TaskView(ctx)
    robot = d.robot
    name = spec.get("name", "hf")
    axes = {"x": 0, "y": 1, "z": 2}
    if "contact" in spec:
        c = spec["contact"]
        pair, axis = (c.get("pair"), c.get("axis", "z")) if isinstance(c, dict) else (None, None)
        if pair not in con.PAIRS or axis not in axes:
            raise d._fail(f"hybrid_constraints.contact: expected {{pair: {' | '.join(con.PAIRS)}, axis: x | y | z}}")
        free = con.PAIRS[pair](axes[axis])
        how = f"A {pair} contact with axis ${axis}_t$ leaves free: {_names(con.VELOCITY_NAMES[i] for i in free) or 'nothing'}."
    elif "free" in spec:
        bad = [v for v in spec["free"] if v not in con.VELOCITY_NAMES]
        if bad:
            raise d._fail(f"hybrid_constraints.free: unknown directions {bad} (use {', '.join(con.VELOCITY_NAMES)})")
        free = [con.VELOCITY_NAMES.index(v) for v in spec["free"]]
        how = f"Free motions: {_names(spec['free'])}."
    else:
        raise d._fail("hybrid_constraints: give contact {pair, axis} or free [...]")
    directions = spec.get("directions", "all")
    if directions == "all":
        commandable = list(range(6))
    elif directions == "jacobian":
        q = d.configuration(spec.get("q"))
        try:
            J6 = jac.jacobian(robot, spec.get("point", "ee"), ["x", "y", "z", "wx", "wy", "wz"])
        except UserError as exc:
            raise d._fail(f"hybrid_constraints.point: {exc}") from None
        Jn = np.atleast_2d(jac.evaluate(robot, J6, q, d.params))
        commandable = [i for i in range(6) if np.linalg.norm(Jn[i]) > 1e-9]
        ctx.step("Directions the robot commands", r"J(q) = " + mat(Jn),
                 f"Rows of the geometric Jacobian that are not zero: {_names(con.VELOCITY_NAMES[i] for i in commandable)}.",
                 configuration={c: float(v) for c, v in zip(robot.coordinates, q)})
    else:
        bad = [v for v in directions if v not in con.VELOCITY_NAMES]
        if bad:
            raise d._fail(f"hybrid_constraints.directions: unknown directions {bad}")
        commandable = [con.VELOCITY_NAMES.index(v) for v in directions]
    res = con.task_frame_constraints(free, commandable)
    refs = spec.get("references") or {}
    unknown = [k for k in refs if k not in con.VELOCITY_NAMES + con.FORCE_NAMES]
    if unknown:
        raise d._fail(f"hybrid_constraints.references: unknown names {unknown}")
    natural = set(res.natural_velocities) | set(res.natural_forces)
    clash = [k for k in refs if k in natural]
    if clash:
        raise d._fail(f"hybrid_constraints.references: {clash} are natural constraints (imposed by the environment), not references")
    ref = lambda k: d.expression(str(refs[k]), f"references.{k}") if k in refs else sp.Integer(0)
    tex = lambda names, values: r",\ ".join(rf"{sp.latex(sp.Symbol(n))} = {sp.latex(v)}" for n, v in zip(names, values)) or r"\text{none}"
    ctx.step("Natural constraints", tex(res.natural_velocities + res.natural_forces, [0] * 6),
             how + " The environment blocks the other motions (zero velocity) and exerts no force or moment along the free ones.")
    art = [n for n in con.FORCE_NAMES if n not in natural] + [n for n in con.VELOCITY_NAMES if n not in natural]
    ctx.step("Artificial constraints", tex(art, [ref(n) for n in art]),
             "The complement of the natural ones: the references of the controller (0 unless the task asks otherwise).")
    automatic = [n for n in res.uncontrolled if n in con.FORCE_NAMES and ref(n) == 0]
    empty = r"\emptyset"
    ctx.step("Selection matrices", rf"S_f = {mat(res.S_f) if res.S_f.size else empty},\quad S_v = {mat(res.S_v) if res.S_v.size else empty}",
             f"{len(res.force_controlled)} force loop(s), {len(res.velocity_controlled)} velocity loop(s)"
             + (f"; the robot cannot impose {_names(res.uncontrolled)}" if res.uncontrolled else "")
             + (f" (${' = '.join(sp.latex(sp.Symbol(n)) for n in automatic)} = 0$ hold by themselves: the structure "
                "resists those directions)" if automatic else "") + ".")
    syms = lambda names: [sp.Symbol(n) for n in names]
    ctx.answer(f"{name}_natural_velocities", syms(res.natural_velocities))
    ctx.answer(f"{name}_natural_forces", syms(res.natural_forces))
    ctx.answer(f"{name}_force_controlled", syms(res.force_controlled))
    ctx.answer(f"{name}_force_references", [ref(n) for n in res.force_controlled])
    ctx.answer(f"{name}_velocity_controlled", syms(res.velocity_controlled))
    ctx.answer(f"{name}_velocity_references", [ref(n) for n in res.velocity_controlled])
    ctx.answer(f"{name}_uncontrolled", syms(res.uncontrolled))
    ctx.answer(f"{name}_automatic", syms(automatic))
    ctx.answer(f"{name}_S_f", res.S_f)
    ctx.answer(f"{name}_S_v", res.S_v)
    ctx.answer(f"{name}_force_loops", len(res.force_controlled))
    ctx.answer(f"{name}_velocity_loops", len(res.velocity_controlled))
    ctx.answer(f"{name}_specifications", len(res.force_controlled) + len(res.velocity_controlled))


@task("residual_response")
def residual_response_task(ctx, spec):
    """Simulated momentum residual after a collision or fault, against its first-order response."""
    from scipy.integrate import solve_ivp
    d = TaskView(ctx)
    robot = d.robot
    n = robot.n
    name = spec.get("name", "r")
    num_model = ctx.numeric
    q0 = d.configuration(spec.get("q"))
    dq0 = d.array(spec.get("velocity", [0.0] * n), "velocity").reshape(-1)
    K = d.array(spec.get("gains", 1.0), "gains") * np.ones(n)
    t_c = d.number(spec.get("t_c", 0.0), "t_c")
    T = d.number(spec.get("duration", max(t_c + 5.0 / float(K.min()), 1e-3)), "duration")
    if np.any(K <= 0) or T <= t_c:
        raise d._fail("residual_response: gains must be positive and the duration longer than t_c")
    if "torque" in spec:
        tau_c = d.array(spec["torque"], "torque").reshape(-1) * np.ones(n)
        disturbance = lambda q: tau_c
        what = f"generalized force ${vec(tau_c)}$"
    elif "fault" in spec:
        u_f = d.array(spec["fault"], "fault").reshape(-1) * np.ones(n)
        disturbance = lambda q: -u_f
        what = f"fault $u_f = {vec(u_f)}$ subtracted from the commands"
    elif "force" in spec:
        F = d.array(spec["force"], "force").reshape(-1)
        pos, jacf = num_model.point_function(*jac.point_location(robot, spec.get("point", "ee")))
        rows = 2 if robot.is_planar else 3
        if F.size != rows:
            raise d._fail(f"residual_response.force: expected {rows} components")
        disturbance = lambda q: jacf(q)[:rows].T @ F
        what = f"force ${vec(F)}$ on {_point_name(spec.get('point', 'ee'))}"
    else:
        raise d._fail("residual_response: give a torque, a fault or a force")
    hold = spec.get("hold")
    kp = d.number(hold.get("kp", 0.0), "hold.kp") if hold else 0.0
    kd = d.number(hold.get("kd", 0.0), "hold.kd") if hold else 0.0
    p0 = num_model.M(q0) @ dq0

    def rhs(t, x, active):
        q, dq, z, rf = x[:n], x[n:2 * n], x[2 * n:3 * n], x[3 * n:]
        tau = num_model.g(q) + kp * (q0 - q) - kd * dq
        td = disturbance(q) if active else np.zeros(n)
        ddq = num_model.forward_dynamics(q, dq, tau + td)
        r = K * (num_model.M(q) @ dq - p0 - z)
        dz = tau + num_model.C(q, dq).T @ dq - num_model.g(q) + r
        return np.concatenate([dq, ddq, dz, K * (td - rf)])

    times = sorted(d.number(x, "at") for x in (spec.get("at") or []))
    grid = np.unique(np.concatenate([np.linspace(0.0, T, 401), [t for t in times if 0 <= t <= T], [t_c]]))
    x = np.concatenate([q0, dq0, np.zeros(2 * n)])
    states = []
    for lo, hi, active in ((0.0, t_c, False), (t_c, T, True)):
        pts = grid[(grid >= lo) & (grid <= hi)]
        if hi <= lo:
            continue
        sol = solve_ivp(rhs, (lo, hi), x, t_eval=pts, args=(active,), rtol=1e-10, atol=1e-12, method="DOP853")
        if not sol.success:
            raise d._fail(f"residual_response: the simulation failed ({sol.message})")
        states += [(tt, sol.y[:, k]) for k, tt in enumerate(sol.t) if not states or tt > states[-1][0]]
        x = sol.y[:, -1]
    ts = np.array([s[0] for s in states])
    X = np.array([s[1] for s in states])
    resid = np.array([K * (num_model.M(xx[:n]) @ xx[n:2 * n] - p0 - xx[2 * n:3 * n]) for xx in X])
    filt = X[:, 3 * n:]
    steady = disturbance(q0)
    dev = float(np.max(np.abs(resid - filt)))
    ctx.step("Momentum residual", r"r = K\left(p(t) - p(0) - \int_0^t (\tau + C^T(q,\dot q)\dot q - g(q) + r)\,ds\right)\ \Rightarrow\ \dot r = K(\tau_d - r)",
             f"Disturbance from $t = {num(t_c)}$ s: {what}.", configuration={c: float(v) for c, v in zip(robot.coordinates, q0)})
    deviation = f"= {sig(dev, 2)}" if dev >= 1e-8 else "< 10^{-8}"      # below that it is integration round-off
    ctx.step("Simulated response", rf"\max_t |r(t) - r_{{filter}}(t)| {deviation},\quad r(\infty) = \tau_d(t_c) = {vec(steady)}",
             r"The residual computed from the simulated motion equals the first-order filter of the disturbance: $r(t) = (1 - e^{-K (t - t_c)})\, \tau_d$ when $\tau_d$ is constant.")
    ctx.answer(f"{name}_deviation", dev)
    ctx.answer(f"{name}_steady", steady)
    if times:
        idx = [int(np.argmin(np.abs(ts - tt))) for tt in times]
        ctx.answer(f"{name}_at", resid[idx])
        ctx.answer(f"{name}_filter_at", filt[idx])
        ctx.answer(f"{name}_closed_form_at", np.array([(1 - np.exp(-K * max(tt - t_c, 0.0))) * steady for tt in times]))
        if "fault" in spec:
            ctx.answer(f"{name}_fault_at", -resid[idx])


@task("hybrid_control")
def hybrid_control_task(ctx, spec):
    """Task-frame hybrid force/velocity law for a Cartesian robot on a compliant surface."""
    d = TaskView(ctx)
    robot = d.robot
    if robot.n != 2 or not robot.is_planar:
        raise d._fail("hybrid_control: a planar robot with two joints")
    dyn = ctx.dynamics()
    J = jac.jacobian(robot, spec.get("point", "ee"), ["x", "y"])
    if J.free_symbols & set(robot.q) or dyn.M.free_symbols & set(robot.q) or any(e != 0 for e in dyn.g) or J.det() == 0:
        raise d._fail("hybrid_control: needs a constant invertible Jacobian, a constant inertia matrix and no gravity (a Cartesian robot)")
    a = d.expression(str(spec.get("angle", "alpha")), "angle")
    c, s = sp.cos(a), sp.sin(a)
    R = sp.Matrix([[c, -s], [s, c]])
    Ji = J.inv()
    M_bar = (R.T * Ji.T * dyn.M * Ji * R).applyfunc(lambda e: sp.expand(sp.expand_trig(sp.trigsimp(sp.expand(e)))))
    tau = sp.Matrix(sp.symbols("tau1 tau2", real=True))
    v_t, v_n, f_n, v_d, f_d, K_v, K_f, K_d = sp.symbols("v_t v_n f_n v_d f_d K_v K_f K_d", real=True)
    f = sp.Matrix([0, f_n])
    tau_bar = (R.T * Ji.T * tau).applyfunc(sp.expand)
    acc = sp.Matrix([K_v * (v_d - v_t), K_f * ((f_d - f_n) - K_d * v_n)])
    tau_f = (J.T * R * f).applyfunc(sp.expand)
    u = (dyn.M * Ji * R * acc).applyfunc(sp.factor_terms) - tau_f     # J^T R M_bar = M J^-1 R (R orthogonal)
    ctx.step("Task frame", r"R = " + sp.latex(R) + r",\quad v = R^T J \dot q,\quad \tau_f = J^T R f,\ f = " + sp.latex(f),
             r"Frictionless surface: the environment reacts only along the normal $n$; compliant: $v_n = \dot\delta_n$, $f_n = K_n \delta_n$.")
    ctx.step("Model in the task frame", r"\bar M \dot v = \bar\tau + f,\quad \bar M = " + sp.latex(M_bar) + r",\quad \bar\tau = " + sp.latex(tau_bar),
             "Linear but coupled between $t$ and $n$ when the frame is not aligned with the joints.")
    ctx.step("Decoupling law", r"\bar\tau = \bar M " + sp.latex(acc) + r" - f\ \Rightarrow\ \dot v = " + sp.latex(acc),
             r"Exponential convergence of the tangential velocity; along $n$: $M_f \ddot\delta + K_d \dot\delta + K_n \delta = f_d$ with $M_f = 1/K_f$, so $f_n \to f_d$.")
    ctx.step("Joint torques", r"\tau = J^T R \bar\tau = M J^{-1} R \dot v - \tau_f = " + sp.latex(u), r"$J^T R \bar M = M J^{-1} R$ since $R$ is a rotation.")
    ctx.answer("R", R)
    ctx.answer("M_bar", M_bar)
    ctx.answer("tau_bar", tau_bar)
    ctx.answer("tau_f", tau_f)
    ctx.answer("u", u)
    ctx.answer("closed_loop", acc)
    ctx.answer("M_f", 1 / K_f)
    ctx.answer("f_n_steady", f_d)
