"""The dynamic model in other generalized coordinates.

With the old coordinates written as functions of new ones, q = f(theta), velocities map as
q' = T(theta) theta' with T = df/dtheta, and the kinetic energy keeps its value, so

    M_theta = T^T M(f(theta)) T,   c_theta = T^T (c(f, T theta') + M T' theta'),
    g_theta = T^T g(f(theta)),     tau_theta = T^T tau_q          (virtual work).

With fewer new coordinates than old ones, f embeds holonomic constraints solved for the old
coordinates (e.g. a closed chain whose passive angle is a function of the actuated ones): the same
formulas give the model on the constraint (the constraint forces do no virtual work along T).

>>> from app.core.robot import load_robot
>>> from app.core.dynamics import derive
>>> from app.core.expressions import symbol
>>> d = derive(load_robot("planar_2r"))
>>> t1, t2 = symbol("t1"), symbol("t2")
>>> change = in_coordinates(d.q, d.dq, d.M, d.c, d.g, d.spring, sp.Matrix([t1, t2 - t1]), [t1, t2])
>>> change.T
Matrix([
[ 1, 0],
[-1, 1]])
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import sympy as sp

from .expressions import symbol


@dataclass
class CoordinateChange:
    T: sp.Matrix          # dq/dtheta
    M: sp.Matrix          # T^T M T
    c: sp.Matrix          # T^T (c + M T' theta')
    g: sp.Matrix          # T^T g
    spring: sp.Matrix     # T^T k
    dtheta: sp.Matrix     # the new velocity symbols


def in_coordinates(q, dq, M, c, g, spring, q_of_theta: sp.Matrix, theta: Sequence[sp.Symbol]) -> CoordinateChange:
    """The model (M, c, g, spring in coordinates q with velocities dq) in coordinates ``theta``
    with q = ``q_of_theta`` (unsimplified)."""
    theta = sp.Matrix(list(theta))
    dtheta = sp.Matrix([symbol("d" + s.name) for s in theta])
    T = sp.Matrix(q_of_theta).jacobian(theta)
    if T.rows < T.cols:
        raise ValueError("more new coordinates than old ones")
    if T.rows == T.cols and T.det() == 0:
        raise ValueError("the change of coordinates is singular (dq/dtheta is not invertible)")
    at = dict(zip(q, q_of_theta))
    at.update(zip(dq, T * dtheta))
    Tdot = sum((T.diff(s) * ds for s, ds in zip(theta, dtheta)), sp.zeros(*T.shape))
    M_old = M.subs(at, simultaneous=True)
    c_new = T.T * (c.subs(at, simultaneous=True) + M_old * Tdot * dtheta)
    return CoordinateChange(T, T.T * M_old * T, c_new, T.T * g.subs(at, simultaneous=True),
                            T.T * spring.subs(at, simultaneous=True), dtheta)
