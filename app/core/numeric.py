"""Fast numeric functions of a robot's model and its pinocchio twin.

``NumericModel`` evaluates M, C, c, g, spring and friction terms, energies, forward dynamics,
frames and point Jacobians at numeric states, from lambdified (CSE) versions of the symbolic model,
with parameters that can be changed at any time. ``PinocchioTwin`` builds the same robot in
pinocchio and maps its joint space to the robot's coordinates; ``cross_check`` compares the two.

>>> from app.core.robot import load_robot
>>> num = NumericModel(load_robot("planar_2r"))
>>> bool(np.allclose(num.M([0.1, 0.2]), num.M([0.1, 0.2]).T))
True
"""
from __future__ import annotations

import threading
from dataclasses import dataclass
from functools import cached_property
from typing import Dict, List, Mapping, Optional, Sequence, Tuple

import numpy as np
import sympy as sp

from .dynamics import Dynamics, derive
from .kinematics import Kinematics
from .expressions import symbol
from .robot import DELTA, ParameterError, RobotModel  # noqa: F401 (ParameterError re-exported)

_LAMBDA_CACHE: Dict[Tuple[str, str], object] = {}
_LAMBDA_LOCK = threading.Lock()


def compiled_function(robot: RobotModel, tag: str, args, expr):
    """``sympy.lambdify(args, expr)`` (numpy, common subexpressions eliminated), compiled once per
    robot file and ``tag`` and shared by every user in the process."""
    key = (robot.content_hash or repr(robot), tag)
    with _LAMBDA_LOCK:
        fn = _LAMBDA_CACHE.get(key)
    if fn is None:
        fn = sp.lambdify(args, expr, modules="numpy", cse=True)
        with _LAMBDA_LOCK:
            _LAMBDA_CACHE[key] = fn
    return fn


class NumericModel:
    """Numeric evaluation of a robot's dynamics at given parameter values (defaults from the file)."""

    def __init__(self, robot: RobotModel, params: Optional[Mapping[str, float]] = None,
                 dynamics: Optional[Dynamics] = None):
        self.robot = robot
        if dynamics is not None:
            self.dyn = dynamics             # else derived on first use (kinematics and pinocchio need none)
        self.n = robot.n
        self._q = robot.q
        self._dq = robot.dq
        self._ddq = robot.ddq
        self._p = robot.parameter_symbols
        self.set_parameters(params or {})

    # ------------------------------------------------------------------ parameters
    def set_parameters(self, params: Mapping[str, float]) -> None:
        values = dict(self.robot.parameter_values())
        for name, value in params.items():
            if isinstance(value, np.number):
                value = value.item()
            values[name] = self.robot.check_parameter_value(name, value)
        self.values = values
        self.p = np.array([values[name] for name in self.robot.parameters], dtype=float)

    @cached_property
    def dyn(self) -> Dynamics:
        """The symbolic model (derived, or read from the derivation cache, when first needed)."""
        return derive(self.robot)

    # ------------------------------------------------------------------ compiled functions
    @cached_property
    def _fM(self):
        return compiled_function(self.robot, "M", [self._q, self._p], self.dyn.M)

    @cached_property
    def _fC(self):
        return compiled_function(self.robot, "C", [self._q, self._dq, self._p], self.dyn.C)

    @cached_property
    def _fg(self):
        return compiled_function(self.robot, "g", [self._q, self._p], self.dyn.g)

    @cached_property
    def _fk(self):
        return compiled_function(self.robot, "k", [self._q, self._p], self.dyn.spring)

    @cached_property
    def _ffr(self):
        return compiled_function(self.robot, "friction", [self._dq, self._p], self.dyn.friction)

    @cached_property
    def _fE(self):
        T = sum(self.dyn.kinetic.values(), sp.Integer(0))
        U = sum(self.dyn.potential.values(), sp.Integer(0))
        return compiled_function(self.robot, "energy", [self._q, self._dq, self._p], sp.Matrix([T, U]))

    # ------------------------------------------------------------------ evaluation
    def _qv(self, q):
        q = np.asarray(q, dtype=float).reshape(-1)
        if q.size != self.n:
            raise ValueError(f"expected {self.n} coordinates, got {q.size}")
        return q

    def M(self, q) -> np.ndarray:
        return np.asarray(self._fM(self._qv(q), self.p), dtype=float).reshape(self.n, self.n)

    def C(self, q, dq) -> np.ndarray:
        return np.asarray(self._fC(self._qv(q), self._qv(dq), self.p), dtype=float).reshape(self.n, self.n)

    def c(self, q, dq) -> np.ndarray:
        return self.C(q, dq) @ self._qv(dq)

    def g(self, q) -> np.ndarray:
        return np.asarray(self._fg(self._qv(q), self.p), dtype=float).reshape(self.n)

    def spring(self, q) -> np.ndarray:
        return np.asarray(self._fk(self._qv(q), self.p), dtype=float).reshape(self.n)

    def friction(self, dq) -> np.ndarray:
        return np.asarray(self._ffr(self._qv(dq), self.p), dtype=float).reshape(self.n)

    def bias(self, q, dq) -> np.ndarray:
        """c + g + k + friction: everything but M q''."""
        return self.c(q, dq) + self.g(q) + self.spring(q) + self.friction(dq)

    def inverse_dynamics(self, q, dq, ddq) -> np.ndarray:
        return self.M(q) @ self._qv(ddq) + self.bias(q, dq)

    def forward_dynamics(self, q, dq, tau) -> np.ndarray:
        return np.linalg.solve(self.M(q), np.asarray(tau, dtype=float) - self.bias(q, dq))

    def energy(self, q, dq) -> Tuple[float, float]:
        """(kinetic, potential) energy; potential includes gravity and springs."""
        T, U = np.asarray(self._fE(self._qv(q), self._qv(dq), self.p), dtype=float).reshape(2)
        return float(T), float(U)

    # ------------------------------------------------------------------ kinematics
    @cached_property
    def _kin(self) -> Kinematics:
        return Kinematics(self.robot)

    @cached_property
    def _fframes(self):
        mats = []
        for body in self.robot.bodies:
            fr = self._kin.frames[body.name]
            for f in (fr["joint"], fr["body"]):
                T = sp.eye(4)
                T[:3, :3] = f.R
                T[:3, 3] = f.p
                mats.append(T)
        return compiled_function(self.robot, "frames", [self._q, self._p], mats)

    def frames(self, q) -> Dict[str, Dict[str, np.ndarray]]:
        """World 4x4 transforms of each body's joint frame (before motion) and body frame."""
        mats = self._fframes(self._qv(q), self.p)
        out = {}
        for i, body in enumerate(self.robot.bodies):
            out[body.name] = {"joint": np.asarray(mats[2 * i], dtype=float),
                              "body": np.asarray(mats[2 * i + 1], dtype=float)}
        return out

    def point_function(self, body: Optional[str], local):
        """Compiled (position(q), jacobian(q)) of a point fixed in a body."""
        local = sp.Matrix(local)
        pos = self._kin.point_position(body, local)
        jac = pos.jacobian(sp.Matrix(self._q))
        tag = f"point:{body}:{list(local)}"
        fp = compiled_function(self.robot, tag, [self._q, self._p], pos)
        fj = compiled_function(self.robot, tag + ":J", [self._q, self._p], jac)
        return (lambda q: np.asarray(fp(self._qv(q), self.p), dtype=float).reshape(3),
                lambda q: np.asarray(fj(self._qv(q), self.p), dtype=float).reshape(3, self.n))

    def named_point(self, name: str):
        pt = self.robot.points[name]
        return self.point_function(pt.body, pt.position)


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
        theta = sp.Matrix(joint_exprs).subs(subs)
        E = theta.jacobian(sp.Matrix(q))
        dq = robot.dq
        Edot_dq = (E * sp.Matrix(dq)).jacobian(sp.Matrix(q)) * sp.Matrix(dq)
        self._theta = sp.lambdify([q], theta, "numpy")
        self._E = sp.lambdify([q], E, "numpy")
        self._Edq = sp.lambdify([q, dq], Edot_dq, "numpy")
        self.nj = len(joint_exprs)

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
        q, delta, out = self.robot.q, symbol(DELTA), []
        for spring in self.robot.springs:
            if spring.expr is None:
                continue
            stretch = (spring.expr - spring.rest).subs(self._subs)
            law = (spring.stiffness * delta if spring.is_linear else spring.force).subs(self._subs)
            out.append((sp.lambdify([q], stretch, "numpy"),
                        sp.lambdify([q], [sp.diff(stretch, qk) for qk in q], "numpy"),
                        sp.lambdify([delta], law, "numpy")))
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


def cross_check(robot: RobotModel, params: Optional[Mapping[str, float]] = None, states: int = 50,
                seed: int = 0, tolerance: float = 1e-9, dynamics: Optional[Dynamics] = None) -> CrossCheck:
    """Compare symbolic M, C q', g with pinocchio at random states, and the spring and friction
    terms with their direct evaluation from the robot file. Errors are relative to the size of the
    model at that state (the largest entry of M, C q' and g, at least 1): pinocchio gets C q' as
    rnea(q, q', 0) - g, so its round-off follows the largest term, e.g. g with a mass of 1e9 kg.
    ``dynamics``: the robot's model when the caller has derived it already (else derived here)."""
    num = NumericModel(robot, params, dynamics)
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
