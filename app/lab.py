"""Robotics II Lab from Python (notebooks, scripts): the objects the page and the command line use.

A thin layer over the computing core (app/core): each function loads or builds one of the core's
objects and returns it as it is, so a notebook sees exactly what the page shows. docs/api.md is the
guide; docs/examples/ has a notebook.

>>> from app import lab
>>> arm = lab.robot("planar_2r")
>>> lab.model(arm).M[1, 1]
I2 + d2**2*m2
>>> f"{lab.numeric(arm).M([0.0, 0.0])[1, 1]:.4f}"          # at the file's parameter values
'1.3100'
"""
from __future__ import annotations

from typing import List, Mapping, Optional, Union

from app.core.control import CONTROLLERS
from app.core.dynamics import Dynamics, derive
from app.core.exercise import Exercise, Solution, list_exercises, load_exercise
from app.core.exercise import solve as _solve
from app.core.numeric import CrossCheck, NumericModel, PinocchioTwin, cross_check
from app.core.robot import RobotModel, list_robot_names, load_robot
from app.core.sim import SimResult
from app.core.sim import simulate as _simulate
from app.core.tex import model_tex, solution_tex
from app.core.urdf import to_urdf
from app.core.throw.arm import ThrowingArm
from app.core.throw.config import load_throw_config
from app.core.throw.optimize import DEFAULT_EVALUATIONS, OptimizationResult, ThrowOptimizer
from app.core.throw.reduced import Throw

__all__ = ["robots", "robot", "model", "numeric", "twin", "check", "controllers", "simulate", "throw",
           "optimize_throw", "exercises", "exercise", "solve", "urdf", "latex"]

RobotLike = Union[RobotModel, str]


def _robot(robot_or_name: RobotLike) -> RobotModel:
    return robot_or_name if isinstance(robot_or_name, RobotModel) else load_robot(robot_or_name)


# ---------------------------------------------------------------------- robots and their models
def robots() -> List[str]:
    """The names of the shipped robots (app/robots/*.yaml).

    >>> "planar_2r" in robots() and "throwing_arm" in robots()
    True
    """
    return list_robot_names()


def robot(name_or_path: str) -> RobotModel:
    """A shipped robot by name, or a robot file (YAML, docs/robot-format.md) or URDF file by path.

    >>> arm = robot("planar_2r")
    >>> arm.coordinates, arm.parameters["l1"].value, arm.parameters["l1"].unit   # exact: read from the file
    (('q1', 'q2'), 1.0, 'm')
    """
    return load_robot(name_or_path)


def model(robot: RobotLike, known: Optional[List[str]] = None) -> Dynamics:
    """The symbolic model (sympy, exact, in the compact forms the page shows): ``M``, ``C``, ``c``,
    ``g``, ``spring``, ``friction``, ``christoffel``, the linear parametrization
    ``parametrization.Y``, ``.a`` (``known``: parameters taken as known; default lengths, gravity
    and angles) and the derivation ``steps``. Cached on disk like the page's.

    >>> dyn = model("planar_2r")
    >>> dyn.g[1], dyn.parametrization.count
    (d2*g0*m2*cos(q1 + q2), 4)
    >>> dyn.steps[0].title
    'Generalized coordinates'
    """
    return derive(_robot(robot), known=known)


def numeric(robot: RobotLike, params: Optional[Mapping[str, float]] = None) -> NumericModel:
    """The compiled numeric model at parameter values (the file's defaults, changed by ``params``):
    ``M(q)``, ``C(q, dq)``, ``c``, ``g(q)``, ``inverse_dynamics(q, dq, ddq)``,
    ``forward_dynamics(q, dq, tau)``, ``energy(q, dq)`` (kinetic, potential) ... in SI units.
    A bad value (a negative mass) is refused with a ``ParameterError``.

    >>> num = numeric("planar_2r", {"m2": 2.0})
    >>> tau = num.inverse_dynamics([0.3, -0.2], [0.0, 0.0], [0.0, 0.0])      # gravity alone [N m]
    >>> [f"{t:.4f}" for t in tau], bool(abs(tau - num.g([0.3, -0.2])).max() < 1e-12)
    (['73.4117', '7.8088'], True)
    """
    return NumericModel(_robot(robot), params)


def twin(robot: RobotLike, params: Optional[Mapping[str, float]] = None) -> PinocchioTwin:
    """The robot built in pinocchio with the same numbers; ``terms(q, dq)`` gives its M, c and g
    in the robot's coordinates (``twin.model`` and ``twin.data`` are pinocchio's own).

    >>> import numpy as np
    >>> M, c, g = twin("planar_2r").terms([0.3, -0.2], [1.0, 0.5])
    >>> bool(np.allclose(M, numeric("planar_2r").M([0.3, -0.2]), atol=1e-12))
    True
    """
    return PinocchioTwin(_robot(robot), numeric(robot, params).values)


def check(robot: RobotLike, params: Optional[Mapping[str, float]] = None, states: int = 50,
          seed: int = 0) -> CrossCheck:
    """The symbolic model against pinocchio at ``states`` random states (``python -m app check``).

    >>> result = check("planar_2r", states=20)
    >>> result.ok, sorted(result.max_rel_error)
    (True, ['Cdq', 'M', 'g'])
    """
    return cross_check(_robot(robot), params, states=states, seed=seed)


# ---------------------------------------------------------------------- control
def controllers() -> List[str]:
    """The controllers ``simulate`` knows (docs/controllers.md has their laws and gains).

    >>> "computed_torque" in controllers() and "pd_gravity" in controllers()
    True
    """
    return sorted(CONTROLLERS)


def simulate(robot: RobotLike, controller: str, **options) -> SimResult:
    """A closed-loop run, as the Control tab and ``python -m app simulate`` make it: ``controller``
    by name, ``gains`` by name, a ``reference`` text (docs/controllers.md), ``q0``, ``duration``
    [s], ``rate`` [Hz], model mismatch (``plant_params``), contacts ... (app/core/sim.py
    ``simulate``). The result has arrays ``t``, ``q``, ``dq``, ``tau``, ``e`` and ``to_csv()``.

    >>> run = simulate("planar_2r", "computed_torque", gains={"Kp": 100, "Kd": 20},
    ...                reference="setpoint goal=0.5,-0.3", q0=[0.0, 0.0], duration=1.0)
    >>> run.completed, bool(abs(run.e[-1]).max() < 1e-3)          # the error at t = 1 s [rad]
    (True, True)
    """
    return _simulate(_robot(robot), controller, **options)


# ---------------------------------------------------------------------- throws
def throw(config: str = "throw1", params: Optional[Mapping[str, float]] = None,
          robot: RobotLike = "throwing_arm") -> Throw:
    """A VHC throw of the throwing arm (docs/throwing.md), planned and evaluated as the Throw tab
    does: ``config`` a shipped throw (throw1, throw2, throw3) or a throw file; the result has the
    time law (``duration``, ``theta_at(t)``), the joint motion and torques (``sample()``), the
    ``release`` (point, velocity, distances) and ``check()``, the limits of the robot file.

    >>> t = throw("throw1")     # the thesis's first throw (Table 5.1; the thesis reports 2.95 m with its model)
    >>> f"{t.theta_dot_e:.4f} m/s", f"{t.duration:.4f} s", f"{t.release.distance_from_base_thesis:.3f} m"
    ('3.7762 m/s', '0.2863 s', '2.797 m')
    >>> t.check().feasible                       # it exceeds a limit of the robot file
    False
    """
    cfg = load_throw_config(config)
    arm = ThrowingArm(_robot(robot), {**cfg.model, **(params or {})})
    return arm.solve(cfg.spec)


def optimize_throw(seed: int = 0, evaluations: int = DEFAULT_EVALUATIONS, objective: str = "thesis",
                   degree: int = 6, params: Optional[Mapping[str, float]] = None, **options) -> OptimizationResult:
    """The longest throw under every limit (``python -m app throw --optimize``). The budget is
    counted in throw ``evaluations`` (the same seed gives the same throw on any machine);
    ``objective`` is "thesis" or "physical"; ``options`` are those of ``ThrowOptimizer.run``
    (``candidates``, ``starts`` size the global stage; ``max_seconds`` an optional time cap). The
    result has the ``throw``, its ``feasibility`` and ``distance_from_base`` [m].

    >>> best = optimize_throw(seed=0, evaluations=300, candidates=200, starts=1)     # a small search
    >>> best.feasibility.feasible, best.evaluations <= 300, f"{best.distance_from_base:.2f} m"
    (True, True, '2.43 m')
    >>> optimize_throw(objective="farthest")
    Traceback (most recent call last):
    ...
    app.core.errors.UserError: objective must be 'thesis' or 'physical', got 'farthest'
    """
    arm = ThrowingArm(params=params)
    return ThrowOptimizer(arm, degree=degree, objective=objective).run(seed=seed, evaluations=evaluations, **options)


# ---------------------------------------------------------------------- exercises
def exercises() -> List[str]:
    """The ids of the shipped exam exercises (``python -m app exercises``).

    >>> "2004-03-25#1" in exercises()
    True
    """
    return [ex.id for ex in list_exercises()]


def exercise(id_or_path: str) -> Exercise:
    """An exercise by id or exercise file (docs/exercise-format.md): ``question``, ``given``,
    ``robot``, ``tasks``.

    >>> exercise("2004-03-25#1").robot
    'rp_2004_03_25'
    """
    return load_exercise(id_or_path)


def solve(exercise: Union[Exercise, str], given: Optional[Mapping[str, float]] = None) -> Solution:
    """An exercise solved step by step, as the Exercises tab shows it: ``steps`` (title, text,
    LaTeX), named ``answers``, ``notes`` on the printed solution, ``markdown()``; ``given``
    changes given numbers (a variant).

    >>> sol = solve("2004-03-25#1")
    >>> sol.answers["regressor_count"], len(sol.steps) > 10
    (3, True)
    """
    return _solve(exercise if isinstance(exercise, Exercise) else load_exercise(exercise), given)


# ---------------------------------------------------------------------- other formats
def urdf(robot: RobotLike, values: Optional[Mapping[str, float]] = None) -> str:
    """The robot as URDF text at parameter values (``python -m app export ROBOT --urdf``); a robot
    URDF cannot express (springs, elastic joints, a map of coordinates) raises ``UrdfError``.

    >>> text = urdf("planar_2r")
    >>> text.count('type="revolute"') + text.count('type="continuous"')
    2
    """
    return to_urdf(_robot(robot), values)


def latex(item: Union[RobotModel, Solution, str]) -> str:
    """A LaTeX fragment (amsmath) of a robot's model or of a solution (``derive --latex``,
    ``solve --latex``); a string is a robot's name or file.

    >>> r"m_{22} = I_{2} + d_{2}^{2} m_{2}" in latex("planar_2r")
    True
    """
    if isinstance(item, Solution):
        return solution_tex(item)
    robot_model = _robot(item)
    return model_tex(robot_model, derive(robot_model))
