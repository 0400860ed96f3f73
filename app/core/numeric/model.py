"""A robot's compiled model, a workspace of parameter values, and the algorithms over both.

In the manner of pinocchio's model/data:

- ``CompiledModel`` (``compiled_model(robot)``): every compiled function of one robot *content*
  (M, C, g, springs, friction, energies, frames, points and their Jacobians, the regressors Y and
  Y_r, the coefficients a(p), ...), each compiled once when first asked for and then shared by every
  user in the process. Its content is fixed by the robot file: it is keyed by the robot's content
  hash (two loads of one file share it) and holds no parameter values. It is the only cache of
  compiled functions in the lab.
- ``Workspace``: the parameter values of one user (a page session, a simulation's plant or its
  controller's model), checked by the robot module's one rule (``RobotModel.check_parameter_value``).
- free functions ``mass_matrix(model, ws, q)``, ``coriolis_matrix``, ``gravity``, ``spring``,
  ``friction``, ``bias``, ``inverse_dynamics``, ``forward_dynamics``, ``energy``, ``frames``.

``NumericModel`` is the two together behind one object (``num.M(q)``), for callers that hold one
robot at one set of values.

>>> from app.core.robot import load_robot
>>> robot = load_robot("planar_2r")
>>> model, ws = compiled_model(robot), Workspace(robot, {"m2": 2.0})
>>> model is compiled_model(load_robot("planar_2r"))      # one per robot content
True
>>> bool(np.allclose(mass_matrix(model, ws, [0.1, 0.2]), mass_matrix(model, ws, [0.1, 0.2]).T))
True
>>> num = NumericModel(robot)
>>> bool(np.allclose(num.M([0.1, 0.2]), num.M([0.1, 0.2]).T))
True
"""
from __future__ import annotations

import threading
from collections import OrderedDict
from functools import cached_property
from typing import Callable, Dict, Mapping, Optional, Tuple, Union

import numpy as np
import sympy as sp

from ..dynamics import Dynamics, derive
from ..kinematics import Kinematics
from ..robot import RobotModel
from .compile import numeric_function

#: parameter-dependent data kept per compiled model (linear spring maps, pinocchio models, ...):
#: the most recent sets of values only
MAX_VALUE_SETS = 32


def _compiled_term(tag: str, arguments: str, term: str) -> cached_property:
    """A CompiledModel property: the derivation's ``term`` compiled over the model's ``arguments``
    (``_qp``: q, p; ``_qdp``: q, q', p), once per model."""
    return cached_property(lambda model: model.function(tag, lambda: (getattr(model, arguments),
                                                                       getattr(model.dyn, term))))


class CompiledModel:
    """Every compiled function of one robot content, compiled on first use (see the module doc).

    Functions take ``(q, p)``, ``(q, dq, p)``, ... with ``p`` the parameter values in the order of
    ``robot.parameters``. The object never changes what a function computes: asking twice gives
    the same function."""

    def __init__(self, robot: RobotModel, key: str):
        self.robot = robot
        self.key = key
        self.n = robot.n
        self._functions: Dict[str, Callable] = {}
        self._values: "OrderedDict[tuple, object]" = OrderedDict()
        self._lock = threading.RLock()
        self._dyn: Optional[Dynamics] = None
        self._kin: Optional[Kinematics] = None

    def __repr__(self) -> str:
        return f"CompiledModel({self.robot.name}, {len(self._functions)} functions)"

    # ------------------------------------------------------------------ symbolic sources
    @property
    def dyn(self) -> Dynamics:
        """The symbolic model (derived, or read from the derivation cache, when first needed)."""
        if self._dyn is None:
            dyn = derive(self.robot)
            with self._lock:
                if self._dyn is None:
                    self._dyn = dyn
        return self._dyn

    def _offer_dynamics(self, dynamics: Optional[Dynamics]) -> None:
        """Use a model the caller derived already (same robot content, so the same M, C, g; derived
        with the default known parameters, so the same regressors)."""
        if dynamics is not None and self._dyn is None:
            with self._lock:
                if self._dyn is None:
                    self._dyn = dynamics

    @property
    def kinematics(self) -> Kinematics:
        """The symbolic kinematics (frames, point positions, Jacobians)."""
        if self._kin is None:
            kin = Kinematics(self.robot)
            with self._lock:
                if self._kin is None:
                    self._kin = kin
        return self._kin

    # ------------------------------------------------------------------ compiled functions
    def function(self, tag: str, build: Callable[[], Tuple[list, object]], cse: bool = True,
                 modules="numpy") -> Callable:
        """The function named ``tag``; ``build()`` gives its ``(args, expr)`` the first time."""
        fn = self._functions.get(tag)
        if fn is None:
            args, expr = build()
            fn = numeric_function(args, expr, modules=modules, cse=cse)
            with self._lock:
                fn = self._functions.setdefault(tag, fn)
        return fn

    def compile(self, tag: str, args, expr) -> Callable:
        """``numeric_function(args, expr)`` (numpy, CSE) kept under ``tag``: for functions of the robot that
        have no name below (the throwing arm's reduced terms, a task's matrices)."""
        return self.function(tag, lambda: (args, expr))

    @property
    def _qp(self):
        return [self.robot.q, self.robot.parameter_symbols]

    @property
    def _qdp(self):
        return [self.robot.q, self.robot.dq, self.robot.parameter_symbols]

    #: compiled M(q, p), C(q, q', p), g(q, p) and the springs k(q, p)
    fM = _compiled_term("M", "_qp", "M")
    fC = _compiled_term("C", "_qdp", "C")
    fg = _compiled_term("g", "_qp", "g")
    fk = _compiled_term("k", "_qp", "spring")

    @cached_property
    def ffr(self):
        r = self.robot
        return self.function("friction", lambda: ([r.dq, r.parameter_symbols], self.dyn.friction))

    @cached_property
    def fE(self):
        def build():
            T = sum(self.dyn.kinetic.values(), sp.Integer(0))
            U = sum(self.dyn.potential.values(), sp.Integer(0))
            return self._qdp, sp.Matrix([T, U])
        return self.function("energy", build)

    @cached_property
    def fframes(self):
        """``fn(q, p) -> [4x4, ...]``: the joint frame (before its motion) and the body frame of each
        body, in body order."""
        def build():
            mats = []
            for body in self.robot.bodies:
                fr = self.kinematics.frames[body.name]
                for f in (fr["joint"], fr["body"]):
                    T = sp.eye(4)
                    T[:3, :3] = f.R
                    T[:3, 3] = f.p
                    mats.append(T)
            return self._qp, mats
        return self.function("frames", build)

    def point(self, body: Optional[str], local) -> Tuple[Callable, Callable]:
        """(position(q, p), Jacobian(q, p)) of a point fixed in a body (world frame, 3 rows)."""
        local = sp.Matrix(local)
        tag = f"point:{body}:{list(local)}"

        def position():
            return self._qp, self.kinematics.point_position(body, local)

        def jacobian():
            pos = self.kinematics.point_position(body, local)
            return self._qp, pos.jacobian(sp.Matrix(self.robot.q))
        return self.function(tag, position), self.function(tag + ":J", jacobian)

    def task_point(self, body: Optional[str], local) -> Tuple[Callable, Callable, Callable]:
        """(p(q, p), J(q, p), all(q, dq, p) -> [p, J, J' q']) of a point in task coordinates (x, y for
        planar robots, x, y, z otherwise)."""
        rows = [0, 1] if self.robot.is_planar else [0, 1, 2]
        tag = f"task:{body}:{tuple(str(e) for e in local)}"

        def terms():
            q, dq = sp.Matrix(self.robot.q), sp.Matrix(self.robot.dq)
            pos = self.kinematics.point_position(body, sp.Matrix(local))[rows, :]
            J = pos.jacobian(q)
            return pos, J, (J * dq).jacobian(q) * dq
        return (self.function(tag, lambda: (self._qp, terms()[0])),
                self.function(tag + ":J", lambda: (self._qp, terms()[1])),
                self.function(tag + ":all", lambda: (self._qdp, list(terms()))))

    def angular_jacobian(self, body: Optional[str]) -> Callable:
        """J_w(q, p) (3 x n, world frame) of a body."""
        return self.function(f"Jw:{body}", lambda: (self._qp, self.kinematics.angular_jacobian(body)))

    def regressor_ref(self) -> Tuple[Callable, Callable]:
        """(Y_r(q, dq, dq_r, ddq_r, p), its known terms y0(q, dq, dq_r, ddq_r, p)): the Slotine-Li
        regressor, Y_r a + y0 = M ddq_r + C dq_r + g (+ springs, friction)."""
        r = self.robot
        dqr, ddqr = r.reference_symbols()
        args = [r.q, r.dq, dqr, ddqr, r.parameter_symbols]
        par = lambda: self.dyn.parametrization          # noqa: E731
        return (self.function("Y_r", lambda: (args, par().Y_ref)),
                self.function("Y_r:known", lambda: (args, par().known_terms_ref)))

    def regressor(self) -> Callable:
        """Y(q, dq, ddq, p): tau = Y a + the known terms."""
        r = self.robot
        return self.function("Y", lambda: ([r.q, r.dq, r.ddq, r.parameter_symbols], self.dyn.parametrization.Y))

    def coefficients(self) -> Callable:
        """a(p): the dynamic coefficients of the linear parametrization at parameter values p."""
        return self.function("a", lambda: ([self.robot.parameter_symbols], sp.Matrix(self.dyn.parametrization.a)))

    # ------------------------------------------------------------------ data at parameter values
    def at_values(self, key: tuple, build: Callable[[], object]):
        """Numeric data that depends on parameter values too (``key`` holds them): a pinocchio
        model, the linear maps of springs and friction. The most recent MAX_VALUE_SETS are kept."""
        with self._lock:
            if key in self._values:
                self._values.move_to_end(key)
                return self._values[key]
        value = build()
        with self._lock:
            value = self._values.setdefault(key, value)
            while len(self._values) > MAX_VALUE_SETS:
                self._values.popitem(last=False)
        return value


_MODELS: Dict[str, CompiledModel] = {}
_MODELS_LOCK = threading.Lock()


def model_key(robot: RobotModel) -> str:
    """What identifies a robot's content: its file's hash (the full description for a robot built in
    memory)."""
    return robot.content_hash or repr(robot)


def compiled_model(robot: Union[RobotModel, CompiledModel], dynamics: Optional[Dynamics] = None) -> CompiledModel:
    """The compiled model of a robot's content (one per content in the process). ``dynamics``: the
    robot's symbolic model when the caller has it already (saves deriving it again)."""
    if isinstance(robot, CompiledModel):
        robot._offer_dynamics(dynamics)
        return robot
    key = model_key(robot)
    with _MODELS_LOCK:
        model = _MODELS.get(key)
        if model is None:
            model = _MODELS[key] = CompiledModel(robot, key)
    model._offer_dynamics(dynamics)
    return model


def compiled_function(robot: RobotModel, tag: str, args, expr):
    """``numeric_function(args, expr)`` (numpy, CSE), compiled once per robot content and ``tag`` (kept by
    the robot's compiled model)."""
    return compiled_model(robot).compile(tag, args, expr)


def forget_compiled() -> None:
    """Drop every compiled model (cold benchmarks)."""
    with _MODELS_LOCK:
        _MODELS.clear()


# ====================================================================== workspace
class Workspace:
    """The parameter values of one user of a robot: ``values`` by name, ``p`` as the vector the
    compiled functions take. Values are checked by the robot module's rule."""

    def __init__(self, robot: RobotModel, params: Optional[Mapping[str, float]] = None):
        self.robot = robot
        self.set_parameters(params or {})

    def set_parameters(self, params: Mapping[str, float]) -> None:
        """The file's values, with ``params`` instead where given."""
        values = dict(self.robot.parameter_values())
        for name, value in params.items():
            if isinstance(value, np.number):
                value = value.item()
            values[name] = self.robot.check_parameter_value(name, value)
        self.values = values
        self.p = np.array([values[name] for name in self.robot.parameters], dtype=float)

    @property
    def key(self) -> tuple:
        return tuple(sorted(self.values.items()))


# ====================================================================== algorithms
def _vec(q, n: int) -> np.ndarray:
    q = np.asarray(q, dtype=float).reshape(-1)
    if q.size != n:
        raise ValueError(f"expected {n} coordinates, got {q.size}")
    return q


def mass_matrix(model: CompiledModel, ws: Workspace, q) -> np.ndarray:
    n = model.n
    return np.asarray(model.fM(_vec(q, n), ws.p), dtype=float).reshape(n, n)


def coriolis_matrix(model: CompiledModel, ws: Workspace, q, dq) -> np.ndarray:
    n = model.n
    return np.asarray(model.fC(_vec(q, n), _vec(dq, n), ws.p), dtype=float).reshape(n, n)


def gravity(model: CompiledModel, ws: Workspace, q) -> np.ndarray:
    return np.asarray(model.fg(_vec(q, model.n), ws.p), dtype=float).reshape(model.n)


def spring(model: CompiledModel, ws: Workspace, q) -> np.ndarray:
    return np.asarray(model.fk(_vec(q, model.n), ws.p), dtype=float).reshape(model.n)


def friction(model: CompiledModel, ws: Workspace, dq) -> np.ndarray:
    return np.asarray(model.ffr(_vec(dq, model.n), ws.p), dtype=float).reshape(model.n)


def bias(model: CompiledModel, ws: Workspace, q, dq) -> np.ndarray:
    """c + g + k + friction: everything but M q''."""
    n, p = model.n, ws.p
    q, dq = _vec(q, n), _vec(dq, n)
    return (np.asarray(model.fC(q, dq, p), dtype=float).reshape(n, n) @ dq
            + np.asarray(model.fg(q, p), dtype=float).reshape(n) + np.asarray(model.fk(q, p), dtype=float).reshape(n)
            + np.asarray(model.ffr(dq, p), dtype=float).reshape(n))


def inverse_dynamics(model: CompiledModel, ws: Workspace, q, dq, ddq) -> np.ndarray:
    return mass_matrix(model, ws, q) @ _vec(ddq, model.n) + bias(model, ws, q, dq)


def forward_dynamics(model: CompiledModel, ws: Workspace, q, dq, tau) -> np.ndarray:
    return np.linalg.solve(mass_matrix(model, ws, q), np.asarray(tau, dtype=float) - bias(model, ws, q, dq))


def energy(model: CompiledModel, ws: Workspace, q, dq) -> Tuple[float, float]:
    """(kinetic, potential) energy; potential includes gravity and springs."""
    T, U = np.asarray(model.fE(_vec(q, model.n), _vec(dq, model.n), ws.p), dtype=float).reshape(2)
    return float(T), float(U)


def frames(model: CompiledModel, ws: Workspace, q) -> Dict[str, Dict[str, np.ndarray]]:
    """World 4x4 transforms of each body's joint frame (before motion) and body frame."""
    mats = model.fframes(_vec(q, model.n), ws.p)
    out = {}
    for i, body in enumerate(model.robot.bodies):
        out[body.name] = {"joint": np.asarray(mats[2 * i], dtype=float),
                          "body": np.asarray(mats[2 * i + 1], dtype=float)}
    return out


# ====================================================================== model and workspace in one
class NumericModel:
    """Numeric evaluation of a robot's dynamics at given parameter values (defaults from the file):
    the robot's compiled model and one workspace."""

    def __init__(self, robot: Union[RobotModel, CompiledModel], params: Optional[Mapping[str, float]] = None,
                 dynamics: Optional[Dynamics] = None):
        self.model = compiled_model(robot, dynamics)
        self.robot = self.model.robot if isinstance(robot, CompiledModel) else robot
        self.n = self.robot.n
        self.ws = Workspace(self.robot, params)

    # ------------------------------------------------------------------ parameters
    def set_parameters(self, params: Mapping[str, float]) -> None:
        self.ws.set_parameters(params)

    @property
    def values(self) -> Dict[str, float]:
        return self.ws.values

    @property
    def p(self) -> np.ndarray:
        return self.ws.p

    @property
    def dyn(self) -> Dynamics:
        """The symbolic model (derived, or read from the derivation cache, when first needed)."""
        return self.model.dyn

    # ------------------------------------------------------------------ evaluation
    def _qv(self, q):
        return _vec(q, self.n)

    def M(self, q) -> np.ndarray:
        n = self.n
        return np.asarray(self.model.fM(_vec(q, n), self.ws.p), dtype=float).reshape(n, n)

    def C(self, q, dq) -> np.ndarray:
        return coriolis_matrix(self.model, self.ws, q, dq)

    def c(self, q, dq) -> np.ndarray:
        return self.C(q, dq) @ self._qv(dq)

    def g(self, q) -> np.ndarray:
        return gravity(self.model, self.ws, q)

    def spring(self, q) -> np.ndarray:
        return spring(self.model, self.ws, q)

    def friction(self, dq) -> np.ndarray:
        return friction(self.model, self.ws, dq)

    def bias(self, q, dq) -> np.ndarray:
        """c + g + k + friction: everything but M q''."""
        return bias(self.model, self.ws, q, dq)

    def inverse_dynamics(self, q, dq, ddq) -> np.ndarray:
        return inverse_dynamics(self.model, self.ws, q, dq, ddq)

    def forward_dynamics(self, q, dq, tau) -> np.ndarray:
        return forward_dynamics(self.model, self.ws, q, dq, tau)

    def energy(self, q, dq) -> Tuple[float, float]:
        """(kinetic, potential) energy; potential includes gravity and springs."""
        return energy(self.model, self.ws, q, dq)

    # ------------------------------------------------------------------ kinematics
    def frames(self, q) -> Dict[str, Dict[str, np.ndarray]]:
        """World 4x4 transforms of each body's joint frame (before motion) and body frame."""
        return frames(self.model, self.ws, q)

    def point_function(self, body: Optional[str], local):
        """Compiled (position(q), jacobian(q)) of a point fixed in a body."""
        fp, fj = self.model.point(body, local)
        return (lambda q: np.asarray(fp(self._qv(q), self.p), dtype=float).reshape(3),
                lambda q: np.asarray(fj(self._qv(q), self.p), dtype=float).reshape(3, self.n))

    def named_point(self, name: str):
        pt = self.robot.points[name]
        return self.point_function(pt.body, pt.position)
