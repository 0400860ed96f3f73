"""Visual servoing tasks on point features (``app.core.visual_servoing``).

``interaction_matrix`` (symbolic, no robot needed): ``points`` (list of [u, v, Z], expressions) or
``count`` (N points named u1, v1, Z1, ...; one point: u, v, Z), ``focal`` (default ``lam``),
``combine`` (``stack``: 2N x 6; ``mean``: the image barycentre, 2 x 6), ``name`` (default J_p),
``nullspace`` (true: basis and dimension of the camera motions that leave the features still),
``at`` (values of some symbols for a special case of the basis, e.g. {u: 0, v: 0}), ``subspaces``
(label -> components among v_x v_y v_z w_x w_y w_z: the still motions using only those, e.g.
translations), ``desired`` (list of [u_d, v_d]: the error e = f_d - f and its norm), ``coordinates``
(one point: ``{names: [rho, theta], u: "rho*cos(theta)", v: "rho*sin(theta)", name, damping}``,
the matrix for other image coordinates s with u = u(s), v = v(s): J_t = d(u, v)/ds, s' = J_t^-1 J_p,
and with ``damping`` sigma the damped inverse of J_t).
Answers: ``<name>``, ``<name>_rank``, ``J_t``, ``det_J_t``, ``J_t_inv``, the new matrix (``name`` of
``coordinates``, default ``<name>_s``), ``<name>_zeros`` and ``<new name>_zeros`` (zero entries as
[row, component]), ``J_t_dls``, ``det_J_t_dls``, ``null_dim``, ``null_basis`` (6 x k, one column per free
velocity component, as Matlab's symbolic null), ``null_basis_at``, ``<label>_dim``, ``<label>``
(the direction when the dimension is one, else the basis as columns; scaled to polynomial
entries), ``e``, ``eta``.

``visual_servoing`` (numeric, a camera on the robot): ``camera: {body, xyz, rpy}`` (camera frame
fixed in a body; the optical axis is its z), ``points`` (3-D points in the world frame),
``desired`` (features [u_d, v_d] per point), ``focal``, ``gain`` (k), ``q``, ``suffix`` (appended
to every answer name). The task is the norm
of the feature error, eta = ||f_d - f||, regulated by q' = -k eta J_eta^# (eta' = -k eta).
Answers: ``features`` (rows u, v, Z), ``J_p``, ``J_m`` (camera twist in camera axes), ``J``
(J_p J_m), ``J_check`` (largest deviation of J from central differences of the projected
features), ``e``, ``eta``, ``J_eta`` (-e^T J / eta), ``J_eta_check`` (against differences of eta),
``J_eta_pinv`` (-eta J^T e / (e^T J J^T e)), ``J_eta_pinv_check`` (against numpy's pseudoinverse),
``J_eta_times_pinv`` (J_eta J_eta^#), ``dq``, ``eta_dot``, ``eta_rate`` (eta'/eta), ``P_rank``
(rank of I - J_eta^# J_eta), ``pinv_J_rank`` (rank of J_eta^# J_eta).

Example (2020-09-11#2, the image barycentre of three points):

    - {kind: interaction_matrix, count: 3, combine: mean, name: J_b, nullspace: true,
       subspaces: {translation: [v_x, v_y, v_z], planar: [v_x, v_y, w_z]}}
"""
from __future__ import annotations

from typing import List

import numpy as np
import sympy as sp

from .. import visual_servoing as vs
from ..exercise import ExerciseError
from ..expressions import ExpressionError, parse_expression, symbol
from ..latex import mat, num, sig, vec
from ..newton_euler import NewtonEuler, NewtonEulerError
from ..robot import elementary_rotation
from ..steps import to_latex
from . import task
from .context import TaskView


def _fail(ctx, option, what):
    return ExerciseError(f"{ctx.exercise.source or ctx.exercise.id}: {option}: {what}")


def _expr(ctx, value, option):
    try:
        return parse_expression(value)
    except ExpressionError as exc:
        raise _fail(ctx, option, str(exc)) from None


def _points(ctx, spec) -> List[tuple]:
    if "points" in spec:
        pts = spec["points"]
        if not isinstance(pts, list) or not all(isinstance(p, list) and len(p) == 3 for p in pts):
            raise _fail(ctx, "interaction_matrix.points", "expected a list of [u, v, Z]")
        return [tuple(_expr(ctx, x, "interaction_matrix.points") for x in p) for p in pts]
    count = spec.get("count", 1)
    if not isinstance(count, int) or count < 1:
        raise _fail(ctx, "interaction_matrix.count", f"expected a positive integer, got {count!r}")
    if count == 1:
        return [(symbol("u"), symbol("v"), symbol("Z"))]
    return [(symbol(f"u{i}"), symbol(f"v{i}"), symbol(f"Z{i}")) for i in range(1, count + 1)]


def _columns(vectors) -> sp.Matrix:
    return sp.Matrix.hstack(*vectors) if vectors else sp.zeros(6, 0)


@task("interaction_matrix")
def interaction_matrix_task(ctx, spec):
    """Interaction matrix of point features and its null space (see the module docstring)."""
    name = str(spec.get("name", "J_p"))
    points = _points(ctx, spec)
    lam = _expr(ctx, spec.get("focal", "lam"), "interaction_matrix.focal")
    combine = spec.get("combine", "stack")
    if combine not in ("stack", "mean"):
        raise _fail(ctx, "interaction_matrix.combine", "stack or mean")
    J = vs.interaction_matrix(points, lam, combine)
    rank = J.rank(simplify=sp.cancel)
    ctx.answer(name, J)
    ctx.answer(f"{name}_rank", rank)
    how = ("the mean of the point matrices (the barycentre moves with the mean velocity)" if combine == "mean"
           else "one pair of rows per point")
    ctx.step("Interaction matrix", rf"\dot f = J (V, \Omega),\quad {to_latex(name)} = {to_latex(J)}",
             rf"Pin-hole projection $u = \lambda X/Z$, $v = \lambda Y/Z$ of fixed points seen by a moving camera; {how}; "
             f"rank {rank}.")
    if spec.get("coordinates"):
        _other_coordinates(ctx, spec["coordinates"], J, name, points)
    if spec.get("nullspace"):
        basis = vs.null_basis(J)
        N = _columns(basis)
        ctx.answer("null_dim", len(basis))
        ctx.answer("null_basis", N)
        ctx.step("Camera motions that keep the features still",
                 rf"\mathcal N({to_latex(name)}) = \operatorname{{span}}\ {to_latex(N)}",
                 f"Dimension $6 - {rank} = {len(basis)}$: one basis vector per free velocity component.")
        if spec.get("at"):
            subs = {symbol(k): _expr(ctx, v, f"interaction_matrix.at.{k}") for k, v in spec["at"].items()}
            N_at = N.xreplace(subs).applyfunc(sp.cancel)
            ctx.answer("null_basis_at", N_at)
            ctx.step("Special case", rf"{to_latex(N_at)}",
                     "The same basis for $" + ", ".join(f"{to_latex(symbol(k))} = {to_latex(_expr(ctx, v, k))}"
                                                      for k, v in spec["at"].items()) + "$.")
    for label, comps in (spec.get("subspaces") or {}).items():
        if not isinstance(comps, list) or not all(c in vs.COMPONENTS for c in comps):
            raise _fail(ctx, f"interaction_matrix.subspaces.{label}", f"components among {', '.join(vs.COMPONENTS)}")
        vecs = vs.restricted_null_basis(J, [vs.COMPONENTS.index(c) for c in comps])
        ctx.answer(f"{label}_dim", len(vecs))
        value = vecs[0] if len(vecs) == 1 else _columns(vecs)
        ctx.answer(label, value)
        ctx.step("Still motions using only " + ", ".join(f"${to_latex(sp.Symbol(c))}$" for c in comps),
                 rf"\dim = {len(vecs)}" + (rf",\quad (V, \Omega) \propto {to_latex(_columns(vecs))}" if vecs else ""),
                 "The other velocity components are set to zero and the null space of the remaining columns is taken.")
    if spec.get("desired"):
        des = spec["desired"]
        if not isinstance(des, list) or len(des) != len(points):
            raise _fail(ctx, "interaction_matrix.desired", f"expected {len(points)} pairs [u_d, v_d]")
        e = sp.Matrix([_expr(ctx, x, "interaction_matrix.desired") - f for d, p in zip(des, points)
                       for x, f in zip(d, p[:2])])
        eta = sp.sqrt(sum(x ** 2 for x in e))
        ctx.answer("e", e)
        ctx.answer("eta", eta)
        ctx.step("Feature error and its norm", rf"e = f_d - f = {to_latex(e)},\quad \eta = \|e\| = {to_latex(eta)}",
                 "A scalar task: one row, so n - 1 degrees of freedom stay for other tasks.")


def _other_coordinates(ctx, opt, J, name, points):
    """The ``coordinates`` option: the interaction matrix with other image coordinates (one point)."""
    where = "interaction_matrix.coordinates"
    if len(points) != 1 or not isinstance(opt, dict) or not {"names", "u", "v"} <= set(opt) or len(opt["names"]) != 2:
        raise _fail(ctx, where, "one point and {names: [two new coordinates], u: u(new), v: v(new)}")
    new = [symbol(str(c)) for c in opt["names"]]
    u, v, _Z = points[0]
    u_of, v_of = _expr(ctx, opt["u"], f"{where}.u"), _expr(ctx, opt["v"], f"{where}.v")
    damping = _expr(ctx, opt["damping"], f"{where}.damping") if "damping" in opt else None
    r = vs.reparametrized(J, new, u_of, v_of, u, v, damping)
    new_name = str(opt.get("name", f"{name}_s"))
    L = to_latex
    ctx.step("Change of image coordinates",
             rf"(u, v) = ({L(u_of)}, {L(v_of)}),\quad J_t = \frac{{\partial (u, v)}}{{\partial ({L(new[0])}, {L(new[1])})}} = "
             rf"{L(r['J_t'])},\quad \det J_t = {L(r['det_J_t'])}",
             r"The new features move as $\dot s = J_t^{-1} (\dot u, \dot v)$ wherever $J_t$ is nonsingular.")
    ctx.step("Interaction matrix in the new coordinates",
             rf"J_t^{{-1}} = {L(r['J_t_inv'])},\quad {L(new_name)} = J_t^{{-1}} {L(name)} = {L(r['J_s'])}",
             "The matrix of the point written with the new coordinates and premultiplied by the inverse of $J_t$.")
    pairs = r["zeros_s"]
    ctx.step("Decoupled velocity components",
             r",\ ".join(rf"\partial \dot {L(new[i])} / \partial {L(sp.Symbol(c))} = 0" for i, c in pairs) or r"\text{none}",
             "A zero entry: that feature does not move with that velocity component of the camera (compare the zeros "
             f"of ${L(name)}$).")
    answers = {"J_t": r["J_t"], "det_J_t": r["det_J_t"], "J_t_inv": r["J_t_inv"], new_name: r["J_s"],
               f"{name}_zeros": [list(z) for z in r["zeros_p"]], f"{new_name}_zeros": [list(z) for z in pairs]}
    if damping is not None:
        answers.update(J_t_dls=r["J_t_dls"], det_J_t_dls=r["det_J_t_dls"])
        ctx.step("Damped inverse near the singularity",
                 rf"J_t^{{DLS}} = J_t^T\left({L(damping)}^2 I + J_t J_t^T\right)^{{-1}} = {L(r['J_t_dls'])},\quad "
                 rf"\det J_t^{{DLS}} = {L(r['det_J_t_dls'])}",
                 rf"Where $\det J_t = {L(r['det_J_t'])}$ vanishes the inverse blows up; the damped inverse stays bounded and "
                 "equals the inverse for zero damping.")
    for key, value in answers.items():
        ctx.answer(key, value)


# ====================================================================== numeric, camera on a robot
def _camera_frame(ctx, d, ne, q, spec):
    cam = spec.get("camera") or {}
    body = cam.get("body", ctx.robot.bodies[-1].name)
    xyz = d.array(cam.get("xyz", [0, 0, 0]), "camera.xyz").reshape(-1)
    rpy = d.array(cam.get("rpy", [0, 0, 0]), "camera.rpy").reshape(-1)
    R_off = np.array(elementary_rotation((0, 0, 1), rpy[2]) * elementary_rotation((0, 1, 0), rpy[1])
                     * elementary_rotation((1, 0, 0), rpy[0]), dtype=float)
    states, _ = ne.forward(q, gravity=False)
    try:
        st = states[ne._body(body)]
    except NewtonEulerError as exc:
        raise _fail(ctx, "visual_servoing.camera.body", str(exc)) from None
    return body, xyz, st.R @ R_off, st.origin + st.R @ xyz


def _features(ctx, d, ne, q, spec, world, lam):
    _body, _xyz, R, o = _camera_frame(ctx, d, ne, q, spec)
    try:
        return vs.project((world - o) @ R, lam)
    except ValueError as exc:
        raise _fail(ctx, "visual_servoing.points", str(exc)) from None


@task("visual_servoing")
def visual_servoing_task(ctx, spec):
    """Norm-of-the-feature-error task on a robot carrying a camera (see the module docstring)."""
    d = TaskView(ctx)
    robot = ctx.robot
    q = d.configuration(spec.get("q"))
    lam = d.number(spec.get("focal", 1.0), "visual_servoing.focal")
    k = d.number(spec.get("gain", 1.0), "visual_servoing.gain")
    world = np.atleast_2d(d.array(spec.get("points"), "visual_servoing.points"))
    desired = np.atleast_2d(d.array(spec.get("desired"), "visual_servoing.desired"))
    if world.shape[1] != 3 or desired.shape != (world.shape[0], 2):
        raise _fail(ctx, "visual_servoing", "points: rows [X, Y, Z]; desired: one [u_d, v_d] per point")
    ne = NewtonEuler(robot, d.params)
    body, xyz, R, _o = _camera_frame(ctx, d, ne, q, spec)
    feats = _features(ctx, d, ne, q, spec, world, lam)
    Jp = vs.numeric_interaction_matrix(feats, lam)
    Jm = vs.camera_twist_jacobian(ne.geometric_jacobian(q, body, xyz), R)
    J = Jp @ Jm
    f = feats[:, :2].reshape(-1)
    e = desired.reshape(-1) - f
    eta = float(np.linalg.norm(e))
    if eta == 0:
        raise _fail(ctx, "visual_servoing.desired", "the features are already at the desired values (eta = 0)")
    J_eta = -(e @ J) / eta
    Jte = J.T @ e
    J_eta_pinv = -eta * Jte / float(Jte @ Jte)
    dq = -k * eta * J_eta_pinv
    h = 1e-6
    num_J = np.column_stack([(_features(ctx, d, ne, q + h * ei, spec, world, lam)[:, :2].reshape(-1)
                              - _features(ctx, d, ne, q - h * ei, spec, world, lam)[:, :2].reshape(-1)) / (2 * h)
                             for ei in np.eye(robot.n)])
    num_J_eta = -(e @ num_J) / eta
    P = np.eye(robot.n) - np.outer(J_eta_pinv, J_eta)
    answers = {"features": feats, "J_p": Jp, "J_m": Jm, "J": J, "J_check": float(np.max(np.abs(J - num_J))),
               "e": e, "eta": eta, "J_eta": J_eta, "J_eta_check": float(np.max(np.abs(J_eta - num_J_eta))),
               "J_eta_pinv": J_eta_pinv,
               "J_eta_pinv_check": float(np.max(np.abs(J_eta_pinv - np.linalg.pinv(J_eta[None, :]).reshape(-1)))),
               "J_eta_times_pinv": float(J_eta @ J_eta_pinv), "dq": dq, "eta_dot": float(J_eta @ dq),
               "eta_rate": float(J_eta @ dq) / eta, "P_rank": int(np.linalg.matrix_rank(P)),
               "pinv_J_rank": int(np.linalg.matrix_rank(np.outer(J_eta_pinv, J_eta)))}
    suffix = str(spec.get("suffix", "") or "")
    for key, value in answers.items():
        ctx.answer(key + suffix, value)
    conf = dict(zip(robot.coordinates, map(float, q)))
    ctx.step("Features seen by the camera", rf"(u_i, v_i, Z_i) = {mat(feats)},\quad e = f_d - f = {vec(e)},\ \eta = {num(eta)}",
             "Points expressed in the camera frame and projected; eta is the norm of the feature error.",
             bodies=[body], configuration=conf)
    ctx.step("Task Jacobian", rf"J = J_p J_m = {mat(J, 3)},\quad J_\eta = -\frac{{e^T J}}{{\eta}} = {vec(J_eta, 3)}^T",
             r"$J_m$ maps $\dot q$ to the camera twist in camera axes; $J$ agrees with differences of the projected "
             f"features to ${sig(answers['J_check'], 2)}$.", joints=[b.name for b in robot.bodies])
    ctx.step("Regulation of the norm", rf"J_\eta^\# = -\eta\frac{{J^T e}}{{e^T J J^T e}},\quad \dot q = -k\,\eta\,J_\eta^\# = {vec(dq, 3)},"
             rf"\quad \dot\eta = J_\eta \dot q = {num(answers['eta_dot'])} = -k\eta",
             r"$J_\eta J_\eta^\# = 1$, so $\dot\eta = -k \eta$; the projector $I - J_\eta^\# J_\eta$ has rank "
             f"{answers['P_rank']} (the null space of a one-row task), " + r"$J_\eta^\# J_\eta$" + f" rank {answers['pinv_J_rank']}.")
