"""What every controller of app/core/control.py shares: the ``Controller`` base class (gains by
name, set-up for a robot, reference coordinates, the step interface), its documented gains
(``Gain``), what it may know of the robot (``ControlSetup``), its errors (``GainError``,
``ControlStop``) and the text form of gains on the command line and the page (``parse_gains``).

Gains are given by name, case-insensitively: ``Kp=100`` sets every entry, ``Kp2=50`` only the
second one (entries follow the reference coordinates, or the coefficients for Gamma).

>>> parse_gains("Kp=100, Kp2=2*pi")["Kp"]      # exact: parsed from text
100.0
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Dict, List, Mapping, Optional, Tuple

import numpy as np

from .errors import UserError
from .expressions import ExpressionError, parse_number


class GainError(UserError):
    """Unknown or unacceptable gain, or a controller that does not fit the robot."""


class ControlStop(Exception):
    """Raised by a controller inside a run to stop it with a message (e.g. a singular matrix)."""


@dataclass(frozen=True)
class Gain:
    """A gain: ``size`` is 'ref' (one per reference coordinate), 'one' (a scalar) or 'param' (one
    per estimated coefficient); ``positive``: must be > 0 (else >= 0); ``per_inertia``: the default
    is multiplied by the diagonal entry M_ii(q0) of the controller's model, so that default
    torque-level gains fit robots of any size (default * M_ii = w^2 M_ii for Kp = w^2)."""
    name: str
    default: float
    doc: str
    unit: str = ""
    size: str = "ref"
    positive: bool = True
    per_inertia: bool = False


@dataclass
class ControlSetup:
    """What a controller may know: the robot, its own model (``model``: numeric.ModelTerms at the
    controller's parameter values), the control period, which joints are actuated, the initial
    state, task points (``make_point(name)`` -> numeric.TaskPoint), the surfaces in the scene
    ((name, kind, normal, offset) tuples, kind 'rigid' or 'wall') and a force sensor
    (``read_force(point_name)`` -> force on the robot at that point, or None)."""
    robot: object
    model: object
    period: float
    actuated: np.ndarray
    q0: np.ndarray
    dq0: np.ndarray
    make_point: Callable = None
    task_point: Optional[object] = None
    surfaces: List[tuple] = field(default_factory=list)
    read_force: Callable = None


# ====================================================================== base class
class Controller:
    """Base class; subclasses set the class attributes and implement ``step``."""
    name = ""
    title = ""
    law_latex = ""
    closed_loop = ""
    gain_specs: Tuple[Gain, ...] = ()
    needs_full_actuation = False
    #: "joint" (references in coordinates, rad or m) or "task" (a point's position, m)
    space = "joint"

    def __init__(self, gains: Optional[Mapping[str, float]] = None):
        self._requested: Dict[str, float] = {}
        self.internal_names: List[str] = []
        self.gain_arrays: Dict[str, np.ndarray] = {}
        if gains:
            self.set_gains(gains)

    # -------------------------------------------------------------- gains
    def _split(self, key: str) -> Tuple[Gain, Optional[int]]:
        specs = {g.name.lower(): g for g in self.gain_specs}
        low = key.strip().lower()
        if low in specs:
            return specs[low], None
        base = low.rstrip("0123456789")
        if base in specs and base != low:
            return specs[base], int(low[len(base):])
        names = ", ".join(g.name for g in self.gain_specs) or "none"
        raise GainError(f"{self.name}: unknown gain '{key}' (its gains: {names}; add an index for one entry, e.g. Kp2)")

    def set_gains(self, gains: Mapping[str, float]) -> None:
        for key, value in gains.items():
            spec, index = self._split(key)
            try:
                value = float(value)
            except (TypeError, ValueError):
                raise GainError(f"{self.name}: {key} must be a number, got {value!r}") from None
            if not math.isfinite(value):
                raise GainError(f"{self.name}: {key} must be finite")
            if spec.positive and value <= 0:
                raise GainError(f"{self.name}: {key} must be positive (got {value:g})")
            if not spec.positive and value < 0:
                raise GainError(f"{self.name}: {key} must not be negative (got {value:g})")
            if index is not None and index < 1:
                raise GainError(f"{self.name}: gain indices start at 1 ({key})")
            self._requested[key.strip()] = value

    def _gain_size(self, spec: Gain) -> int:
        return {"ref": len(self.reference_names), "one": 1}.get(spec.size, 1)

    def _resolve_gains(self) -> None:
        arrays = {}
        for spec in self.gain_specs:
            size = self._gain_size(spec)
            arr = np.full(size, float(spec.default))
            if spec.per_inertia:
                arr = arr * np.diag(self.model.M(self.s.q0))[self.ref_index]
            for key, value in self._requested.items():
                s, index = self._split(key)
                if s is spec and index is None:
                    arr[:] = value
            for key, value in self._requested.items():
                s, index = self._split(key)
                if s is spec and index is not None:
                    if index > size:
                        raise GainError(f"{self.name}: {key}: {spec.name} has {size} entries")
                    arr[index - 1] = value
            arrays[spec.name] = arr
        self.gain_arrays = arrays
        for spec in self.gain_specs:      # scalars as floats, the others as arrays
            arr = arrays[spec.name]
            setattr(self, spec.name, float(arr[0]) if spec.size == "one" else arr)

    # -------------------------------------------------------------- life cycle
    def setup(self, s: ControlSetup) -> None:
        """Bind to a robot and a model; decide the reference coordinates; resolve the gains."""
        self.s = s
        self.robot = s.robot
        self.model = s.model
        self.n = s.robot.n
        self.dt = s.period
        if self.needs_full_actuation and not np.all(s.actuated):
            passive = [c for c, a in zip(s.robot.coordinates, s.actuated) if not a]
            raise GainError(f"{self.name} needs every coordinate actuated; {', '.join(passive)} "
                            f"{'is' if len(passive) == 1 else 'are'} passive (try partial feedback linearization, "
                            "or declare no joint passive)")
        self.reference_names, self.reference_start = self.reference_coordinates(s)
        self.prepare(s)
        self._resolve_gains()

    def reference_coordinates(self, s: ControlSetup) -> Tuple[List[str], np.ndarray]:
        """Names and initial values of the coordinates the reference is given in (default: q)."""
        self.ref_index = np.arange(self.n)
        return list(s.robot.coordinates), s.q0.copy()

    def prepare(self, s: ControlSetup) -> None:
        """Gain-independent preparation (compiled functions, checks)."""

    def begin(self, reference) -> None:
        """Called once with the reference (a trajectories.Reference) before the first step."""
        self.reference = reference

    def step(self, k: int, t: float, q, dq, qd, dqd, ddqd) -> np.ndarray:
        raise NotImplementedError

    def internals(self) -> np.ndarray:
        """Current values of ``internal_names`` (after a step)."""
        return np.zeros(0)

    def measure(self, Q: np.ndarray, DQ: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
        """The referenced quantity and its rate over recorded samples (default: joint values)."""
        return Q[:, self.ref_index].copy(), DQ[:, self.ref_index].copy()

    def describe_gains(self) -> str:
        return "\n".join(f"  {g.name:7s} {g.doc} [{g.unit or '-'}], default {g.default:g}"
                         + (" M_ii(q0)" if g.per_inertia else "") for g in self.gain_specs)


def parse_gains(text: Optional[str]) -> Dict[str, float]:
    """``"Kp=100,Kd=20,Kp2=50"`` -> {'Kp': 100.0, 'Kd': 20.0, 'Kp2': 50.0}; values may use pi.

    >>> parse_gains("Kp=100, Kd=2*10")        # exact: integers
    {'Kp': 100.0, 'Kd': 20.0}
    """
    out: Dict[str, float] = {}
    for item in (text or "").split(","):
        item = item.strip()
        if not item:
            continue
        if "=" not in item:
            raise GainError(f"gains: expected name=value, got '{item}'")
        key, raw = (x.strip() for x in item.split("=", 1))
        if not key.replace("_", "").isalnum():
            raise GainError(f"gains: '{key}' is not a gain name")
        try:
            out[key] = parse_number(raw)
        except (ExpressionError, TypeError) as exc:
            raise GainError(f"gains: {key}={raw}: {exc}") from None
    return out


#: the proportional and derivative gains on the acceleration, shared by several controllers
KP = Gain("Kp", 100.0, "proportional gain K_P on the acceleration (diagonal)", "1/s^2")
KD = Gain("Kd", 20.0, "derivative gain K_D on the acceleration (diagonal)", "1/s")
