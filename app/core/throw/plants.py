"""Plants of the closed-loop throws: the simulated arm differs from the planner's model (dynamic
parameters, wrist friction, torque saturation, sensor noise, a control period and, for Monte-Carlo,
uncertainty ranges); read from YAML/JSON files (app/throws/plants/, docs/throwing.md). ``PlantBatch``
holds B plants as arrays for the vectorized simulation (``closed_loop.py``).

>>> plant = load_plant("heavier")
>>> f"k x {plant.scale['k']:.2f}, control every {1e3 * plant.control_period:.1f} ms"
'k x 0.90, control every 1.0 ms'
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Dict, List, Mapping, Sequence

import numpy as np
import yaml

from ..errors import UserError
from ..robot_model import refuse_negative

if TYPE_CHECKING:
    from .arm import ThrowingArm

#: parameters a plant may change (the dynamics; the geometry stays the planner's)
PLANT_PARAMETERS = ("m1", "m2", "m3", "c1", "c2", "c3", "d1", "d2", "d3", "J1", "J2", "J3", "k")
#: width of the smooth Coulomb friction law tau = -Fc tanh(q3' / width) [rad/s]
COULOMB_WIDTH = 0.05
PLANTS_DIR = Path(__file__).resolve().parents[2] / "throws" / "plants"


# ====================================================================== plants
@dataclass
class Plant:
    """The simulated arm: relative ``scale`` factors and absolute ``model`` values of the dynamic
    parameters (applied to the throw's model, k to the throw's spring), wrist friction, torque
    saturation, sensor noise, control period and, for Monte-Carlo, uncertainty ranges.

    ``uncertainty`` maps a parameter to a relative half-width r (each draw multiplies it by a factor
    uniform in [1 - r, 1 + r]); ``viscous`` and ``coulomb`` map to absolute ranges [lo, hi].

    >>> f'{Plant(scale={"m1": 1.1}).values({"m1": 2.0, "k": 20.0}, 20.0)["m1"]:.3f}'
    '2.200'
    """
    title: str = "exact plant (the planner's model)"
    scale: Dict[str, float] = field(default_factory=dict)
    model: Dict[str, float] = field(default_factory=dict)
    viscous: float = 0.0          # wrist viscous friction [N m s/rad]
    coulomb: float = 0.0          # wrist Coulomb friction [N m]
    saturate: bool = True         # clip the torques at the Table A.2 limits
    noise_q: float = 0.0          # standard deviation of the measured joint angles [rad]
    noise_dq: float = 0.0         # standard deviation of the measured joint speeds [rad/s]
    control_period: float = 0.0   # [s]; 0: continuous control
    uncertainty: Dict[str, object] = field(default_factory=dict)

    def __post_init__(self):
        for block in (self.scale, self.model):
            for name, value in block.items():
                if name not in PLANT_PARAMETERS:
                    raise UserError(f"plant: unknown parameter '{name}' (a plant may change "
                                    f"{', '.join(PLANT_PARAMETERS)})")
                if not math.isfinite(value):
                    raise UserError(f"plant: {name} must be a finite number")
        for name, value in self.scale.items():
            if value <= 0:
                raise UserError(f"plant: the scale factor of {name} must be positive (got {value:g})")
        for name in ("viscous", "coulomb", "noise_q", "noise_dq", "control_period"):
            value = getattr(self, name)
            if not math.isfinite(value) or value < 0:
                raise UserError(f"plant: {name} must be a non-negative number (got {value!r})")
        if self.control_period > 0.05:
            raise UserError("plant: the control period must be at most 0.05 s")
        if (self.noise_q > 0 or self.noise_dq > 0) and self.control_period == 0:
            raise UserError("plant: sensor noise needs a control period > 0 (the noise is drawn per sample)")
        for name, spread in self.uncertainty.items():
            if name in ("viscous", "coulomb"):
                lo, hi = _pair(spread, f"uncertainty of {name}")
                if lo < 0 or hi < lo:
                    raise UserError(f"plant: the {name} range must satisfy 0 <= lo <= hi (got {lo:g}, {hi:g})")
            elif name in PLANT_PARAMETERS:
                r = _number(spread, f"uncertainty of {name}")
                if not 0 <= r < 1:
                    raise UserError(f"plant: the relative uncertainty of {name} must be in [0, 1) (got {r:g})")
            else:
                raise UserError(f"plant: unknown uncertain quantity '{name}' (parameters "
                                f"{', '.join(PLANT_PARAMETERS)}, viscous, coulomb)")

    def values(self, nominal: Mapping[str, float], k: float) -> Dict[str, float]:
        """The plant's parameter values from the planner's ``nominal`` ones and the throw's spring ``k``."""
        out = {**dict(nominal), "k": k}
        for name, value in self.model.items():
            out[name] = float(value)
        for name, factor in self.scale.items():
            out[name] = out[name] * float(factor)
        for name in ("m1", "m2", "m3", "J1", "J2", "J3"):
            if out.get(name, 1.0) <= 0:
                raise UserError(f"plant: {name} must be positive (got {out[name]:g})")
        problem = refuse_negative("plant: the spring k", out["k"])
        if problem:
            raise UserError(problem)
        return out

    def to_config(self) -> dict:
        return {"title": self.title, "scale": dict(self.scale), "model": dict(self.model),
                "wrist_friction": {"viscous": self.viscous, "coulomb": self.coulomb},
                "torque_saturation": self.saturate, "sensor_noise": {"q": self.noise_q, "dq": self.noise_dq},
                "control_period": self.control_period, "uncertainty": dict(self.uncertainty)}


def _number(value, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise UserError(f"plant: {where} must be a finite number (got {value!r})")
    return float(value)


def _pair(value, where: str):
    if not isinstance(value, (list, tuple)) or len(value) != 2:
        raise UserError(f"plant: {where} must be a range [lo, hi] (got {value!r})")
    return _number(value[0], where), _number(value[1], where)


_PLANT_KEYS = {"title", "scale", "model", "wrist_friction", "torque_saturation", "sensor_noise", "control_period",
               "uncertainty"}


def parse_plant(data, source: str = "<plant>") -> Plant:
    """A plant from a mapping (the file format of docs/throwing.md)."""
    if not isinstance(data, dict):
        raise UserError(f"{source}: a plant file must be a mapping")
    unknown = set(data) - _PLANT_KEYS
    if unknown:
        raise UserError(f"{source}: unknown keys {sorted(unknown)} (allowed: {sorted(_PLANT_KEYS)})")

    def block(name):
        value = data.get(name) or {}
        if not isinstance(value, dict):
            raise UserError(f"{source}: '{name}' must be a mapping")
        return value

    fr, noise = block("wrist_friction"), block("sensor_noise")
    for name, allowed in (("wrist_friction", {"viscous", "coulomb"}), ("sensor_noise", {"q", "dq"})):
        extra = set(block(name)) - allowed
        if extra:
            raise UserError(f"{source}: unknown keys {sorted(extra)} in '{name}' (allowed: {sorted(allowed)})")
    sat = data.get("torque_saturation", True)
    if not isinstance(sat, bool):
        raise UserError(f"{source}: torque_saturation must be true or false")
    try:
        return Plant(title=str(data.get("title", Path(source).stem)),
                     scale={k: _number(v, f"scale of {k}") for k, v in block("scale").items()},
                     model={k: _number(v, f"value of {k}") for k, v in block("model").items()},
                     viscous=_number(fr.get("viscous", 0.0), "wrist_friction.viscous"),
                     coulomb=_number(fr.get("coulomb", 0.0), "wrist_friction.coulomb"),
                     saturate=sat,
                     noise_q=_number(noise.get("q", 0.0), "sensor_noise.q"),
                     noise_dq=_number(noise.get("dq", 0.0), "sensor_noise.dq"),
                     control_period=_number(data.get("control_period", 0.0), "control_period"),
                     uncertainty=dict(block("uncertainty")))
    except UserError as exc:
        raise UserError(f"{source}: {exc}") from None


def list_plant_names() -> List[str]:
    return sorted(p.stem for p in PLANTS_DIR.glob("*.yaml"))


def load_plant(name_or_path: str) -> Plant:
    """A plant file (YAML or JSON) or a shipped plant by name (``list_plant_names()``)."""
    path = Path(name_or_path)
    if not path.exists():
        shipped = PLANTS_DIR / f"{name_or_path}.yaml"
        if not shipped.exists():
            raise UserError(f"no plant file '{name_or_path}' (shipped plants: {', '.join(list_plant_names())})")
        path = shipped
    try:
        data = yaml.safe_load(path.read_text(encoding="utf-8"))
    except (yaml.YAMLError, UnicodeDecodeError) as exc:
        raise UserError(f"{path}: not valid YAML/JSON: {exc}") from None
    return parse_plant(data, str(path))


# ====================================================================== a batch of plants
@dataclass
class PlantBatch:
    """B plants as arrays: parameter vectors (P, B) in the robot's parameter order, wrist friction (B,)."""
    params: np.ndarray
    viscous: np.ndarray
    coulomb: np.ndarray

    @property
    def size(self) -> int:
        return self.params.shape[1]

    def take(self, idx) -> "PlantBatch":
        return PlantBatch(self.params[:, idx], self.viscous[idx], self.coulomb[idx])


def plant_batch(arm: ThrowingArm, k: float, values: Sequence[Mapping[str, float]], viscous, coulomb) -> PlantBatch:
    names = arm.parameter_names
    params = np.array([[float(v[n]) for v in values] for n in names])
    return PlantBatch(params, np.asarray(viscous, dtype=float), np.asarray(coulomb, dtype=float))


