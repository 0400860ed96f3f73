"""What a throw is: its parameters (``ThrowSpec``, the thesis's Tables 5.1-5.3), a batch of them as
arrays (``SpecBatch``), the throw files of app/throws/ (``ThrowConfig``) and the engine's error.

>>> thesis_throw("throw1").degree
(6, 6)
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Callable, Dict, List, Optional, Sequence, Tuple

import numpy as np

from ..errors import UserError
from ..expressions import excerpt, parse_number
from ..files import load_yaml, read_user_file
from ..robot_model import refuse_negative
from .bezier import elevate_bezier

Progress = Optional[Callable[[float, str], None]]

ROBOT_NAME = "throwing_arm"
#: parameters the VHC engine reads by name (besides the mass model, which comes from the robot file)
REQUIRED_PARAMETERS = ("l1", "l2", "l3", "l0", "platform", "g", "k")
#: lower bound of q1 used by the thesis's optimization problem (eq. 4.5), stricter than Table A.2
Q1_MIN_EQ_4_5 = math.pi / 6


class VHCError(UserError):
    """A throw that cannot be carried out: unreachable constraint, singular or stalling dynamics."""


# ====================================================================== throw parameters
@dataclass(frozen=True)
class ThrowSpec:
    """The parameters of one throw (the thesis's Tables 5.1-5.3).

    theta_b, theta_e [m]: start and release values of theta; psi [rad]: the rotation of the theta
    axis (the thesis's "release angle"); k [N m/rad]: wrist spring; a, b: Bezier control points of
    q1 and q2 [rad]; theta_dot_b [m/s]: initial speed; branch: +1 for the printed arccos branch of
    eq. (3.14), -1 for the other one.

    >>> ThrowSpec(-0.3, 0.3, 0.3, 20.0, (1.7, 1.3), (0.6, 0.3)).degree
    (1, 1)
    """
    theta_b: float
    theta_e: float
    psi: float
    k: float
    a: Tuple[float, ...]
    b: Tuple[float, ...]
    theta_dot_b: float = 0.0
    branch: int = 1

    def __post_init__(self):
        object.__setattr__(self, "a", tuple(float(v) for v in self.a))
        object.__setattr__(self, "b", tuple(float(v) for v in self.b))
        for name in ("theta_b", "theta_e", "psi", "k", "theta_dot_b"):
            value = getattr(self, name)
            if not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value):
                raise UserError(f"{name}: expected a finite number, got {value!r}")
            object.__setattr__(self, name, float(value))
        if len(self.a) < 2 or len(self.b) < 2:
            raise UserError("a and b need at least two Bezier control points each")
        if not all(math.isfinite(v) for v in self.a + self.b):
            raise UserError("Bezier control points must be finite numbers")
        if not self.theta_e > self.theta_b:
            raise UserError(f"theta_e ({self.theta_e:g} m) must be greater than theta_b ({self.theta_b:g} m)")
        problem = (refuse_negative("k: the wrist spring", self.k)
                   or refuse_negative("theta_dot_b: the initial speed", self.theta_dot_b))
        if problem:
            raise UserError(problem)
        if self.branch not in (1, -1):
            raise UserError(f"branch: expected +1 or -1, got {self.branch!r}")

    @property
    def degree(self) -> Tuple[int, int]:
        return len(self.a) - 1, len(self.b) - 1

    @property
    def psi_deg(self) -> float:
        return math.degrees(self.psi)

    def to_config(self) -> dict:
        """The throw as a CLI config mapping (psi in degrees).

        >>> thesis_throw("throw2").to_config()["psi_deg"]      # exact: as read from the file
        37.099
        """
        out = {"theta_b": self.theta_b, "theta_e": self.theta_e, "psi_deg": round(self.psi_deg, 12),
               "k": self.k, "a": list(self.a), "b": list(self.b), "theta_dot_b": self.theta_dot_b}
        if self.branch != 1:
            out["branch"] = self.branch
        return out

    def elevated(self, degree: int) -> "ThrowSpec":
        """The same curves written with ``degree`` + 1 control points each (exact degree elevation)."""
        return replace(self, a=tuple(elevate_bezier(self.a, degree)), b=tuple(elevate_bezier(self.b, degree)))



def thesis_throw(name: str) -> ThrowSpec:
    """One of the thesis's three throws as printed (``throw1``..``throw3``, Tables 5.1-5.3), from the
    shipped throw files in app/throws/.

    >>> thesis_throw("throw2").psi_deg          # exact: as read from the file
    37.099
    """
    return load_throw_config(name).spec


@dataclass
class SpecBatch:
    """Throw parameters of a batch as arrays (B, ...) for vectorized evaluation."""
    a: np.ndarray
    b: np.ndarray
    theta_b: np.ndarray
    theta_e: np.ndarray
    psi: np.ndarray
    k: np.ndarray
    theta_dot_b: np.ndarray
    branch: np.ndarray

    @staticmethod
    def of(specs: Sequence[ThrowSpec]) -> "SpecBatch":
        col = lambda name: np.array([[float(getattr(s, name))] for s in specs])
        return SpecBatch(np.array([s.a for s in specs]), np.array([s.b for s in specs]), col("theta_b"),
                      col("theta_e"), col("psi"), col("k"), col("theta_dot_b"), col("branch"))



# ====================================================================== throw configs
THROWS_DIR = Path(__file__).resolve().parents[2] / "throws"
_LINK_FIELDS = ("m", "l", "c", "d", "J")
_GLOBAL_FIELDS = ("g", "l0", "platform")
_CONFIG_KEYS = {"theta_b", "theta_e", "psi_deg", "k", "a", "b", "theta_dot_b", "branch", "model", "title",
                "notes", "thesis"}


@dataclass
class ThrowConfig:
    """A throw file: the throw, model overrides (robot parameter names), and information to show."""
    spec: ThrowSpec
    model: Dict[str, float]
    title: str = ""
    notes: str = ""
    thesis: Dict[str, float] = field(default_factory=dict)   # what the thesis reports for it
    source: str = ""


def _number(value, where: str) -> float:
    if isinstance(value, bool) or value is None:
        raise UserError(f"{where}: expected a number, got {value!r}")
    if isinstance(value, (int, float)):
        out = float(value) if abs(value) <= 1e308 else math.inf
    elif isinstance(value, str):
        try:
            out = parse_number(value)
        except (UserError, TypeError) as exc:
            raise UserError(f"{where}: expected a number: {exc}") from None
    else:
        raise UserError(f"{where}: expected a number, got {excerpt(value)}")
    if not math.isfinite(out):
        raise UserError(f"{where}: expected a finite number, got {excerpt(value)}")
    return out


def model_overrides(block) -> Dict[str, float]:
    """The config's "model" block as robot parameter names.

    Per link i = 1..3: m, l, c (CoM along the link from its joint), d (CoM offset perpendicular to the
    link, counter-clockwise positive), J (inertia about the CoM, axis normal to the plane), given as
    ``link2: {m: 3.9}`` (or ``2: {...}``) or flat as ``m2: 3.9``; and g, l0, platform.

    >>> model_overrides({"link3": {"c": 0.1, "J": 0.01}, "g": 9.8, "m1": 4})     # exact: the values given
    {'c3': 0.1, 'J3': 0.01, 'g': 9.8, 'm1': 4.0}
    """
    if block is None:
        return {}
    if not isinstance(block, dict):
        raise UserError("model: expected a mapping (link1: {m: ..., c: ...}, g: ..., l0: ..., platform: ...)")
    out: Dict[str, float] = {}
    flat = {f"{f}{i}" for f in _LINK_FIELDS for i in (1, 2, 3)} | set(_GLOBAL_FIELDS)
    for key, value in block.items():
        name = str(key)
        link = name[4:] if name.startswith("link") else name
        if link in ("1", "2", "3"):
            if not isinstance(value, dict):
                raise UserError(f"model.{name}: expected a mapping with some of {list(_LINK_FIELDS)}")
            for field_name, v in value.items():
                if field_name not in _LINK_FIELDS:
                    raise UserError(f"model.{name}.{field_name}: unknown field (allowed: {list(_LINK_FIELDS)})")
                out[f"{field_name}{link}"] = _number(v, f"model.{name}.{field_name}")
        elif name in flat:
            out[name] = _number(value, f"model.{name}")
        else:
            raise UserError(f"model.{name}: unknown key (allowed: link1..link3 with {list(_LINK_FIELDS)}, "
                            f"m1..J3, {', '.join(_GLOBAL_FIELDS)})")
    return out


def parse_throw_config(data, source: str = "<config>") -> ThrowConfig:
    """Build a ThrowConfig from a mapping (a parsed YAML/JSON throw file); UserError on bad input."""
    if not isinstance(data, dict):
        raise UserError(f"{source}: expected a mapping with theta_b, theta_e, psi_deg, k, a, b")
    unknown = set(map(str, data)) - _CONFIG_KEYS
    if unknown:
        raise UserError(f"{source}: unknown key(s) {sorted(unknown)} (allowed: {sorted(_CONFIG_KEYS)})")
    missing = [k for k in ("theta_b", "theta_e", "psi_deg", "k", "a", "b") if k not in data]
    if missing:
        raise UserError(f"{source}: missing key(s) {missing}")
    pts = {}
    for key in ("a", "b"):
        v = data[key]
        if not isinstance(v, list) or len(v) < 2:
            raise UserError(f"{source}: {key}: expected a list of at least two Bezier control points [rad]")
        pts[key] = tuple(_number(x, f"{key}[{i}]") for i, x in enumerate(v))
    branch = data.get("branch", 1)
    if branch not in (1, -1):
        raise UserError(f"{source}: branch: expected 1 or -1, got {branch!r}")
    try:
        spec = ThrowSpec(_number(data["theta_b"], "theta_b"), _number(data["theta_e"], "theta_e"),
                         math.radians(_number(data["psi_deg"], "psi_deg")), _number(data["k"], "k"),
                         pts["a"], pts["b"], _number(data.get("theta_dot_b", 0.0), "theta_dot_b"), branch)
    except UserError as exc:
        raise UserError(f"{source}: {exc}") from None
    thesis = data.get("thesis") or {}
    if not isinstance(thesis, dict):
        raise UserError(f"{source}: thesis: expected a mapping of reported values")
    return ThrowConfig(spec, model_overrides(data.get("model")), str(data.get("title", "")),
                       str(data.get("notes", "")), {str(k): _number(v, f"thesis.{k}") for k, v in thesis.items()},
                       source)


def throw_config_path(name_or_path: str) -> Path:
    path = Path(name_or_path)
    if path.suffix in (".yaml", ".yml", ".json") or path.exists():
        if not path.is_file():
            raise UserError(f"{path}: no such throw file")
        return path
    shipped = THROWS_DIR / f"{name_or_path}.yaml"
    if shipped.is_file():
        return shipped
    names = ", ".join(list_throw_names())
    raise UserError(f"unknown throw '{name_or_path}': not a file and not a shipped throw ({names})")


def list_throw_names() -> List[str]:
    return sorted(p.stem for p in THROWS_DIR.glob("*.yaml"))


def load_throw_config(name_or_path: str) -> ThrowConfig:
    """A shipped throw by name (``throw1``) or a YAML/JSON throw file by path."""
    path = throw_config_path(name_or_path)
    data = load_yaml(read_user_file(path), str(path))      # JSON is YAML too
    return parse_throw_config(data, str(path))

