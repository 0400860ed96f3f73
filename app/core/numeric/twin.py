"""The robot built in pinocchio, and the cross-check of the symbolic model against it.

``PinocchioTwin`` builds the same robot in pinocchio and maps its joint space to the robot's
coordinates; ``cross_check`` compares the compiled symbolic model with it at random states.

>>> from app.core.robot import load_robot
>>> cross_check(load_robot("planar_2r"), states=5).ok
True
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import Dict, List, Mapping, Optional, Tuple, Union

import numpy as np
import sympy as sp

from ..dynamics import Dynamics
from ..robot import DELTA, RobotModel
from ..expressions import symbol
from .model import CompiledModel, NumericModel, compiled_model


# ====================================================================== pinocchio twin
class PinocchioTwin:
    """The robot built in pinocchio with the same numbers, mapped to the robot's coordinates.

    Pinocchio's joint variables are theta = f(q) (the joint expressions of the robot file);
    M_q = E^T M E, c_q = E^T (C theta' + M E' q'), g_q = E^T g with E = d theta / d q."""

    def __init__(self, robot: RobotModel, values: Mapping[str, float]):
        import pinocchio as pin
        self.pin = pin
        self.robot = robot
        subs = {sp.Symbol(k, real=True): v for k, v in values.items()}
        self._subs = subs
        model = pin.Model()
        model.gravity.linear = np.array([float(e.subs(subs)) for e in robot.gravity])
        joint_of: Dict[Optional[str], int] = {None: 0}
        frame_in_joint: Dict[Optional[str], object] = {None: pin.SE3.Identity()}
        joint_exprs: List[sp.Expr] = []
        q = robot.q
        for body in robot.bodies:
            j = body.joint
            parent_joint = joint_of[body.parent]
            placement = frame_in_joint[body.parent] * self._se3(j.pre)
            if j.type == "fixed":
                joint_of[body.name] = parent_joint
                frame_in_joint[body.name] = placement * self._se3(j.post)
            else:
                jm = self._joint_model(j.type, j.axis)
                jid = model.addJoint(parent_joint, jm, placement, body.name)
                joint_exprs.append(j.value)
                joint_of[body.name] = jid
                frame_in_joint[body.name] = self._se3(j.post)
            mass = float(body.mass.subs(subs))
            com = np.array([float(e.subs(subs)) for e in body.com])
            inertia = np.array(body.inertia.subs(subs), dtype=float)
            if mass != 0 or np.any(inertia):
                jid = joint_of[body.name]
                local = frame_in_joint[body.name]
                Ibody = pin.Inertia(mass, com, inertia)
                model.appendBodyToJoint(jid, local.act(Ibody), pin.SE3.Identity())
        for cname, inertia in robot.motor_inertias.items():
            jid = model.addJoint(0, pin.JointModelRZ(), pin.SE3.Identity(), f"motor_{cname}")
            Im = float(inertia.subs(subs))
            model.appendBodyToJoint(jid, pin.Inertia(0.0, np.zeros(3), np.diag([0.0, 0.0, Im])), pin.SE3.Identity())
            joint_exprs.append(sp.Symbol(cname, real=True))
        self.model = model
        self.data = model.createData()
        self._joint_of, self._frame_in_joint = joint_of, frame_in_joint
        self.nj = len(joint_exprs)
        # theta(q), E(q), E'(q) q' compiled once per robot content, evaluated at these values
        self.compiled = cm = compiled_model(robot)
        p = np.array([{**robot.parameter_values(), **values}[k] for k in robot.parameters], dtype=float)
        self._p = p
        fth, fE, fEdq = _joint_map(cm, joint_exprs)
        self._theta = lambda q: fth(q, p)
        self._E = lambda q: fE(q, p)
        self._Edq = lambda q, dq: fEdq(q, dq, p)

    def body_frames(self, q) -> Dict[str, np.ndarray]:
        """World 4x4 transform of every body frame at coordinates q, by pinocchio's forward
        kinematics (independent of the symbolic frames the drawing uses)."""
        pin = self.pin
        pin.forwardKinematics(self.model, self.data, np.asarray(self._theta(np.asarray(q, float)), float).ravel())
        out = {}
        for body in self.robot.bodies:
            placement = self.data.oMi[self._joint_of[body.name]] * self._frame_in_joint[body.name]
            out[body.name] = placement.homogeneous.copy()
        return out

    # ------------------------------------------------------------------ springs, dampers, friction
    @cached_property
    def _stretch_springs(self):
        """(stretch(q), its gradient(q), elastic force law f(delta)) of each spring given by ``expr``."""
        robot, p, out = self.robot, self._p, []
        q, ps, delta = robot.q, robot.parameter_symbols, symbol(DELTA)
        for i, spring in enumerate(robot.springs):
            if spring.expr is None:
                continue
            stretch = spring.expr - spring.rest
            law = spring.stiffness * delta if spring.is_linear else spring.force
            fs = self.compiled.compile(f"twin:spring{i}", [q, ps], stretch)
            fg = self.compiled.compile(f"twin:spring{i}:grad", [q, ps], [sp.diff(stretch, qk) for qk in q])
            fl = self.compiled.compile(f"twin:spring{i}:law", [delta, ps], law)
            out.append((lambda x, f=fs: f(x, p), lambda x, f=fg: f(x, p), lambda d, f=fl: f(d, p)))
        return out

    def _point(self, body: Optional[str], local: sp.Matrix) -> Tuple[np.ndarray, np.ndarray]:
        """World position and linear Jacobian (3 x joints) of a point fixed in a body, from pinocchio
        (after forwardKinematics and computeJointJacobians)."""
        pin = self.pin
        local = np.array([float(e.subs(self._subs)) for e in local])
        if body is None:
            return local, np.zeros((3, self.model.nv))
        jid = self._joint_of[body]
        placement = self.data.oMi[jid] * self._frame_in_joint[body]
        p = placement.act(local)
        J6 = pin.getJointJacobian(self.model, self.data, jid, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
        r = p - self.data.oMi[jid].translation
        skew = np.array([[0, -r[2], r[1]], [r[2], 0, -r[0]], [-r[1], r[0], 0]])
        return p, J6[:3] - skew @ J6[3:]

    def spring_forces(self, q) -> np.ndarray:
        """Elastic generalized forces from the robot file's springs, computed without the symbolic
        model: f(delta) mapped by the stretch's gradient, and point springs k (p_a - p_b) mapped by
        pinocchio's point Jacobians."""
        q = np.asarray(q, dtype=float)
        tau = np.zeros(self.robot.n)
        for stretch, gradient, law in self._stretch_springs:
            tau += np.asarray(gradient(q), dtype=float).reshape(-1) * float(law(float(stretch(q))))
        point_springs = [s for s in self.robot.springs if s.expr is None]
        if point_springs:
            pin = self.pin
            th = np.asarray(self._theta(q), dtype=float).reshape(-1)
            pin.forwardKinematics(self.model, self.data, th)
            pin.computeJointJacobians(self.model, self.data, th)
            E = np.asarray(self._E(q), dtype=float).reshape(self.nj, -1)
            for spring in point_springs:
                (ba, la), (bb, lb) = spring.points
                (pa, Ja), (pb, Jb) = self._point(ba, la), self._point(bb, lb)
                k = float(spring.stiffness.subs(self._subs))
                tau += E.T @ ((Ja - Jb).T @ (k * (pa - pb)))
        return tau

    def friction_forces(self, dq) -> np.ndarray:
        """Viscous and Coulomb friction and damper forces from the robot file's coefficients."""
        robot, dq = self.robot, np.asarray(dq, dtype=float)
        tau = np.zeros(robot.n)
        for table, law in ((robot.viscous, lambda v: v), (robot.coulomb, np.sign)):
            for cname, coeff in table.items():
                k = robot.coordinates.index(cname)
                tau[k] += float(coeff.subs(self._subs)) * law(dq[k])
        for damper in robot.dampers:
            a = np.array([float(sp.diff(damper.expr, qk).subs(self._subs)) for qk in robot.q])
            tau += float(damper.coefficient.subs(self._subs)) * a * (a @ dq)
        return tau

    def _se3(self, tf):
        R = np.array(tf.R.subs(self._subs), dtype=float)
        p = np.array([float(e.subs(self._subs)) for e in tf.p])
        return self.pin.SE3(R, p)

    def _joint_model(self, jtype, axis):
        pin = self.pin
        named = {("revolute", (1, 0, 0)): pin.JointModelRX, ("revolute", (0, 1, 0)): pin.JointModelRY,
                 ("revolute", (0, 0, 1)): pin.JointModelRZ, ("prismatic", (1, 0, 0)): pin.JointModelPX,
                 ("prismatic", (0, 1, 0)): pin.JointModelPY, ("prismatic", (0, 0, 1)): pin.JointModelPZ}
        if isinstance(axis, tuple) and (jtype, axis) in named:
            return named[(jtype, axis)]()
        vec = np.array([float(a) for a in axis], dtype=float)
        if jtype == "revolute":
            return pin.JointModelRevoluteUnaligned(vec)
        return pin.JointModelPrismaticUnaligned(vec)

    def terms(self, q, dq) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(M, c, g) in the robot's coordinates: c = C(q, q') q'."""
        pin = self.pin
        q = np.asarray(q, dtype=float)
        dq = np.asarray(dq, dtype=float)
        th = np.asarray(self._theta(q), dtype=float).reshape(-1)
        E = np.asarray(self._E(q), dtype=float).reshape(self.nj, -1)
        dth = E @ dq
        M = pin.crba(self.model, self.data, th)
        M = np.triu(M) + np.triu(M, 1).T
        g = pin.computeGeneralizedGravity(self.model, self.data, th)
        nle = pin.nonLinearEffects(self.model, self.data, th, dth)
        Edq = np.asarray(self._Edq(q, dq), dtype=float).reshape(-1)
        Mq = E.T @ M @ E
        cq = E.T @ (nle - g + M @ Edq)
        gq = E.T @ g
        return Mq, cq, gq


def _joint_map(cm: CompiledModel, joint_exprs) -> Tuple:
    """theta(q, p), E(q, p) = d theta / d q and E'(q) q' (q, q', p): pinocchio's joint variables
    from the robot's coordinates."""
    robot = cm.robot
    q, dq, ps = robot.q, robot.dq, robot.parameter_symbols

    def terms():
        theta = sp.Matrix(joint_exprs)
        E = theta.jacobian(sp.Matrix(q))
        return theta, E, (E * sp.Matrix(dq)).jacobian(sp.Matrix(q)) * sp.Matrix(dq)
    return (cm.function("twin:theta", lambda: ([q, ps], terms()[0])),
            cm.function("twin:E", lambda: ([q, ps], terms()[1])),
            cm.function("twin:Edq", lambda: ([q, dq, ps], terms()[2])))


@dataclass
class CrossCheck:
    robot: str
    states: int
    max_rel_error: Dict[str, float]
    tolerance: float

    @property
    def ok(self) -> bool:
        return all(v <= self.tolerance for v in self.max_rel_error.values())

    def summary(self) -> str:
        errs = ", ".join(f"{k} {v:.1e}" for k, v in self.max_rel_error.items())
        verdict = "OK" if self.ok else "MISMATCH"
        return f"{self.robot}: symbolic vs pinocchio at {self.states} random states: {errs} -> {verdict}"


def random_state(robot: RobotModel, rng: np.random.Generator) -> Tuple[np.ndarray, np.ndarray]:
    """(q within the position limits, q' in [-2, 2]) drawn from ``rng``."""
    q = robot.random_configuration(rng)
    return q, rng.uniform(-2, 2, robot.n)


def cross_check(robot: Union[RobotModel, CompiledModel], params: Optional[Mapping[str, float]] = None,
                states: int = 50, seed: int = 0, tolerance: float = 1e-9,
                dynamics: Optional[Dynamics] = None) -> CrossCheck:
    """Compare symbolic M, C q', g with pinocchio at random states, and the spring and friction
    terms with their direct evaluation from the robot file. Errors are relative to the size of the
    model at that state (the largest entry of M, C q' and g, at least 1): pinocchio gets C q' as
    rnea(q, q', 0) - g, so its round-off follows the largest term, e.g. g with a mass of 1e9 kg.
    ``robot``: a robot or its compiled model (``compiled_model(robot, dynamics)``, whose functions
    are then used as they are); ``dynamics``: the robot's model when the caller has derived it
    already (else derived here when needed)."""
    num = NumericModel(robot, params, dynamics)
    robot = num.robot
    twin = PinocchioTwin(robot, num.values)
    rng = np.random.default_rng(seed)
    worst = {"M": 0.0, "Cdq": 0.0, "g": 0.0}
    if robot.springs:
        worst["spring"] = 0.0
    if robot.has_friction:
        worst["friction"] = 0.0
    for _ in range(states):
        q, dq = random_state(robot, rng)
        Mp, cp, gp = twin.terms(q, dq)
        Ms, cs, gs = num.M(q), num.c(q, dq), num.g(q)
        pairs = [("M", Ms, Mp), ("Cdq", cs, cp), ("g", gs, gp)]
        if robot.springs:
            pairs.append(("spring", num.spring(q), twin.spring_forces(q)))
        if robot.has_friction:
            pairs.append(("friction", num.friction(dq), twin.friction_forces(dq)))
        model_scale = max(1.0, *(float(np.max(np.abs(t))) for t in (Mp, cp, gp) if t.size))
        for key, a, b in pairs:
            own = float(np.max(np.abs(b))) if b.size else 0.0
            scale = max(1.0, own) if key in ("spring", "friction") else max(model_scale, own)
            err = float(np.max(np.abs(a - b))) / scale if a.size else 0.0
            worst[key] = max(worst[key], err)
    return CrossCheck(robot.name, states, worst, tolerance)
