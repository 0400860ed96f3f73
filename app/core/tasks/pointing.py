"""Pointing a planar end effector at a (moving) target. Values follow the conventions of
``context`` (TaskView).

``pointing``: the end-effector axis (orientation alpha(q) of the link holding ``point``, default
  ee) should point at a target p_t moving with p'_t. The desired orientation
  alpha_d = atan2(p_ty - p_y, p_tx - p_x) depends on q and on p_t: differentiating,
  alpha_d' = J_alpha_d (p' - p'_t) with J_alpha_d = (p_ty - p_y, -(p_tx - p_x)) / |p_t - p|^2, and
  the task alpha' = alpha_d' reads J_r q' = J_alpha_d p'_t with J_r = J_alpha_d J_p - J_alpha.
  With the error e_r = alpha_d - alpha (not wrapped unless ``wrap: true``) and a gain ``k``, the
  task velocity is J_alpha_d p'_t - k e_r, so that e_r' = -k e_r when J_r q' equals it.
  Options ``target``, ``target_velocity``, ``k`` (default 0), ``q``, ``name`` (default Jr).
  Answers ``<name>_num`` (J_r, also usable as a Jacobian by later tasks under ``name``),
  ``<name>_alpha``, ``<name>_alpha_d``, ``<name>_error``, ``<name>_J_alpha_d``,
  ``<name>_feedforward`` (J_alpha_d p'_t) and ``<name>_task`` (feedforward - k e_r).
"""
from __future__ import annotations

import math

import numpy as np

from .. import jacobians as jac
from ..latex import mat, num, vec
from . import task
from .context import TaskView


@task("pointing")
def pointing_task(ctx, spec):
    """Task Jacobian and task velocity for pointing the end effector at a target."""
    d = TaskView(ctx)
    robot = d.robot
    if not robot.is_planar:
        raise d._fail("pointing: planar robots only (the pointing direction is a planar angle)")
    name = spec.get("name", "Jr")
    point = spec.get("point", "ee")
    q = d.configuration(spec.get("q"))
    try:
        Jp_sym = jac.jacobian(robot, point, ["x", "y"])
        Ja_sym = jac.jacobian(robot, point, ["angle"])
        r_sym = jac.task_function(robot, point, ["x", "y", "angle"])
    except Exception as exc:   # JacobianError: a bad point
        raise d._fail(f"pointing.point: {exc}") from None
    Jp = np.atleast_2d(jac.evaluate(robot, Jp_sym, q, d.params))
    Ja = np.atleast_2d(jac.evaluate(robot, Ja_sym, q, d.params))
    px, py, alpha = np.asarray(jac.evaluate(robot, r_sym, q, d.params), float).reshape(-1)
    pt = d.array(spec["target"], "target").reshape(-1)
    vt = d.array(spec.get("target_velocity", [0, 0]), "target_velocity").reshape(-1)
    dx, dy = pt[0] - px, pt[1] - py
    dist2 = dx * dx + dy * dy
    if dist2 <= 1e-18:
        raise d._fail("pointing: the target is at the end effector; the pointing direction is undefined")
    alpha_d = math.atan2(dy, dx)
    e = alpha_d - alpha
    if spec.get("wrap"):
        e = math.atan2(math.sin(e), math.cos(e))
    J_ad = np.array([[dy, -dx]]) / dist2
    Jr = J_ad @ Jp - Ja
    ff = float((J_ad @ vt)[0])
    k = d.number(spec.get("k", 0.0), "k")
    t = ff - k * e
    conf = {c: float(v) for c, v in zip(robot.coordinates, q)}
    ctx.step("Pointing error", rf"p = {vec([px, py])},\ \alpha = {num(alpha)},\quad \alpha_d = \mathrm{{atan2}}(p_{{ty}} - p_y,\, p_{{tx}} - p_x) = {num(alpha_d)},\quad e_r = \alpha_d - \alpha = {num(e)}",
             "The end-effector axis should point at the target." + ("" if spec.get("wrap") else r" The error is not wrapped to $(-\pi, \pi]$."),
             configuration=conf, points=[{"label": "target", "position": [float(pt[0]), float(pt[1]), 0.0]}],
             vectors=[{"label": "target velocity", "origin": [float(pt[0]), float(pt[1]), 0.0], "vector": [float(vt[0]), float(vt[1]), 0.0], "role": "desired"}])
    ctx.step("Task matrix", rf"J_{{\alpha_d}} = \frac{{(p_{{ty}} - p_y,\ -(p_{{tx}} - p_x))}}{{\|p_t - p\|^2}} = {mat(J_ad)},\quad J_r = J_{{\alpha_d}} J_p - J_\alpha = {mat(Jr)}",
             r"$\dot\alpha_d = J_{\alpha_d} (\dot p - \dot p_t)$, so $\dot\alpha = \dot\alpha_d$ is $J_r \dot q = J_{\alpha_d} \dot p_t$.")
    ctx.step("Task velocity", rf"J_{{\alpha_d}} \dot p_t - k\,e_r = {num(ff)} - {num(k)} \cdot ({num(e)}) = {num(t)}",
             r"With $J_r \dot q$ equal to it the error obeys $\dot e_r = -k e_r$.")
    d.objects[name] = {"sym": None, "num": Jr, "r": None, "q": q}
    ctx.answer(f"{name}_num", Jr)
    ctx.answer(f"{name}_alpha", alpha)
    ctx.answer(f"{name}_alpha_d", alpha_d)
    ctx.answer(f"{name}_error", e)
    ctx.answer(f"{name}_J_alpha_d", J_ad)
    ctx.answer(f"{name}_feedforward", ff)
    ctx.answer(f"{name}_task", [t])
