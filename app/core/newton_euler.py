"""Numeric recursive Newton-Euler inverse dynamics for any robot file (serial chains and trees),
with no symbolic model: it works for six-joint arms whose symbolic model would take minutes.

Forward recursion (base to tip, world coordinates): body orientation R_i, origin o_i, angular
velocity w_i and acceleration dw_i, linear acceleration of the origin a_i, with the base moving at
-g (gravity enters as an acceleration). Backward recursion (tip to base): the force f_i and the
moment m_i (about the joint point) that the parent exerts on body i,

    f_i = m_i a_ci + sum_children f_j + sum f_env,
    m_i = I_i dw_i + w_i x I_i w_i + (c_i - p_i) x m_i a_ci + sum_children (m_j + (p_j - p_i) x f_j) + ...

and the joint force is the projection on the joint axis. The generalized forces on the robot's
coordinates follow by virtual work, u_k = sum_i (d theta_i / d q_k) tau_i. A wrench F_e = (f, m)
that the robot exerts on the environment at a point initializes the backward recursion: with
q' = q'' = 0 and no gravity the result is J^T(q) F_e.

>>> from app.core.robot import load_robot
>>> ne = NewtonEuler(load_robot("planar_2r"))
>>> u = ne.inverse_dynamics([0.0, 0.0], [0.0, 0.0], [0.0, 0.0])
>>> [f"{x:.4f}" for x in u]      # g(q) of the stretched arm: (m1 d1 + m2 (l1 + d2)) g0, m2 d2 g0
['131.4540', '23.5440']
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Dict, List, Mapping, Optional, Sequence, Tuple

import numpy as np
import sympy as sp

from .errors import UserError
from .numeric import numeric_function
from .robot import RobotModel


class NewtonEulerError(UserError):
    """Bad input to the recursion (sizes, unknown bodies, missing values)."""


def _rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rodrigues' formula for a unit axis."""
    k = axis / np.linalg.norm(axis)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


@dataclass
class Wrench:
    """A wrench the robot exerts on its environment at a point fixed in a body (world axes)."""
    body: str
    local: np.ndarray
    force: np.ndarray
    moment: np.ndarray


@dataclass
class BodyState:
    R: np.ndarray
    origin: np.ndarray
    joint_point: np.ndarray
    axis: np.ndarray             # world joint axis (zero for a fixed joint)
    w: np.ndarray
    dw: np.ndarray
    a: np.ndarray                # acceleration of the body origin (gravity included)
    force: np.ndarray = None     # exerted by the parent on the body
    moment: np.ndarray = None    # about the joint point


class NewtonEuler:
    """The recursion for one robot with numeric parameter values (robot defaults, overridden)."""

    def __init__(self, robot: RobotModel, values: Optional[Mapping[str, float]] = None):
        self.robot = robot
        subs = {p.symbol: float(v) for p, v in zip(robot.parameters.values(),
                                                    robot.parameter_values(values).values())}
        q = sp.Matrix(robot.q)

        def num(x):
            out = np.array(sp.Matrix(x).xreplace(subs).evalf(), dtype=float)
            return out.reshape(-1) if out.shape[1] == 1 else out

        self.gravity = num(robot.gravity)
        self.bodies = []
        values_expr = []
        for body in robot.bodies:
            j = body.joint
            self.bodies.append(dict(
                name=body.name, parent=body.parent, type=j.type,
                axis=num(sp.Matrix(j.axis)) if j.type != "fixed" else np.zeros(3),
                pre_R=num(j.pre.R), pre_p=num(j.pre.p), post_R=num(j.post.R), post_p=num(j.post.p),
                mass=float(sp.sympify(body.mass).xreplace(subs)), com=num(body.com), inertia=num(body.inertia)))
            values_expr.append(sp.sympify(j.value).xreplace(subs) if j.type != "fixed" else sp.Integer(0))
        theta = sp.Matrix(values_expr)
        E = theta.jacobian(q)
        dq = sp.Matrix(robot.dq)
        Edot_dq = (E * dq).jacobian(q) * dq
        self._theta = numeric_function([list(q)], list(theta), "numpy")
        self._E = numeric_function([list(q)], E, "numpy")
        self._Edq = numeric_function([list(q), list(dq)], list(Edot_dq), "numpy")
        self.index = {b["name"]: i for i, b in enumerate(self.bodies)}

    # ---------------------------------------------------------------- kinematics
    def _joint_values(self, q, dq, ddq):
        q = np.asarray(q, float).reshape(-1)
        dq = np.asarray(dq, float).reshape(-1)
        ddq = np.asarray(ddq, float).reshape(-1)
        if not (q.size == dq.size == ddq.size == self.robot.n):
            raise NewtonEulerError(f"expected {self.robot.n} values for q, q', q''")
        E = np.asarray(self._E(q), float).reshape(len(self.bodies), -1)
        th = np.asarray(self._theta(q), float).reshape(-1)
        dth = E @ dq
        ddth = E @ ddq + np.asarray(self._Edq(q, dq), float).reshape(-1)
        return th, dth, ddth, E

    def forward(self, q, dq=None, ddq=None, gravity: bool = True) -> Tuple[List[BodyState], np.ndarray]:
        """Forward recursion; returns the body states and E = d theta / d q."""
        n = self.robot.n
        dq = np.zeros(n) if dq is None else dq
        ddq = np.zeros(n) if ddq is None else ddq
        th, dth, ddth, E = self._joint_values(q, dq, ddq)
        base_a = -self.gravity if gravity else np.zeros(3)
        states: List[BodyState] = []
        for i, b in enumerate(self.bodies):
            if b["parent"] is None:
                R_P, o_P, w_P, dw_P, a_P = np.eye(3), np.zeros(3), np.zeros(3), np.zeros(3), base_a
            else:
                P = states[self.index[b["parent"]]]
                R_P, o_P, w_P, dw_P, a_P = P.R, P.origin, P.w, P.dw, P.a
            R_j = R_P @ b["pre_R"]
            p_j = o_P + R_P @ b["pre_p"]
            r = p_j - o_P
            a_j = a_P + np.cross(dw_P, r) + np.cross(w_P, np.cross(w_P, r))
            z = R_j @ b["axis"] if b["type"] != "fixed" else np.zeros(3)
            w, dw, R_m, p_m, a_m = w_P, dw_P, R_j, p_j, a_j
            if b["type"] == "revolute":
                w = w_P + z * dth[i]
                dw = dw_P + z * ddth[i] + np.cross(w_P, z) * dth[i]
                R_m = R_j @ _rotation(b["axis"], th[i])
            elif b["type"] == "prismatic":
                p_m = p_j + z * th[i]
                d = z * th[i]
                a_m = a_j + np.cross(dw_P, d) + np.cross(w_P, np.cross(w_P, d)) \
                    + 2 * np.cross(w_P, z) * dth[i] + z * ddth[i]
            R = R_m @ b["post_R"]
            o = p_m + R_m @ b["post_p"]
            rr = o - p_m
            a = a_m + np.cross(dw, rr) + np.cross(w, np.cross(w, rr))
            states.append(BodyState(R, o, p_m, z, w, dw, a))
        return states, E

    def point(self, states: Sequence[BodyState], body: str, local) -> np.ndarray:
        st = states[self._body(body)]
        return st.origin + st.R @ np.asarray(local, float)

    def _body(self, name: str) -> int:
        if name not in self.index:
            raise NewtonEulerError(f"{self.robot.name} has no body '{name}' (bodies: {', '.join(self.index)})")
        return self.index[name]

    def geometric_jacobian(self, q, body: str, local=(0, 0, 0)) -> np.ndarray:
        """6 x n Jacobian (linear velocity of the point, angular velocity of the body) from the
        joint axes: column of joint i is (z_i x (p - p_i), z_i) or (z_i, 0), mapped by E."""
        states, E = self.forward(q)
        p = self.point(states, body, local)
        chain = {b.name for b in self.robot.chain(body)}
        J_theta = np.zeros((6, len(self.bodies)))
        for i, (b, st) in enumerate(zip(self.bodies, states)):
            if b["name"] not in chain or b["type"] == "fixed":
                continue
            if b["type"] == "revolute":
                J_theta[:3, i] = np.cross(st.axis, p - st.joint_point)
                J_theta[3:, i] = st.axis
            else:
                J_theta[:3, i] = st.axis
        return J_theta @ E

    # ---------------------------------------------------------------- dynamics
    def inverse_dynamics(self, q, dq, ddq, gravity: bool = True,
                         wrenches: Sequence[Wrench] = ()) -> np.ndarray:
        """Generalized forces u on the robot's coordinates: M q'' + c + g (+ J^T F_e)."""
        states, E = self.forward(q, dq, ddq, gravity)
        self.backward(states, wrenches)
        tau = np.array([st.moment @ st.axis if b["type"] == "revolute" else
                        (st.force @ st.axis if b["type"] == "prismatic" else 0.0)
                        for b, st in zip(self.bodies, states)])
        return E.T @ tau

    def backward(self, states: List[BodyState], wrenches: Sequence[Wrench] = ()) -> None:
        """Fill the force and moment each parent exerts on its child (about the joint point)."""
        for st in states:
            st.force, st.moment = np.zeros(3), np.zeros(3)
        for wr in wrenches:
            st = states[self._body(wr.body)]
            p = st.origin + st.R @ np.asarray(wr.local, float)
            st.force += np.asarray(wr.force, float)
            st.moment += np.asarray(wr.moment, float) + np.cross(p - st.joint_point, wr.force)
        for i in reversed(range(len(self.bodies))):
            b, st = self.bodies[i], states[i]
            c = st.origin + st.R @ b["com"]
            rc = c - st.origin
            a_c = st.a + np.cross(st.dw, rc) + np.cross(st.w, np.cross(st.w, rc))
            I = st.R @ b["inertia"] @ st.R.T
            f_in = b["mass"] * a_c
            st.force += f_in
            st.moment += I @ st.dw + np.cross(st.w, I @ st.w) + np.cross(c - st.joint_point, f_in)
            if b["parent"] is not None:
                P = states[self.index[b["parent"]]]
                P.force += st.force
                P.moment += st.moment + np.cross(st.joint_point - P.joint_point, st.force)
