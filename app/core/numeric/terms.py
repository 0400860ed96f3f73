"""Numeric dynamics and task points at fixed parameter values, fast enough for a 1 kHz loop.

``ModelTerms`` gives M, the bias forces, inverse and forward dynamics of a robot at one set of
parameter values, from pinocchio where the robot's joint variables are its coordinates, else from
the compiled symbolic model; ``TaskPoint`` a point's position, Jacobian and J' q' in task
coordinates. Both take their compiled functions from the robot's ``CompiledModel``.
"""
from __future__ import annotations

from typing import Mapping, Optional, Sequence, Tuple, Union

import numpy as np
import sympy as sp

from ..errors import SimulationError
from ..robot import RobotModel
from .model import NumericModel, compiled_model
from .twin import PinocchioTwin


# ====================================================================== fast model terms
class ModelTerms:
    """Numeric dynamics at fixed parameter values, fast enough for a 1 kHz loop.

    With ``backend="pinocchio"`` (the default when the robot's joint variables are its coordinates,
    in order) M, the bias forces, inverse and forward dynamics come from pinocchio (crba,
    nonLinearEffects, rnea, aba); spring and friction terms of the robot file (and an optional
    extra viscous friction) are added, as linear maps when they are linear. Otherwise everything
    comes from the lambdified symbolic model (``NumericModel``).

    >>> from app.core.robot import load_robot
    >>> fast = ModelTerms(load_robot("planar_2r"))
    >>> slow = ModelTerms(load_robot("planar_2r"), backend="symbolic")
    >>> q, dq, tau = np.array([0.3, -0.2]), np.array([1.0, 0.5]), np.array([2.0, -1.0])
    >>> fast.backend, bool(np.allclose(fast.forward_dynamics(q, dq, tau), slow.forward_dynamics(q, dq, tau)))
    ('pinocchio', True)
    """

    def __init__(self, robot: RobotModel, params: Optional[Mapping[str, float]] = None,
                 backend: str = "auto", extra_viscous: Optional[Sequence[float]] = None):
        if backend not in ("auto", "pinocchio", "symbolic"):
            raise SimulationError(f"unknown backend '{backend}' (auto, pinocchio or symbolic)")
        self.robot = robot
        self.num = NumericModel(robot, params)
        self.values = self.num.values
        self.n = n = robot.n
        self.extra_viscous = None if extra_viscous is None else np.asarray(extra_viscous, dtype=float).reshape(n)
        spring_lin, friction_lin, identity, pin_model = self.num.model.at_values(
            ("terms", self.num.ws.key), lambda: _prepare_terms(robot, self.num))
        if backend == "pinocchio" and not identity:
            raise SimulationError(f"{robot.name}: the pinocchio backend needs joint variables equal to the "
                                  "coordinates (in order); use the symbolic backend")
        self.backend = "pinocchio" if (backend != "symbolic" and identity) else "symbolic"
        self._spring_diagonal = self._friction_diagonal = None   # diagonal linear maps, when they are
        self.spring = self._spring_function(spring_lin)
        self.friction = self._friction_function(friction_lin)
        if self.backend == "pinocchio":
            self._bind_pinocchio(pin_model())
        else:
            self._bind_symbolic()

    # -------------------------------------------------------------- springs and friction
    def _spring_function(self, lin):
        """k(q) (the gradient of the elastic energy), as a (diagonal) linear map when it is one."""
        n = self.n
        if not self.robot.springs:
            self.has_spring = False
            return lambda q: np.zeros(n)
        self.has_spring = True
        if lin is None:
            return self.num.spring
        K, k0 = lin
        Kd = _diagonal(K)
        if Kd is not None and not np.any(k0):
            self._spring_diagonal = Kd
        if np.any(k0):
            return (lambda q: Kd * q + k0) if Kd is not None else (lambda q: K @ q + k0)
        return (lambda q: Kd * q) if Kd is not None else (lambda q: K @ q)

    def _friction_function(self, lin):
        """Friction forces of the robot file plus the extra viscous friction of a plant."""
        n = self.n
        ev = self.extra_viscous
        if self.robot.coulomb:
            self.has_friction = True
            fr = self.num.friction
            return fr if ev is None else (lambda dq: fr(dq) + ev * dq)
        Fv = np.zeros((n, n)) if lin is None else lin[0]
        if ev is not None:
            Fv = Fv + np.diag(ev)
        self.has_friction = bool(np.any(Fv))
        if not self.has_friction:
            return lambda dq: np.zeros(n)
        Fd = _diagonal(Fv)
        self._friction_diagonal = Fd
        return (lambda dq: Fd * dq) if Fd is not None else (lambda dq: Fv @ dq)

    # -------------------------------------------------------------- hot-path closures
    def _bind_symbolic(self):
        num, spring = self.num, self.spring
        ev = self.extra_viscous

        def bias(q, dq):
            b = num.bias(q, dq)
            return b if ev is None else b + ev * dq
        self.M = num.M
        self.Minv = lambda q: np.linalg.inv(num.M(q))
        self.bias = bias
        self.inverse_dynamics = lambda q, dq, a: num.M(q) @ a + bias(q, dq)
        self.forward_dynamics = lambda q, dq, tau: np.linalg.solve(num.M(q), tau - bias(q, dq))
        self.gravity = lambda q: num.g(q) + spring(q)
        self.coriolis_matrix = num.C

    def _bind_pinocchio(self, model):
        import pinocchio as pin
        data = model.createData()
        aba, rnea, crba, nle = pin.aba, pin.rnea, pin.crba, pin.nonLinearEffects
        minv, grav, cor = pin.computeMinverse, pin.computeGeneralizedGravity, pin.computeCoriolisMatrix
        spring, friction = self.spring, self.friction
        self.M = lambda q: crba(model, data, q)
        self.Minv = lambda q: minv(model, data, q)
        self.coriolis_matrix = lambda q, dq: cor(model, data, q, dq)
        if self.has_spring:
            self.gravity = lambda q: grav(model, data, q) + spring(q)
        else:
            self.gravity = lambda q: grav(model, data, q)
        Kd, Fd = self._spring_diagonal, self._friction_diagonal
        if self.has_spring and not self.has_friction and Kd is not None:
            # the usual elastic joint: k(q) = K q with K diagonal, inlined in the hot path
            self.bias = lambda q, dq: nle(model, data, q, dq) + Kd * q
            self.inverse_dynamics = lambda q, dq, a: rnea(model, data, q, dq, a) + Kd * q
            self.forward_dynamics = lambda q, dq, tau: aba(model, data, q, dq, tau - Kd * q)
            return
        if self.has_spring and self.has_friction and Kd is not None and Fd is not None:
            extra = lambda q, dq: Kd * q + Fd * dq
        elif self.has_spring and self.has_friction:
            extra = lambda q, dq: spring(q) + friction(dq)
        elif self.has_spring:
            extra = lambda q, dq: spring(q)
        elif self.has_friction:
            extra = lambda q, dq: friction(dq)
        else:
            self.bias = lambda q, dq: nle(model, data, q, dq)
            self.inverse_dynamics = lambda q, dq, a: rnea(model, data, q, dq, a)
            self.forward_dynamics = lambda q, dq, tau: aba(model, data, q, dq, tau)
            return
        self.bias = lambda q, dq: nle(model, data, q, dq) + extra(q, dq)
        self.inverse_dynamics = lambda q, dq, a: rnea(model, data, q, dq, a) + extra(q, dq)
        self.forward_dynamics = lambda q, dq, tau: aba(model, data, q, dq, tau - extra(q, dq))


def _prepare_terms(robot: RobotModel, num: NumericModel):
    """Parameter-dependent pieces of ModelTerms worth caching: linear spring and friction maps,
    whether pinocchio's joints are the coordinates, and a factory of the pinocchio model."""
    q, dq = robot.q, robot.dq
    subs = {sp.Symbol(k, real=True): v for k, v in num.values.items()}
    spring_lin = _linear_map(num.dyn.spring, q, subs) if robot.springs else None
    friction_lin = (_linear_map(num.dyn.friction, dq, subs)
                    if (robot.viscous or robot.dampers) and not robot.coulomb else None)
    joint_values = [b.joint.value for b in robot.bodies if b.joint.type != "fixed"]
    joint_values += [sp.Symbol(c, real=True) for c in robot.motor_inertias]
    identity = len(joint_values) == robot.n and all(v == s for v, s in zip(joint_values, q))
    holder = {}

    def pin_model():
        if "model" not in holder:
            holder["model"] = PinocchioTwin(robot, num.values).model
        return holder["model"]
    return spring_lin, friction_lin, identity, pin_model


def _diagonal(A: Optional[np.ndarray]) -> Optional[np.ndarray]:
    """The diagonal of A when A is diagonal, else None."""
    if A is None or np.any(A - np.diag(np.diag(A))):
        return None
    return np.diag(A).copy()


def _linear_map(vec: sp.Matrix, variables, subs) -> Optional[Tuple[np.ndarray, np.ndarray]]:
    """(A, b) with vec = A x + b at the given parameter values, or None when vec is not linear in x."""
    A = vec.jacobian(sp.Matrix(variables))
    if any(e.free_symbols & set(variables) for e in A):
        return None
    b = vec - A * sp.Matrix(variables)
    b = b.subs({v: 0 for v in variables})
    try:
        return (np.array(A.subs(subs), dtype=float).reshape(len(vec), len(variables)),
                np.array(b.subs(subs), dtype=float).reshape(len(vec)))
    except TypeError:
        return None


# ====================================================================== task points
class TaskPoint:
    """A point fixed in a body: position p(q), Jacobian J(q) and J'(q) q' in task coordinates
    (x, y for planar robots, x, y, z otherwise), at fixed parameter values.

    >>> from app.core.robot import load_robot
    >>> ee = TaskPoint(load_robot("planar_2r"), "ee")
    >>> (ee.position(np.array([0.0, 0.0])).round(6) + 0.0).tolist(), ee.dim
    ([1.8, 0.0], 2)
    """

    def __init__(self, robot: RobotModel, point: Union[str, Tuple[Optional[str], Sequence]],
                 values: Optional[Mapping[str, float]] = None):
        body, local, label = resolve_point(robot, point)
        self.robot, self.body, self.local, self.name = robot, body, local, label
        self.rows = [0, 1] if robot.is_planar else [0, 1, 2]
        self.dim = len(self.rows)
        self.axes = ["x", "y", "z"][:self.dim]
        values = dict(robot.parameter_values()) if values is None else dict(values)
        self.p = np.array([values[name] for name in robot.parameters], dtype=float)
        self._model = compiled_model(robot)
        fns = self._model.task_point(body, local)
        self._fp, self._fJ, self._fall = fns
        self._shape = (self.dim, robot.n)

    def position(self, q) -> np.ndarray:
        return np.asarray(self._fp(q, self.p), dtype=float).reshape(self.dim)

    def jacobian(self, q) -> np.ndarray:
        return np.asarray(self._fJ(q, self.p), dtype=float).reshape(self._shape)

    def angular_jacobian(self, q) -> np.ndarray:
        """J_w(q) (3 x n, world frame) of the body the point is fixed in."""
        fn = self.__dict__.get("_fJw")
        if fn is None:
            fn = self._fJw = self._model.angular_jacobian(self.body)
        return np.asarray(fn(q, self.p), dtype=float).reshape(3, self.robot.n)

    def kinematics(self, q, dq) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(p, J, J' q') in one evaluation; J' q' is the velocity-product part of the acceleration."""
        p, J, Jd = self._fall(q, dq, self.p)
        return (np.asarray(p, dtype=float).reshape(self.dim), np.asarray(J, dtype=float).reshape(self._shape),
                np.asarray(Jd, dtype=float).reshape(self.dim))


def resolve_point(robot: RobotModel, point) -> Tuple[Optional[str], Tuple, str]:
    """(body, local position, label) of a named point, a body name (its frame origin), or a
    (body, [x, y, z]) pair."""
    if isinstance(point, str):
        if point in robot.points:
            pt = robot.points[point]
            return pt.body, tuple(pt.position), point
        if point in [b.name for b in robot.bodies]:
            return point, (0, 0, 0), point
        names = list(robot.points) + [b.name for b in robot.bodies]
        raise SimulationError(f"{robot.name} has no point or body '{point}' (known: {', '.join(names)})")
    try:
        body, local = point
        local = tuple(float(x) for x in local)
    except (TypeError, ValueError):
        raise SimulationError(f"a point is a name or (body, [x, y, z]), got {point!r}") from None
    if len(local) == 2:
        local = local + (0.0,)
    if len(local) != 3:
        raise SimulationError(f"a point's local position needs 3 coordinates, got {len(local)}")
    if body not in (None, "base") and body not in [b.name for b in robot.bodies]:
        raise SimulationError(f"{robot.name} has no body '{body}'")
    body = None if body == "base" else body
    return body, local, f"{body or 'base'}@{','.join(f'{x:g}' for x in local)}"

