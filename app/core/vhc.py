"""Throws of the three-link arm with a passive spring wrist, planned with virtual holonomic
constraints (VHC), after Lillehammer (NTNU 2014), chapters 3-4.

The ball's position along an axis through the shoulder, rotated by the release angle psi, is the
path coordinate (eq. 3.12)::

    theta = l1 cos(q1 - psi) + l2 cos(q1 + q2 - psi) + l3 cos(q1 + q2 + q3 - psi)

The actuated joints follow Bezier polynomials q1 = phi1(theta), q2 = phi2(theta) of any degree in
s = (theta - theta_b) / (theta_e - theta_b) (eqs. 4.1, 4.2); the wrist angle follows from (3.12)
(eq. 3.14, printed "+" branch by default). On the constraint the passive row of M q'' + C q' + g +
k q3 = [tau1, tau2, 0] becomes alpha theta'' + beta theta'^2 + gamma = 0 (eqs. 3.15-3.20), whose
integral (3.24) gives theta'^2(theta) in closed form.

Numerics: every integral is a piecewise Chebyshev (Clenshaw-Curtis) quadrature in sigma with
theta = theta_b + (theta_e - theta_b) sigma^2. The substitution removes the 1/sqrt singularity of
dt = dtheta / theta' at a start from rest, and the pieces are bisected until the Chebyshev
coefficients of every integrand have decayed (near-singular wrists, small alpha). Everything is
vectorized over nodes and over batches of throws (the optimizer's finite differences are one call).

>>> arm = ThrowingArm()
>>> throw = arm.solve(thesis_throw("throw1"))
>>> round(throw.theta_dot_e, 4), round(throw.duration, 4)     # reference model B
(3.7762, 0.2863)
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from functools import lru_cache
from math import comb
from pathlib import Path
from typing import Callable, Dict, List, Mapping, Optional, Sequence, Tuple

import numpy as np
import sympy as sp
from numpy.polynomial import chebyshev as npcheb

from .ballistics import landing_distance
from .dynamics import derive
from .errors import UserError
from .numeric import compiled_function
from .expressions import excerpt, parse_expression
from .files import load_yaml, read_user_file
from .numeric import NumericModel
from .robot import RobotModel, load_robot

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
        if self.k < 0:
            raise UserError(f"k: the wrist spring must not be negative (got {self.k:g})")
        if self.theta_dot_b < 0:
            raise UserError(f"theta_dot_b: the initial speed must not be negative (got {self.theta_dot_b:g})")
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


def elevate_bezier(points: Sequence[float], degree: int) -> List[float]:
    """Control points of the same Bezier polynomial written with a higher degree.

    >>> [round(v, 12) + 0.0 for v in elevate_bezier([0.0, 1.0], 2)]
    [0.0, 0.5, 1.0]
    """
    c = [float(v) for v in points]
    if degree < len(c) - 1:
        raise UserError(f"cannot lower the degree of a Bezier curve from {len(c) - 1} to {degree}")
    while len(c) - 1 < degree:
        n = len(c) - 1
        c = [c[0]] + [(i / (n + 1)) * c[i - 1] + (1 - i / (n + 1)) * c[i] for i in range(1, n + 1)] + [c[-1]]
    return c


def thesis_throw(name: str) -> ThrowSpec:
    """One of the thesis's three throws as printed (``throw1``..``throw3``, Tables 5.1-5.3), from the
    shipped throw files in app/throws/.

    >>> thesis_throw("throw2").psi_deg          # exact: as read from the file
    37.099
    """
    return load_throw_config(name).spec


# ====================================================================== throw configs
THROWS_DIR = Path(__file__).resolve().parent.parent / "throws"
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
            out = float(parse_expression(value, allowed_names=()))
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


# ====================================================================== Bezier and Chebyshev tools
def bernstein(degree: int, s: np.ndarray, derivative: int = 0) -> np.ndarray:
    """Matrix (len(s), degree + 1) mapping control points to the ``derivative``-th s-derivative.

    >>> (bernstein(2, np.array([0.5])) @ np.array([0.0, 1.0, 0.0])).round(12).tolist()
    [0.5]
    """
    s = np.asarray(s, dtype=float)
    n = degree - derivative
    if n < 0:
        return np.zeros((s.size, degree + 1))
    basis = np.stack([comb(n, k) * s ** k * (1 - s) ** (n - k) for k in range(n + 1)], axis=-1)
    diff = np.eye(degree + 1)
    for d in range(derivative):   # forward differences, scaled: n!/(n-r)! Delta^r c
        m = degree - d
        diff = m * (diff[1:] - diff[:-1])
    return basis @ diff


@lru_cache(maxsize=None)
def _cheb_tables(P: int):
    """Chebyshev-Lobatto nodes on [-1, 1], values->coefficients matrix, cumulative integration matrix."""
    x = -np.cos(np.pi * np.arange(P) / (P - 1))
    V = npcheb.chebvander(x, P - 1)
    Vinv = np.linalg.inv(V)
    W = np.empty((P, P))
    for m in range(P):
        e = np.zeros(P)
        e[m] = 1.0
        W[:, m] = npcheb.chebval(x, npcheb.chebint(e, lbnd=-1))
    S = W @ Vinv
    S[0] = 0.0              # the integral from -1 to the first node (-1 itself) is 0, not a rounding of it
    return x, Vinv, S


class ChebPieces:
    """Piecewise Chebyshev-Lobatto representation of functions on [breaks[0], breaks[-1]].

    >>> mesh = ChebPieces(np.linspace(0.0, 1.0, 3), 8)
    >>> f = np.cos(mesh.nodes)
    >>> bool(abs(mesh.cumulative(f)[-1, -1] - np.sin(1.0)) < 1e-12)
    True
    """

    def __init__(self, breaks, P: int = 16):
        self.breaks = np.asarray(breaks, dtype=float)
        self.P = P
        x, self._Vinv, self._S = _cheb_tables(P)
        self.h = np.diff(self.breaks)
        self.nodes = self.breaks[:-1, None] + 0.5 * (x[None, :] + 1.0) * self.h[:, None]   # (K, P)

    @property
    def pieces(self) -> int:
        return self.h.size

    def cumulative(self, f: np.ndarray) -> np.ndarray:
        """Integral from breaks[0] to every node of f given at the nodes (shape (..., K, P))."""
        local = np.einsum("ij,...kj->...ki", self._S, f) * (0.5 * self.h)[:, None]
        totals = local[..., -1]
        offsets = np.cumsum(totals, axis=-1) - totals
        return local + offsets[..., None]

    def tails(self, f: np.ndarray) -> np.ndarray:
        """Size of the last two Chebyshev coefficients per piece times half its length (error scale)."""
        coef = np.einsum("ij,...kj->...ki", self._Vinv, f)
        return (np.abs(coef[..., -1]) + np.abs(coef[..., -2])) * 0.5 * self.h

    def split(self, mask: np.ndarray) -> "ChebPieces":
        mids = 0.5 * (self.breaks[:-1] + self.breaks[1:])[mask]
        return ChebPieces(np.sort(np.concatenate([self.breaks, mids])), self.P)

    def interpolate(self, values: np.ndarray, where) -> np.ndarray:
        """Values (K, P) at the nodes -> values of the piecewise interpolant at points ``where``."""
        where = np.asarray(where, dtype=float)
        k = np.clip(np.searchsorted(self.breaks, where, side="right") - 1, 0, self.pieces - 1)
        x = 2.0 * (where - self.breaks[k]) / self.h[k] - 1.0
        coef = values @ self._Vinv.T                      # (K, P)
        return npcheb.chebval(x, coef[k].T, tensor=False)


# ====================================================================== the arm
@dataclass
class ConstraintState:
    """The constrained configuration along theta (arrays of shape (B, N); q-like ones (3, B, N))."""
    theta: np.ndarray
    q: np.ndarray          # Phi(theta)
    dq: np.ndarray         # Phi'(theta)   (joint speed = Phi' theta_dot)
    ddq: np.ndarray        # Phi''(theta)
    u: np.ndarray          # arccos argument of eq. (3.14) (reachable where |u| <= 1)
    alpha: Optional[np.ndarray] = None   # (3, B, N): M Phi'
    beta: Optional[np.ndarray] = None    # M Phi'' + C(Phi, Phi') Phi'
    gamma: Optional[np.ndarray] = None   # g + spring


class ThrowingArm:
    """The throwing arm's model (a robot file with the throwing arm's structure) at given parameter
    values, compiled for fast vectorized evaluation of constraints and reduced dynamics.

    ``params`` overrides robot parameters by name (m1, c3, J2, d3, l0, platform, g, ...).

    >>> arm = ThrowingArm(params={"platform": 0.0})
    >>> round(arm.values["l3"], 2), arm.limits["speed"].round(4).tolist()
    (0.24, [1.9199, 2.234, 3.2114])
    """

    def __init__(self, robot: RobotModel | str | None = None, params: Optional[Mapping[str, float]] = None):
        robot = load_robot(robot or ROBOT_NAME) if not isinstance(robot, RobotModel) else robot
        missing = [p for p in REQUIRED_PARAMETERS if p not in robot.parameters]
        if robot.n != 3 or robot.actuated != (True, True, False) or missing or "ball" not in robot.points:
            raise UserError(f"robot '{robot.name}' does not have the throwing arm's structure (three "
                            f"coordinates, the third passive, a point 'ball', parameters {REQUIRED_PARAMETERS}; "
                            f"missing: {missing})")
        if robot.has_friction:
            raise UserError("the VHC reduced dynamics of the throwing arm assumes no friction")
        self.robot = robot
        self.numeric = NumericModel(robot, params)      # validates the values
        self.values = dict(self.numeric.values)
        for name in ("l1", "l2", "l3"):
            if self.values[name] <= 0:
                raise UserError(f"{name}: a link length must be positive (got {self.values[name]:g})")
        if self.values["platform"] + self.values["l0"] < 0:
            raise UserError("the shoulder (platform + l0) must not be below the ground")
        self.l1, self.l2, self.l3 = (self.values[n] for n in ("l1", "l2", "l3"))
        self.shoulder_height = self.values["platform"] + self.values["l0"]
        self.g = self.values["g"]
        self._param_names = list(robot.parameters)
        self._k_index = self._param_names.index("k")
        dyn = derive(robot)
        q, dq, p = robot.q, robot.dq, robot.parameter_symbols
        self._fM = compiled_function(robot, "vhc:M", [q, p], list(dyn.M))
        self._fc = compiled_function(robot, "vhc:c", [q, dq, p], list(dyn.c))
        self._fG = compiled_function(robot, "vhc:G", [q, p], list(dyn.g + dyn.spring))
        self.limits = self._read_limits()
        self._check_kinematics()

    # ------------------------------------------------------------------ data
    def _read_limits(self) -> Dict[str, np.ndarray]:
        lo, hi, speed, torque = [], [], [], []
        for i, name in enumerate(self.robot.coordinates):
            lim = self.robot.limits.get(name)
            pos = lim.position if lim and lim.position else (-np.inf, np.inf)
            lo.append(pos[0])
            hi.append(pos[1])
            speed.append(lim.velocity if lim and lim.velocity else np.inf)
            if self.robot.actuated[i]:
                torque.append(lim.torque if lim and lim.torque else np.inf)
        return {"lower": np.array(lo), "upper": np.array(hi), "speed": np.array(speed), "torque": np.array(torque)}

    def _check_kinematics(self) -> None:
        """The robot file's ball point must be where eq. (3.1) puts it (else the VHC would be wrong)."""
        pos, _jac = self.numeric.named_point("ball")
        q = np.array([0.7, -0.4, 0.9])
        mine = self.ball_position(q[:, None])[:, 0]
        if not np.allclose(pos(q)[:2], mine, atol=1e-12):
            raise UserError(f"robot '{self.robot.name}': the point 'ball' is not at the tip of link 3 at "
                            f"(0, platform + l0) + l1, l2, l3 as the VHC of eq. (3.12) assumes")

    def ball_position(self, q: np.ndarray) -> np.ndarray:
        """Ball (x, y) [m], y from the ground, for joint angles q of shape (3, ...) (eq. 3.1 + platform)."""
        a1, a12 = q[0], q[0] + q[1]
        a123 = a12 + q[2]
        x = self.l1 * np.cos(a1) + self.l2 * np.cos(a12) + self.l3 * np.cos(a123)
        y = self.shoulder_height + self.l1 * np.sin(a1) + self.l2 * np.sin(a12) + self.l3 * np.sin(a123)
        return np.stack([x, y])

    def ball_velocity(self, q: np.ndarray, dq: np.ndarray) -> np.ndarray:
        """Ball velocity J(q) dq [m/s] for arrays of shape (3, ...)."""
        a1, a12 = q[0], q[0] + q[1]
        a123 = a12 + q[2]
        w1, w12 = dq[0], dq[0] + dq[1]
        w123 = w12 + dq[2]
        vx = -(self.l1 * np.sin(a1) * w1 + self.l2 * np.sin(a12) * w12 + self.l3 * np.sin(a123) * w123)
        vy = self.l1 * np.cos(a1) * w1 + self.l2 * np.cos(a12) * w12 + self.l3 * np.cos(a123) * w123
        return np.stack([vx, vy])

    def theta_of_q(self, q: np.ndarray, psi: float) -> np.ndarray:
        """Eq. (3.12): the ball's position along the axis through the shoulder rotated by psi."""
        return (self.l1 * np.cos(q[0] - psi) + self.l2 * np.cos(q[0] + q[1] - psi)
                + self.l3 * np.cos(q[0] + q[1] + q[2] - psi))

    def _params(self, k) -> list:
        p = [self.values[n] for n in self._param_names]
        p[self._k_index] = k
        return p

    # ------------------------------------------------------------------ constraint geometry
    def constraint(self, spec: ThrowSpec, theta, dynamics: bool = True, strict: bool = True) -> ConstraintState:
        """q = Phi(theta) and its theta-derivatives (and alpha, beta, gamma) at the given theta values.

        With ``strict`` an unreachable theta (|arccos argument| > 1) raises a VHCError naming s and theta.

        >>> arm = ThrowingArm()
        >>> st = arm.constraint(thesis_throw("throw1"), [-0.3377])
        >>> st.q[:, 0, 0].round(4).tolist()
        [1.732, 0.666, 0.6283]
        """
        theta = np.atleast_1d(np.asarray(theta, dtype=float))
        batch = _Batch.of([spec])
        s = (theta - spec.theta_b) / (spec.theta_e - spec.theta_b)
        return self._evaluate(batch, s, dynamics=dynamics, strict=strict)

    def _evaluate(self, batch: "_Batch", s: np.ndarray, dynamics: bool = True, strict: bool = True,
                  clip: float = 1.0) -> ConstraintState:
        """Constraint (and reduced dynamics) at s-values ``s`` (N,) for a batch of throws (B)."""
        D = batch.theta_e - batch.theta_b                                   # (B, 1)
        theta = batch.theta_b + D * s[None, :]
        phi1, phi2 = [], []
        for pts, out in ((batch.a, phi1), (batch.b, phi2)):
            deg = pts.shape[1] - 1
            for r in range(3):
                out.append(pts @ bernstein(deg, s, r).T / D ** r)
        psi = batch.psi
        A1 = phi1[0] - psi
        A12 = phi1[0] + phi2[0] - psi
        w12, w12d = phi1[1] + phi2[1], phi1[2] + phi2[2]
        l1, l2, l3 = self.l1, self.l2, self.l3
        u = (theta - l1 * np.cos(A1) - l2 * np.cos(A12)) / l3
        if strict:
            bad = np.abs(u) > 1.0 + 1e-12
            if np.any(bad):
                row = int(np.argwhere(bad)[0][0])
                idx = np.flatnonzero(bad[row])
                w = idx[np.argmax(np.abs(u[row, idx]))]
                raise VHCError(
                    f"the constraint cannot be reached for s between about {s[idx[0]]:.4f} and {s[idx[-1]]:.4f} (theta from "
                    f"{theta[row, idx[0]]:.4f} to {theta[row, idx[-1]]:.4f} m): the arccos argument of eq. (3.14) "
                    f"reaches {u[row, w]:.5f} at s = {s[w]:.4f} (theta = {theta[row, w]:.4f} m), outside [-1, 1]; "
                    f"the ball would have to be {1e3 * (abs(u[row, w]) - 1) * l3:.1f} mm beyond the reach of link 3")
        A3 = batch.branch * np.arccos(np.clip(u, -clip, clip))
        sA1, cA1, sA12, cA12, sA3, cA3 = np.sin(A1), np.cos(A1), np.sin(A12), np.cos(A12), np.sin(A3), np.cos(A3)
        with np.errstate(divide="ignore", invalid="ignore"):
            A3d = -(1.0 + l1 * sA1 * phi1[1] + l2 * sA12 * w12) / (l3 * sA3)
            A3dd = -(l1 * (cA1 * phi1[1] ** 2 + sA1 * phi1[2]) + l2 * (cA12 * w12 ** 2 + sA12 * w12d)
                     + l3 * cA3 * A3d ** 2) / (l3 * sA3)
        q = np.stack([phi1[0], phi2[0], A3 + psi - phi1[0] - phi2[0]])
        dq = np.stack([phi1[1], phi2[1], A3d - w12])
        ddq = np.stack([phi1[2], phi2[2], A3dd - w12d])
        st = ConstraintState(theta, q, dq, ddq, u)
        if dynamics:
            shape = theta.shape
            p = self._params(batch.k)
            M = np.stack([np.broadcast_to(e, shape) for e in self._fM(q, p)]).reshape((3, 3) + shape)
            c = np.stack([np.broadcast_to(e, shape) for e in self._fc(q, dq, p)])
            G = np.stack([np.broadcast_to(e, shape) for e in self._fG(q, p)])
            st.alpha = np.einsum("ij...,j...->i...", M, dq)
            st.beta = np.einsum("ij...,j...->i...", M, ddq) + c
            st.gamma = G
        return st

    # ------------------------------------------------------------------ release kinematics
    def release(self, spec: ThrowSpec, theta_dot_e: float) -> "Release":
        """The ball's state at theta_e for a given release speed theta_dot_e (kinematics only)."""
        st = self.constraint(spec, [spec.theta_e], dynamics=False)
        q = st.q[:, 0, 0]
        dq = st.dq[:, 0, 0] * theta_dot_e
        return Release.make(self, spec, q, dq, theta_dot_e)

    # ------------------------------------------------------------------ the throw
    def solve(self, spec: ThrowSpec, tol: float = 1e-12, nodes: int = 16, max_pieces: int = 512,
              progress: Progress = None) -> "Throw":
        """theta_dot^2(theta) from (3.24), the time law and everything along the throw.

        Raises VHCError when the constraint cannot be reached, alpha crosses zero, or the arm does
        not get to theta_e (theta_dot^2 reaches zero)."""
        mesh = ChebPieces(np.linspace(0.0, 1.0, 9), nodes)
        batch = _Batch.of([spec])
        for it in range(40):
            if progress:
                progress(min(0.9, 0.1 * it), f"quadrature on {mesh.pieces} pieces")
            sol = _integrate(self, batch, mesh)
            sol.raise_problems(spec)
            scale = [np.sum(np.abs(f) * 0.5 * mesh.h[:, None]) / mesh.P + 1e-300 for f in sol.integrands]
            refine = np.zeros(mesh.pieces, dtype=bool)
            for f, sc in zip(sol.integrands, scale):
                refine |= mesh.tails(f)[0] > tol * max(sc, 1e-3)
            if not refine.any() or mesh.pieces >= max_pieces:
                break
            mesh = mesh.split(refine)
        if progress:
            progress(1.0, "done")
        return Throw(self, spec, mesh, sol, converged=not refine.any())

    def reduced_ode(self, spec: ThrowSpec, rtol: float = 1e-12) -> "ReducedSolution":
        """Integrate alpha theta'' + beta theta'^2 + gamma = 0 in time from (theta_b, theta_dot_b) until
        theta = theta_e (an independent check of the closed form)."""
        from scipy.integrate import solve_ivp

        batch = _Batch.of([spec])
        D = spec.theta_e - spec.theta_b

        def rhs(t, x):
            st = self._evaluate(batch, np.array([(x[0] - spec.theta_b) / D]), strict=False, clip=1.0)
            return [x[1], -(st.beta[2, 0, 0] * x[1] ** 2 + st.gamma[2, 0, 0]) / st.alpha[2, 0, 0]]

        def at_release(t, x):
            return x[0] - spec.theta_e
        at_release.terminal = True
        at_release.direction = 1
        sol = solve_ivp(rhs, (0.0, 10.0), [spec.theta_b, spec.theta_dot_b], method="DOP853", rtol=rtol,
                        atol=1e-12, events=at_release, dense_output=True)
        if not sol.t_events[0].size:
            raise VHCError("the reduced dynamics never reaches theta_e within 10 s")
        T = float(sol.t_events[0][0])
        return ReducedSolution(T, float(sol.y_events[0][0][1]), sol.t, sol.y[0], sol.y[1], sol.sol)


@dataclass
class ReducedSolution:
    """The reduced dynamics integrated in time (``ThrowingArm.reduced_ode``); ``dense(t)`` -> (theta, theta_dot)."""
    duration: float
    theta_dot_e: float
    t: np.ndarray
    theta: np.ndarray
    theta_dot: np.ndarray
    dense: object


@dataclass
class _Batch:
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
    def of(specs: Sequence[ThrowSpec]) -> "_Batch":
        col = lambda name: np.array([[float(getattr(s, name))] for s in specs])
        return _Batch(np.array([s.a for s in specs]), np.array([s.b for s in specs]), col("theta_b"),
                      col("theta_e"), col("psi"), col("k"), col("theta_dot_b"), col("branch"))


@dataclass
class _Integrals:
    """Closed-form theta_dot^2 and time on a Chebyshev mesh in sigma (arrays (B, K, P))."""
    state: ConstraintState
    theta: np.ndarray
    I1: np.ndarray            # int beta/alpha dtheta from theta_b
    I2: np.ndarray            # int exp(2 I1) 2 gamma/alpha dtheta
    Y: np.ndarray             # theta_dot^2
    time: Optional[np.ndarray]
    integrands: List[np.ndarray]
    alpha_sign_change: np.ndarray
    stall: np.ndarray
    mesh: ChebPieces

    def raise_problems(self, spec: ThrowSpec) -> None:
        a3 = self.state.alpha[2].reshape(self.theta.shape)[0]
        th = self.theta[0]
        if self.alpha_sign_change[0]:
            flat = a3.ravel()
            j = int(np.argmax(np.sign(flat[1:]) != np.sign(flat[0])))
            raise VHCError(f"the reduced dynamics is singular: alpha (eq. 3.15) changes sign near theta = "
                           f"{th.ravel()[j + 1]:.4f} m (s = {(th.ravel()[j + 1] - spec.theta_b) / (spec.theta_e - spec.theta_b):.4f}); "
                           f"theta_dot^2 of eq. (3.24) is undefined there")
        if self.stall[0]:
            Y = self.Y[0].ravel()
            j = int(np.argmax(Y[1:] <= 0)) + 1
            if j == 1 and spec.theta_dot_b == 0:
                raise VHCError("from rest the passive wrist pushes theta backwards (gamma/alpha > 0 at "
                               "theta_b): the throw cannot start")
            raise VHCError(f"theta_dot^2 reaches zero at theta = {th.ravel()[j]:.4f} m before the release "
                           f"point theta_e = {spec.theta_e:.4f} m: the arm stops and swings back")


def _integrate(arm: ThrowingArm, batch: _Batch, mesh: ChebPieces, with_time: bool = True,
               strict: bool = True, clip: float = 1.0) -> _Integrals:
    sigma = mesh.nodes.ravel()
    st = arm._evaluate(batch, sigma * sigma, strict=strict, clip=clip)
    B = batch.theta_b.shape[0]
    shape = (B,) + mesh.nodes.shape
    D = (batch.theta_e - batch.theta_b)[:, :, None]
    dth = 2.0 * D * mesh.nodes[None]                   # dtheta/dsigma
    a3 = st.alpha[2].reshape(shape)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        g1 = st.beta[2].reshape(shape) / a3 * dth
        g2 = 2.0 * st.gamma[2].reshape(shape) / a3 * dth
        I1 = mesh.cumulative(g1)
        e = np.exp(2.0 * I1)
        I2 = mesh.cumulative(e * g2)
        Yb = (batch.theta_dot_b ** 2)[:, :, None]
        Y = (Yb - I2) / e
    flat = a3.reshape(B, -1)
    sign_change = np.any(np.sign(flat) != np.sign(flat[:, :1]), axis=1) | np.any(flat == 0, axis=1)
    Yf = Y.reshape(B, -1)
    stall = np.any(Yf[:, 1:] <= 0, axis=1)
    integrands = [g1, g2]
    time_nodes = None
    if with_time and not stall.any() and not sign_change.any():
        with np.errstate(divide="ignore", invalid="ignore"):
            gt = dth / np.sqrt(Y)
        # at sigma = 0: 0 when moving, 2 sqrt(D / Y'(theta_b)) from rest (Y ~ Y' D sigma^2)
        slope = (-2.0 * st.gamma[2].reshape(shape) / a3)[:, 0, 0]
        start = np.where(batch.theta_dot_b[:, 0] > 0, 0.0, 2.0 * np.sqrt(D[:, 0, 0] / np.maximum(slope, 1e-300)))
        gt[:, 0, 0] = start
        integrands.append(gt)
        time_nodes = mesh.cumulative(gt)
    return _Integrals(st, st.theta.reshape(shape), I1, I2, Y, time_nodes, integrands, sign_change, stall, mesh)


# ====================================================================== results
@dataclass(frozen=True)
class Release:
    """The ball at release: joint state, position (y from the ground), true velocity J(q) dq, and
    the thesis's convention (speed theta_dot along psi), with the distances of eqs. (3.4)/(3.5)."""
    q: np.ndarray
    dq: np.ndarray
    theta_dot: float
    position: np.ndarray
    velocity: np.ndarray
    velocity_thesis: np.ndarray
    distance_from_base: float
    distance_from_release: float
    distance_from_base_thesis: float
    distance_from_release_thesis: float
    g: float

    @staticmethod
    def make(arm: ThrowingArm, spec: ThrowSpec, q, dq, theta_dot: float) -> "Release":
        q = np.asarray(q, dtype=float)
        dq = np.asarray(dq, dtype=float)
        pos = arm.ball_position(q)
        vel = arm.ball_velocity(q, dq)
        if pos[1] < 0:
            raise VHCError(f"the release point is {-pos[1]:.3f} m below the ground")
        vth = theta_dot * np.array([math.cos(spec.psi), math.sin(spec.psi)])
        d = float(landing_distance(pos[0], pos[1], vel[0], vel[1], arm.g))
        dt = float(landing_distance(pos[0], pos[1], vth[0], vth[1], arm.g))
        return Release(q, dq, float(theta_dot), pos, vel, vth, d, d - float(pos[0]), dt, dt - float(pos[0]), arm.g)

    @property
    def speed(self) -> float:
        return float(np.hypot(*self.velocity))

    @property
    def angle_deg(self) -> float:
        """Direction of the true ball velocity above the horizontal [deg]."""
        return math.degrees(math.atan2(self.velocity[1], self.velocity[0]))


@dataclass
class Trajectory:
    """Samples along a throw (arrays over time; q-like arrays have shape (3, n))."""
    t: np.ndarray
    theta: np.ndarray
    theta_dot: np.ndarray
    theta_ddot: np.ndarray
    q: np.ndarray
    dq: np.ndarray
    ddq: np.ndarray
    tau: np.ndarray          # (2, n) actuated torques
    ball: np.ndarray         # (2, n) ball position, y from the ground
    ball_velocity: np.ndarray


@dataclass
class Feasibility:
    """Constraint check of a throw on a dense grid (limits of the robot file, Table A.2)."""
    feasible: bool
    violations: List[str]
    max_speed_ratio: List[float]
    max_torque: List[float]
    q_min: List[float]
    q_max: List[float]
    grid: int


class Throw:
    """A solved throw: theta_dot(theta), the time law, joint motion, torques and the release.

    ``converged`` says whether the adaptive quadrature met its tolerance; ``nodes`` is its size."""

    def __init__(self, arm: ThrowingArm, spec: ThrowSpec, mesh: ChebPieces, sol: _Integrals, converged: bool):
        self.arm = arm
        self.spec = spec
        self.mesh = mesh
        self.converged = converged
        self._I1 = sol.I1[0]
        self._I2 = sol.I2[0]
        self._time = sol.time[0]
        Y = sol.Y[0]
        self.theta_dot_e = float(math.sqrt(Y[-1, -1]))
        self.duration = float(self._time[-1, -1])
        self.release = arm.release(spec, self.theta_dot_e)
        self.nodes = int(mesh.nodes.size)

    @property
    def delta(self) -> float:
        return self.spec.theta_e - self.spec.theta_b

    def _sigma(self, theta) -> np.ndarray:
        s = (np.asarray(theta, dtype=float) - self.spec.theta_b) / self.delta
        if np.any(s < -1e-12) or np.any(s > 1 + 1e-12):
            raise UserError(f"theta outside the throw's interval [{self.spec.theta_b}, {self.spec.theta_e}]")
        return np.sqrt(np.clip(s, 0.0, 1.0))

    def theta_dot_squared(self, theta) -> np.ndarray:
        """Closed form (3.24) at any theta in [theta_b, theta_e]."""
        sig = self._sigma(theta)
        I1 = self.mesh.interpolate(self._I1, sig)
        I2 = self.mesh.interpolate(self._I2, sig)
        return np.where(sig > 0, (self.spec.theta_dot_b ** 2 - I2) * np.exp(-2.0 * I1), self.spec.theta_dot_b ** 2)

    def theta_dot(self, theta) -> np.ndarray:
        return np.sqrt(np.maximum(self.theta_dot_squared(theta), 0.0))

    def time_of(self, theta) -> np.ndarray:
        """t(theta) = integral of dtheta / theta_dot from theta_b [s]."""
        return self.mesh.interpolate(self._time, self._sigma(theta))

    def theta_at(self, t) -> np.ndarray:
        """The time law theta(t) for 0 <= t <= duration (inverse of time_of, Newton-polished)."""
        t = np.clip(np.asarray(t, dtype=float), 0.0, self.duration)
        sig_nodes = self.mesh.nodes.ravel()
        sig = np.interp(t, self._time.ravel(), sig_nodes)
        for _ in range(4):          # Newton on t(sigma) = t with dt/dsigma = 2 D sigma / theta_dot
            th = self.spec.theta_b + self.delta * sig * sig
            err = self.mesh.interpolate(self._time, sig) - t
            rate = 2.0 * self.delta * sig / np.maximum(self.theta_dot(th), 1e-300)
            step = np.where(rate > 0, err / np.where(rate > 0, rate, 1.0), 0.0)
            sig = np.clip(sig - step, 0.0, 1.0)
        return self.spec.theta_b + self.delta * sig * sig

    def along(self, theta) -> Trajectory:
        """Joint angles, speeds, accelerations and torques at the given theta values."""
        theta = np.atleast_1d(np.asarray(theta, dtype=float))
        st = self.arm.constraint(self.spec, theta)
        Y = np.maximum(self.theta_dot_squared(theta), 0.0)
        a, b, c = (x[:, 0, :] for x in (st.alpha, st.beta, st.gamma))
        thdd = -(b[2] * Y + c[2]) / a[2]
        q, p1, p2 = st.q[:, 0, :], st.dq[:, 0, :], st.ddq[:, 0, :]
        thd = np.sqrt(Y)
        dq = p1 * thd
        ddq = p2 * Y + p1 * thdd
        tau = a[:2] * thdd + b[:2] * Y + c[:2]
        return Trajectory(self.time_of(theta), theta, thd, thdd, q, dq, ddq, tau,
                          self.arm.ball_position(q), self.arm.ball_velocity(q, dq))

    def sample(self, n: int = 200) -> Trajectory:
        """n samples uniform in time from t = 0 to the release (their times exactly those, the first 0)."""
        t = np.linspace(0.0, self.duration, n)
        return replace(self.along(self.theta_at(t)), t=t)

    def check(self, grid: int = 2001, q1_min: Optional[float] = None) -> Feasibility:
        """Every limit of the robot file (positions, speeds, torques) on a uniform theta grid plus the
        quadrature nodes. ``q1_min`` tightens q1's lower limit (pi/6 in eq. 4.5)."""
        theta = np.union1d(np.linspace(self.spec.theta_b, self.spec.theta_e, grid),
                           self.spec.theta_b + self.delta * self.mesh.nodes.ravel() ** 2)
        tr = self.along(theta)
        lim = self.arm.limits
        lower = lim["lower"].copy()
        if q1_min is not None:
            lower[0] = max(lower[0], q1_min)
        names = self.arm.robot.coordinates
        violations: List[str] = []
        tol = 1e-9
        for i, name in enumerate(names):
            j_lo, j_hi = int(np.argmin(tr.q[i])), int(np.argmax(tr.q[i]))
            if tr.q[i, j_lo] < lower[i] - tol:
                violations.append(f"{name} = {tr.q[i, j_lo]:.4f} rad below its lower limit {lower[i]:.4f} rad "
                                  f"at theta = {theta[j_lo]:.4f} m")
            if tr.q[i, j_hi] > lim["upper"][i] + tol:
                violations.append(f"{name} = {tr.q[i, j_hi]:.4f} rad above its upper limit {lim['upper'][i]:.4f} rad "
                                  f"at theta = {theta[j_hi]:.4f} m")
        ratios = []
        for i, name in enumerate(names):
            j = int(np.argmax(np.abs(tr.dq[i])))
            ratio = float(abs(tr.dq[i, j]) / lim["speed"][i])
            ratios.append(ratio)
            if ratio > 1 + tol:
                violations.append(f"speed of {name}: {abs(tr.dq[i, j]):.4f} rad/s at theta = {theta[j]:.4f} m is "
                                  f"{ratio:.2%} of its limit {lim['speed'][i]:.4f} rad/s")
        torques = []
        act = [n for n, a in zip(names, self.arm.robot.actuated) if a]
        for i, name in enumerate(act):
            j = int(np.argmax(np.abs(tr.tau[i])))
            torques.append(float(abs(tr.tau[i, j])))
            if abs(tr.tau[i, j]) > lim["torque"][i] * (1 + tol):
                violations.append(f"torque of {name}: {abs(tr.tau[i, j]):.2f} N m at theta = {theta[j]:.4f} m "
                                  f"exceeds its limit {lim['torque'][i]:g} N m")
        return Feasibility(not violations, violations, ratios, torques, tr.q.min(axis=1).tolist(),
                           tr.q.max(axis=1).tolist(), int(theta.size))


# ====================================================================== phase portraits, equilibria
@dataclass
class Equilibrium:
    theta: float
    omega: float      # d(gamma/alpha)/dtheta at theta (eq. 4.8)
    kind: str         # "center" (omega > 0) or "saddle" (omega < 0)


@dataclass
class PhaseCurve:
    theta0: float
    theta_dot0: float
    theta: np.ndarray
    theta_dot: np.ndarray     # upper branch (+sqrt); NaN where theta_dot^2 < 0 or outside its segment


@dataclass
class PhasePortrait:
    theta: np.ndarray
    alpha: np.ndarray
    gamma: np.ndarray
    equilibria: List[Equilibrium]
    singular: List[float]      # theta where alpha changes sign
    curves: List[PhaseCurve]


def phase_portrait(arm: ThrowingArm, spec: ThrowSpec, theta_range: Optional[Tuple[float, float]] = None,
                   initial: Optional[Sequence[Tuple[float, float]]] = None, n: int = 2001) -> PhasePortrait:
    """theta_dot(theta) through several initial conditions (the integral (3.24) from each), the
    equilibria (gamma = 0) and their type from the sign of d(gamma/alpha)/dtheta (eq. 4.8).

    The reduced system has the first integral (3.24), so its equilibria are centres (omega > 0) or
    saddles (omega < 0); foci (as the thesis's section 4.3 suggests) cannot occur. Outside the
    reachable part of the range (|arccos argument| > 1) and across zeros of alpha the curves stop.
    """
    from scipy.integrate import cumulative_simpson
    from scipy.optimize import brentq

    lo, hi = theta_range or (spec.theta_b, spec.theta_e)
    if not hi > lo:
        raise UserError("the phase-portrait range must be increasing")
    theta = np.linspace(lo, hi, n)
    st = arm.constraint(spec, theta, strict=False)
    ok = np.abs(st.u[0]) <= 1.0
    a, b, c = st.alpha[2, 0], st.beta[2, 0], st.gamma[2, 0]
    a = np.where(ok, a, np.nan)
    # segments: reachable and alpha of one sign
    seg_id = np.full(n, -1)
    current = -1
    for j in range(n):
        if not ok[j] or a[j] == 0:
            continue
        if j == 0 or seg_id[j - 1] < 0 or np.sign(a[j]) != np.sign(a[j - 1]):
            current += 1
        seg_id[j] = current
    singular = [float(0.5 * (theta[j] + theta[j + 1])) for j in range(n - 1)
                if ok[j] and ok[j + 1] and np.sign(a[j]) * np.sign(a[j + 1]) < 0]

    def ratio(th):
        s = arm.constraint(spec, [th], strict=False)
        return s.gamma[2, 0, 0] / s.alpha[2, 0, 0]

    equilibria: List[Equilibrium] = []
    for j in range(n - 1):
        if seg_id[j] >= 0 and seg_id[j] == seg_id[j + 1] and np.sign(c[j]) * np.sign(c[j + 1]) <= 0 and c[j] != c[j + 1]:
            if c[j] == 0 and j > 0 and equilibria and abs(equilibria[-1].theta - theta[j]) < 1e-12:
                continue
            root = brentq(lambda th: arm.constraint(spec, [th], strict=False).gamma[2, 0, 0], theta[j], theta[j + 1],
                          xtol=1e-14)
            h = 1e-5 * max(1.0, abs(root))
            omega = (ratio(root + h) - ratio(root - h)) / (2 * h)
            equilibria.append(Equilibrium(float(root), float(omega), "center" if omega > 0 else "saddle"))
    # first integral per segment: Y e^{2 F1} + F2 = const
    F1 = np.full(n, np.nan)
    F2 = np.full(n, np.nan)
    for sid in range(current + 1):
        idx = np.flatnonzero(seg_id == sid)
        if idx.size < 3:
            continue
        th = theta[idx]
        with np.errstate(over="ignore", invalid="ignore"):
            F1[idx] = cumulative_simpson(b[idx] / a[idx], x=th, initial=0.0)
            F2[idx] = cumulative_simpson(np.exp(2 * F1[idx]) * 2 * c[idx] / a[idx], x=th, initial=0.0)
    if initial is None:
        initial = [(float(t0), 0.0) for t0 in np.linspace(lo, hi, 9)[1:-1]]
        initial.append((spec.theta_b, spec.theta_dot_b))
    curves = []
    for th0, thd0 in initial:
        j0 = int(np.clip(np.searchsorted(theta, th0), 0, n - 1))
        sid = seg_id[j0]
        out = np.full(n, np.nan)
        if sid >= 0:
            idx = np.flatnonzero(seg_id == sid)
            f1 = np.interp(th0, theta[idx], F1[idx])
            f2 = np.interp(th0, theta[idx], F2[idx])
            with np.errstate(over="ignore", invalid="ignore"):
                const = thd0 ** 2 * np.exp(2 * f1) + f2
                Y = (const - F2[idx]) * np.exp(-2 * F1[idx])
            out[idx] = np.where(np.isfinite(Y) & (Y >= 0), np.sqrt(np.abs(Y)), np.nan)
        curves.append(PhaseCurve(float(th0), float(thd0), theta, out))
    return PhasePortrait(theta, a, c, equilibria, singular, curves)


# ====================================================================== full dynamics
@dataclass
class FullSimulation:
    """The complete 3-DOF arm, wrist free, from the VHC's initial state."""
    controller: str
    t: np.ndarray
    q: np.ndarray                 # (3, n)
    dq: np.ndarray
    tau: np.ndarray               # (2, n)
    q_vhc: np.ndarray             # the VHC prediction at the same times
    max_wrist_drift: float        # max |q3 - q3_vhc| [rad]
    max_ball_drift: float         # max |ball - ball_vhc| [m]
    max_theta_dot_error: float    # max |theta_dot_sim - theta_dot_closed_form(theta_sim)| / theta_dot_e
    duration: float               # time to reach theta_e [s]
    release: Release


def simulate_full(throw: Throw, controller: str = "feedforward", rtol: float = 1e-11,
                  kp: float = 400.0, kd: float = 40.0, samples: int = 400,
                  progress: Progress = None) -> FullSimulation:
    """Simulate M q'' + C q' + g + k q3 = [tau1, tau2, 0] (NumericModel, wrist passive).

    ``controller``: "feedforward" applies the VHC torques tau1(t), tau2(t) open loop; "computed_torque"
    tracks the VHC's joint trajectory on joints 1 and 2 by collocated partial feedback linearization
    (q1'' and q2'' imposed as reference + kd e' + kp e, the wrist left to its own dynamics). The
    reference theta*(t) is integrated alongside from the reduced dynamics. The run stops when the
    simulated ball reaches theta_e (release)."""
    from scipy.integrate import solve_ivp

    if controller not in ("feedforward", "computed_torque"):
        raise UserError(f"unknown controller '{controller}' (feedforward or computed_torque)")
    if progress:
        progress(0.0, f"preparing the full arm's model ({controller})")
    arm, spec = throw.arm, throw.spec
    num = NumericModel(arm.robot, {**arm.values, "k": spec.k})
    batch = _Batch.of([spec])
    D = throw.delta

    def reference(th, thd):
        st = arm._evaluate(batch, np.array([(th - spec.theta_b) / D]), strict=False)
        a, b, c = st.alpha[:, 0, 0], st.beta[:, 0, 0], st.gamma[:, 0, 0]
        thdd = -(b[2] * thd * thd + c[2]) / a[2]
        q = st.q[:, 0, 0]
        dq = st.dq[:, 0, 0] * thd
        ddq = st.ddq[:, 0, 0] * thd * thd + st.dq[:, 0, 0] * thdd
        tau = a[:2] * thdd + b[:2] * thd * thd + c[:2]
        return q, dq, ddq, thdd, tau

    def torques(x):
        q, dq, th, thd = x[:3], x[3:6], x[6], x[7]
        qr, dqr, ddqr, thdd, tau_ff = reference(th, thd)
        if controller == "feedforward":
            return tau_ff, thdd
        M = num.M(q)
        h = num.bias(q, dq)
        acc = ddqr[:2] + kd * (dqr[:2] - dq[:2]) + kp * (qr[:2] - q[:2])
        dd3 = -(M[2, :2] @ acc + h[2]) / M[2, 2]
        ddq = np.array([acc[0], acc[1], dd3])
        return (M @ ddq + h)[:2], thdd

    horizon = 2.0 * throw.duration + 0.5
    calls = [0]

    def rhs(t, x):
        calls[0] += 1
        if progress and calls[0] % 50 == 0:       # about 10 ms apart; the progress may stop the run (by raising)
            progress(0.05 + 0.9 * min(1.0, t / throw.duration), f"simulating the full arm ({controller}), t = {t:.3f} s")
        tau, thdd = torques(x)
        ddq = num.forward_dynamics(x[:3], x[3:6], [tau[0], tau[1], 0.0])
        return np.concatenate([x[3:6], ddq, [x[7], thdd]])

    def at_release(t, x):
        return arm.theta_of_q(x[:3], spec.psi) - spec.theta_e
    at_release.terminal = True
    at_release.direction = 1

    st0 = arm.constraint(spec, [spec.theta_b], dynamics=False)
    x0 = np.concatenate([st0.q[:, 0, 0], st0.dq[:, 0, 0] * spec.theta_dot_b, [spec.theta_b, spec.theta_dot_b]])
    if progress:
        progress(0.05, f"simulating the full arm ({controller})")
    sol = solve_ivp(rhs, (0.0, horizon), x0, method="DOP853", rtol=rtol, atol=1e-12,
                    events=at_release, dense_output=True)
    if not sol.t_events[0].size:
        raise VHCError(f"in the full simulation ({controller}) the ball never reaches theta_e")
    T = float(sol.t_events[0][0])
    t = np.linspace(0.0, T, samples)
    X = sol.sol(t)
    X[:, -1] = sol.y_events[0][0]
    q, dq = X[:3], X[3:6]
    if progress:
        progress(0.95, f"sampling the full arm's motion ({controller})")
    refs = [reference(X[6, j], X[7, j]) for j in range(samples)]
    if progress:
        progress(0.97, f"sampling the full arm's motion ({controller})")
    q_vhc = np.array([r[0] for r in refs]).T
    tau = np.array([torques(X[:, j])[0] for j in range(samples)]).T
    if progress:
        progress(0.99, f"sampling the full arm's motion ({controller})")
    ball = arm.ball_position(q)
    ball_vhc = arm.ball_position(q_vhc)
    theta_sim = arm.theta_of_q(q, spec.psi)
    # d theta / dt = d theta/dq . dq
    a1, a12, a123 = q[0] - spec.psi, q[0] + q[1] - spec.psi, q[0] + q[1] + q[2] - spec.psi
    w1, w12, w123 = dq[0], dq[0] + dq[1], dq[0] + dq[1] + dq[2]
    thd_sim = -(arm.l1 * np.sin(a1) * w1 + arm.l2 * np.sin(a12) * w12 + arm.l3 * np.sin(a123) * w123)
    thd_cf = throw.theta_dot(np.clip(theta_sim, spec.theta_b, spec.theta_e))
    rel = Release.make(arm, spec, q[:, -1], dq[:, -1], float(thd_sim[-1]))
    if progress:
        progress(1.0, "done")
    return FullSimulation(controller, t, q, dq, tau, q_vhc, float(np.max(np.abs(q[2] - q_vhc[2]))),
                          float(np.max(np.hypot(*(ball - ball_vhc)))),
                          float(np.max(np.abs(thd_sim - thd_cf)) / throw.theta_dot_e), T, rel)


# ====================================================================== bounds
@dataclass
class SpeedBound:
    """The farthest throw that the joint speed limits alone allow (no dynamics, no torques)."""
    convention: str             # "physical" (ball velocity J q') or "thesis" (speed theta_dot along psi)
    distance_from_base: float
    q: np.ndarray
    dq: np.ndarray
    psi: Optional[float]        # thesis convention: the rotation of the theta axis [rad]
    position: np.ndarray
    velocity: np.ndarray


def _landing(arm: ThrowingArm, pos, vel):
    return landing_distance(pos[0], np.maximum(pos[1], 0.0), vel[0], vel[1], arm.g)


def speed_limit_bound(arm: ThrowingArm, convention: str = "physical", starts: int = 10,
                      seed: int = 0, progress: Progress = None) -> SpeedBound:
    """Maximize the landing distance from the base over every configuration in the joint ranges
    (q1 >= pi/6 as in eq. 4.5) and every joint velocity within the speed limits of Table A.2.

    No throw can land farther (in the same convention): its release state is one of these. In the
    thesis convention the speed is theta_dot = (J q') . (cos psi, sin psi), launched along psi.
    ``progress(fraction, message)`` is called before each local polish (and may stop the work by raising).
    """
    from scipy.optimize import minimize

    if convention not in ("physical", "thesis"):
        raise UserError(f"convention must be 'physical' or 'thesis', got {convention!r}")
    lim = arm.limits
    vmax = lim["speed"]
    qlo = np.maximum(lim["lower"], [Q1_MIN_EQ_4_5, -np.inf, -np.inf])
    bounds = list(zip(qlo, lim["upper"])) + [(-v, v) for v in vmax]
    if convention == "thesis":
        bounds.append((-math.pi / 2, math.pi / 2))

    def state(z):
        q, dq = z[:3], z[3:6]
        pos, vel = arm.ball_position(q), arm.ball_velocity(q, dq)
        if convention == "thesis":
        # only the component along psi counts, launched along psi
            e = np.array([math.cos(z[6]), math.sin(z[6])])
            vel = (vel @ e) * e
        return q, dq, pos, vel

    def neg(z):
        _q, _dq, pos, vel = state(z)
        return -float(_landing(arm, pos, vel))

    rng = np.random.default_rng(seed)
    lo = np.array([b[0] for b in bounds])
    hi = np.array([b[1] for b in bounds])
    Z = lo + (hi - lo) * rng.random((20000, lo.size))      # screen many states at once, polish the best
    q, dq = Z[:, :3].T, Z[:, 3:6].T
    pos, vel = arm.ball_position(q), arm.ball_velocity(q, dq)
    if convention == "thesis":
        e = np.stack([np.cos(Z[:, 6]), np.sin(Z[:, 6])])
        vel = np.sum(vel * e, axis=0) * e
    order = np.argsort(-_landing(arm, pos, vel))
    best = None
    for k, j in enumerate(order[:starts]):
        if progress:
            progress(k / starts, f"speed-limit bound: polish {k + 1}/{starts}")
        r = minimize(neg, Z[j], bounds=bounds, method="L-BFGS-B")
        if best is None or r.fun < best.fun:
            best = r
    q, dq, pos, vel = state(best.x)
    return SpeedBound(convention, -float(best.fun), q, dq, float(best.x[6]) if convention == "thesis" else None,
                      pos, vel)


@dataclass
class HandEstimate:
    """The thesis's estimate (chapter 6): arm stretched out, every joint at its speed limit."""
    speed: float                # sum of speed limit x distance to the ball [m/s]
    angle_deg: float            # release direction [deg]
    position: np.ndarray        # ball position (arm perpendicular to the release direction)
    distance_from_base: float
    best_angle_deg: float
    best_distance: float


def hand_estimate(arm: ThrowingArm, angle_deg: float = 14.0, speed: Optional[float] = None) -> HandEstimate:
    """Ball speed with the arm straight and all joints at their speed limits (or ``speed``), thrown
    at ``angle_deg`` with the arm perpendicular to the throw.

    >>> arm = ThrowingArm()
    >>> round(hand_estimate(arm).speed, 4), round(hand_estimate(arm, speed=4.18).distance_from_base, 3)
    (4.1859, 2.756)
    """
    from scipy.optimize import minimize_scalar

    v = arm.limits["speed"]
    L1, L2, L3 = arm.l1 + arm.l2 + arm.l3, arm.l2 + arm.l3, arm.l3
    speed = float(v[0] * L1 + v[1] * L2 + v[2] * L3) if speed is None else float(speed)

    def throw(angle):
        arm_angle = angle + math.pi / 2           # the arm is perpendicular to the velocity
        pos = np.array([L1 * math.cos(arm_angle), arm.shoulder_height + L1 * math.sin(arm_angle)])
        vel = speed * np.array([math.cos(angle), math.sin(angle)])
        return pos, float(_landing(arm, pos, vel))

    pos, d = throw(math.radians(angle_deg))
    best = minimize_scalar(lambda a: -throw(a)[1], bounds=(0.0, math.pi / 3), method="bounded",
                           options={"xatol": 1e-10})
    return HandEstimate(speed, angle_deg, pos, d, math.degrees(best.x), -float(best.fun))


# ====================================================================== optimization
@dataclass
class OptimizationResult:
    """The best throw found, re-solved with the adaptive quadrature and checked on a dense grid."""
    spec: ThrowSpec
    throw: Throw
    feasibility: Feasibility
    objective: str                # "thesis" (speed theta_dot along psi) or "physical" (J q')
    distance_from_base: float     # in the objective's convention [m]
    bound: SpeedBound             # what the speed limits alone allow, same convention
    evaluations: int              # throw-model evaluations (one per throw and finite-difference point)
    local_runs: int
    elapsed: float                # [s]
    history: List[Tuple[float, float]] = field(default_factory=list)   # (seconds, best feasible distance)
    evaluation_budget: int = 0    # the budget the run was given
    time_capped: bool = False     # the optional time cap ended the search (the result then depends on the machine)
    evaluation_history: List[Tuple[int, float]] = field(default_factory=list)   # (evaluations, best distance)


class _Timeout(Exception):
    pass


#: default evaluation budget of the optimizer (seed 0, thesis convention: its best throw, 2.9656 m, is
#: found after about 10 000 evaluations; see docs/throwing.md)
DEFAULT_EVALUATIONS = 12000


def _smooth_min(values: np.ndarray) -> np.ndarray:
    """Minimum over the last axis of samples on a uniform grid, refined by a parabola through the
    smallest sample and its neighbours (so that it moves smoothly with the function).

    >>> bool(abs(_smooth_min(np.array([(np.linspace(-1, 1, 9) - 0.1) ** 2]))[0]) < 1e-12)
    True
    """
    j = np.clip(np.argmin(values, axis=-1), 1, values.shape[-1] - 2)[..., None]
    f0, f1, f2 = (np.take_along_axis(values, j + d, axis=-1)[..., 0] for d in (-1, 0, 1))
    curv = f0 - 2.0 * f1 + f2
    with np.errstate(divide="ignore", invalid="ignore"):
        vertex = f1 - (f2 - f0) ** 2 / (8.0 * curv)
    inside = (curv > 0) & (np.abs(f2 - f0) < 2.0 * curv)
    return np.minimum(np.min(values, axis=-1), np.where(inside, vertex, np.inf))


class ThrowOptimizer:
    """Maximize the distance from the base over Bezier control points, theta_b, theta_e, psi and k
    (eq. 4.6) under every constraint of eq. (4.5): q1 in [pi/6, 7pi/6], |q2|, |q3| <= 2pi/3, the
    constraint reachable, joint speeds and torques within Table A.2, start from rest.

    Constraints are imposed at the nodes of a fixed Chebyshev mesh (value and finite-difference
    gradient are one vectorized call), with a small safety ``margin`` on speeds and torques; the
    result is re-solved adaptively and checked on a dense grid (the margin tightens if something
    slipped between nodes). Global stage: the speed-limit bound gives the ideal release pose;
    thousands of random joint-space swings ending near it (and the thesis's throws) are turned into
    Bezier VHCs and scored in batches; SLSQP runs from the best distinct ones until the budget ends.

    The wrist spring k ranges over [0, 2000] N m/rad, the stiffness range the thesis gives for the
    robot's joint impedance (section 2.2).
    """
    _progress: Progress = None      # during ``run``: reports by the clock from ``evaluate``
    _reported = 0.0

    def __init__(self, arm: ThrowingArm, degree: int = 6, objective: str = "thesis", pieces: int = 6,
                 nodes: int = 12, margin: float = 0.999, reach: float = 0.995, min_alpha: float = 0.02,
                 k_max: float = 2000.0):
        if objective not in ("thesis", "physical"):
            raise UserError(f"objective must be 'thesis' or 'physical', got {objective!r}")
        if not 2 <= degree <= 12:
            raise UserError(f"Bezier degree must be between 2 and 12, got {degree}")
        self.arm = arm
        self.degree = degree
        self.objective = objective
        self.mesh = ChebPieces(np.linspace(0.0, 1.0, pieces + 1), nodes)
        self.margin = self._margin = margin
        self.reach = reach
        self.min_alpha = min_alpha
        n = degree + 1
        reach_len = arm.l1 + arm.l2 + arm.l3
        lim = arm.limits
        self.lower = np.concatenate([np.full(n, max(lim["lower"][0], Q1_MIN_EQ_4_5)), np.full(n, lim["lower"][1]),
                                     [-reach_len, -reach_len, -math.pi / 6, 0.0]])
        self.upper = np.concatenate([np.full(n, lim["upper"][0]), np.full(n, lim["upper"][1]),
                                     [reach_len, reach_len, math.pi / 2, k_max]])
        self.scale = np.concatenate([np.ones(2 * n), [1.0, 1.0, 1.0, 100.0]])
        x_nodes, vinv, _ = _cheb_tables(nodes)
        x_fine = np.linspace(-1.0, 1.0, 4 * nodes)
        self._fine = npcheb.chebvander(x_fine, nodes - 1) @ vinv      # node values -> fine-grid values
        self.evaluations = 0
        self._best: Tuple[float, Optional[np.ndarray]] = (-np.inf, None)
        self._deadline = np.inf
        self._max_evaluations = np.inf
        self._t0 = time.monotonic()
        self.history: List[Tuple[float, float]] = []     # (seconds into the run, best feasible distance)
        self.evaluation_history: List[Tuple[int, float]] = []

    # ------------------------------------------------------------------ vectors
    def to_vector(self, spec: ThrowSpec) -> np.ndarray:
        spec = spec.elevated(self.degree)
        return np.concatenate([spec.a, spec.b, [spec.theta_b, spec.theta_e, spec.psi, spec.k]])

    def to_spec(self, x: np.ndarray) -> ThrowSpec:
        n = self.degree + 1
        return ThrowSpec(float(x[2 * n]), float(x[2 * n + 1]), float(x[2 * n + 2]), float(x[2 * n + 3]),
                         tuple(x[:n]), tuple(x[n:2 * n]))

    # ------------------------------------------------------------------ evaluation
    def evaluate(self, X: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
        """Distances (B,) and constraint values (B, C) (feasible when all >= 0) for throws X (B, D)."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        n = self.degree + 1
        B = X.shape[0]
        self.evaluations += B
        self._report_by_clock(self.evaluations / self._max_evaluations, f"{self.evaluations} evaluations")
        thb = X[:, 2 * n:2 * n + 1]
        the = np.maximum(X[:, 2 * n + 1:2 * n + 2], thb + 1e-3)
        batch = _Batch(X[:, :n], X[:, n:2 * n], thb, the, X[:, 2 * n + 2:2 * n + 3], X[:, 2 * n + 3:2 * n + 4],
                       np.zeros((B, 1)), np.ones((B, 1)))
        arm, lim, m = self.arm, self.arm.limits, self.margin
        shape = (B,) + self.mesh.nodes.shape
        with np.errstate(all="ignore"):
            sol = _integrate(arm, batch, self.mesh, with_time=False, strict=False, clip=0.99999)
            st = sol.state
            Y = sol.Y
            Yc = np.maximum(Y, 0.0)
            dq = st.dq.reshape((3,) + shape)
            a3 = st.alpha[2].reshape(shape)
            thdd = -(st.beta[2].reshape(shape) * Yc + st.gamma[2].reshape(shape)) / a3
            tau = (st.alpha[:2].reshape((2,) + shape) * thdd + st.beta[:2].reshape((2,) + shape) * Yc
                   + st.gamma[:2].reshape((2,) + shape))
            funcs = [1.0 - (st.u.reshape(shape) / self.reach) ** 2,
                     1.0 - (st.q[2].reshape(shape) / lim["upper"][2]) ** 2]
            funcs += [1.0 - dq[i] ** 2 * Yc / (m * lim["speed"][i]) ** 2 for i in range(3)]
            funcs += [1.0 - tau[i] ** 2 / (m * lim["torque"][i]) ** 2 for i in range(2)]
            # keeps moving forward: Y / sigma^2 > 0 (at sigma = 0 its limit Y'(theta_b) (theta_e - theta_b))
            Z = Y / self.mesh.nodes ** 2
            Z[:, 0, 0] = (-2.0 * st.gamma[2].reshape(shape) / a3)[:, 0, 0] * (the - thb)[:, 0]
            funcs.append(Z - 1e-3)
            funcs.append(np.sign(a3[:, :1, :1]) * a3 - self.min_alpha)  # alpha keeps its sign
            # the smallest value of each constraint per piece, from its interpolant on a fine grid
            cons = [_smooth_min(np.einsum("fp,bkp->bkf", self._fine, f)) for f in funcs]
            cons.append(X[:, 2 * n + 1:2 * n + 2] - thb - 0.05)     # theta_e - theta_b >= 5 cm
            C = np.concatenate(cons, axis=1)
            thd_e = np.sqrt(Yc[:, -1, -1])
            qe = st.q[:, :, -1]
            pos = arm.ball_position(qe)
            if self.objective == "thesis":
                psi = batch.psi[:, 0]
                vel = np.stack([thd_e * np.cos(psi), thd_e * np.sin(psi)])
            else:
                vel = arm.ball_velocity(qe, st.dq[:, :, -1] * thd_e)
            dist = _landing(arm, pos, vel)
        bad = ~np.isfinite(dist) | ~np.all(np.isfinite(C), axis=1)
        dist = np.where(bad, -10.0, dist)
        C = np.where(bad[:, None], -1.0, C)
        ok = np.all(C >= -1e-7, axis=1)
        if ok.any():
            j = int(np.argmax(np.where(ok, dist, -np.inf)))
            if dist[j] > self._best[0]:
                self._best = (float(dist[j]), X[j].copy())
                self.history.append((time.monotonic() - self._t0, float(dist[j])))
                self.evaluation_history.append((self.evaluations, float(dist[j])))
        return dist, C

    def _local(self, x0: np.ndarray, maxiter: int = 150) -> None:
        """SLSQP from x0 with forward-difference gradients computed in one batched evaluation."""
        from scipy.optimize import minimize

        h = 1e-7
        cache: Dict[bytes, tuple] = {}

        def full(z):
            key = z.tobytes()
            if key not in cache:
                if self._out_of_budget(z.size + 1):
                    raise _Timeout
                x = z * self.scale
                dist, C = self.evaluate(np.vstack([x, x + np.diag(h * self.scale)]))
                cache.clear()
                cache[key] = (-dist[0], -(dist[1:] - dist[0]) / h, C[0], ((C[1:] - C[0]) / h).T)
            return cache[key]

        bounds = list(zip(self.lower / self.scale, self.upper / self.scale))
        z0 = np.clip(x0, self.lower, self.upper) / self.scale
        try:
            minimize(lambda z: full(z)[0], z0, jac=lambda z: full(z)[1], method="SLSQP", bounds=bounds,
                     constraints=[{"type": "ineq", "fun": lambda z: full(z)[2], "jac": lambda z: full(z)[3]}],
                     options={"maxiter": maxiter, "ftol": 1e-10})
        except _Timeout:
            pass

    def _report_by_clock(self, fraction: float, message: str) -> None:
        """During ``run``: report progress at most every 0.2 s (by the clock: the search itself
        never depends on it; the report may stop the run by raising)."""
        if self._progress is not None and time.monotonic() - self._reported > 0.2:
            self._reported = time.monotonic()
            self._progress(fraction, message)

    def _out_of_budget(self, next_batch: int = 0) -> bool:
        """The evaluation budget would be exceeded by the next batch, or the optional time cap passed."""
        if time.monotonic() > self._deadline:
            self._time_capped = True
            return True
        return self.evaluations + next_batch > self._max_evaluations

    def candidates(self, rng: np.random.Generator, count: int, release_pose: np.ndarray) -> np.ndarray:
        """Random joint-space swings from rest to near ``release_pose``, written as Bezier VHCs, and the
        thesis's throws one and two (the global stage's pool)."""
        n = self.degree + 1
        s = np.linspace(0.0, 1.0, 60)
        lim = self.arm.limits
        out = [self.to_vector(thesis_throw(name)) for name in ("throw1", "throw2")]
        tries = 0
        while len(out) < count and tries < 20 * count:
            tries += 1
            self._report_by_clock(0.0, f"global stage: {len(out)} of {count} swings drawn")
            q_end = release_pose + rng.normal(0.0, [0.15, 0.15, 0.2])
            q_start = np.array([rng.uniform(q_end[0] + 0.2, lim["upper"][0] - 0.5), rng.uniform(-0.3, 1.2),
                                rng.uniform(-0.5, 1.2)])
            w = s ** rng.uniform(0.7, 1.5)
            bump = rng.normal(0.0, 0.2, 3)[:, None] * np.sin(np.pi * s)[None, :]
            Q = q_start[:, None] * (1 - w) + q_end[:, None] * w + bump
            psi = math.radians(rng.uniform(5.0, 30.0))
            theta = self.arm.theta_of_q(Q, psi)
            if np.any(np.diff(theta) <= 0):
                continue
            basis = bernstein(n - 1, (theta - theta[0]) / (theta[-1] - theta[0]))
            a = np.linalg.lstsq(basis, Q[0], rcond=None)[0]
            b = np.linalg.lstsq(basis, Q[1], rcond=None)[0]
            k = math.exp(rng.uniform(math.log(5.0), math.log(self.upper[-1])))
            out.append(np.clip(np.concatenate([a, b, [theta[0], theta[-1], psi, k]]), self.lower, self.upper))
        return np.array(out)

    def run(self, seed: int = 0, evaluations: int = DEFAULT_EVALUATIONS, max_seconds: Optional[float] = None,
            candidates: int = 4000, starts: int = 16, stop_within: float = 0.002,
            progress: Progress = None, bound: Optional[SpeedBound] = None) -> OptimizationResult:
        """Global stage, then SLSQP from the best distinct candidates until ``evaluations`` throw
        evaluations are spent or the best throw is within ``stop_within`` (relative) of the speed-limit
        bound, which no throw can beat. The budget is counted in evaluations, so the same seed gives the
        same throw on any machine; ``max_seconds`` is an optional extra cap (``time_capped`` says when
        it ended the search, and the result then depends on the machine's speed). ``bound``: a speed-limit
        bound computed before (same objective and seed), to save its computation."""
        if not evaluations > 0:
            raise UserError(f"the evaluation budget must be positive (got {evaluations})")
        if max_seconds is not None and not max_seconds > 0:
            raise UserError(f"the time cap must be positive seconds (got {max_seconds})")
        t0 = self._t0 = time.monotonic()
        self._deadline = t0 + max_seconds if max_seconds is not None else np.inf
        self._max_evaluations = evaluations
        self._time_capped = False
        self.evaluations = 0
        self.history = []
        self.evaluation_history = []
        self.margin = self._margin
        self._best = (-np.inf, None)
        rng = np.random.default_rng(seed)

        def report(frac, msg):
            if progress:
                progress(min(frac, 0.99), msg)

        report(0.0, "speed-limit bound")
        if bound is None or bound.convention != self.objective:
            bound = speed_limit_bound(self.arm, self.objective, seed=seed,
                                      progress=lambda f, m: report(0.02 * f, m))
        self._reported = time.monotonic()
        self._progress = report if progress else None
        try:
            pool = self.candidates(rng, candidates, bound.q)
            pool = pool[:max(1, min(len(pool), evaluations))]        # the global stage fits in the budget too
            scores = np.full(len(pool), -np.inf)
            for i in range(0, len(pool), 250):
                if i and self._out_of_budget(0):
                    break
                dist, C = self.evaluate(pool[i:i + 250])
                scores[i:i + 250] = dist + 20.0 * np.sum(np.minimum(C, 0.0), axis=1)
            report(self.evaluations / evaluations, f"global stage: {int(np.isfinite(scores).sum())} candidates scored")
            chosen: List[np.ndarray] = []
            span = self.upper - self.lower
            for j in np.argsort(-scores):
                if not np.isfinite(scores[j]):
                    break
                if all(np.max(np.abs(pool[j] - c) / span) > 0.02 for c in chosen):
                    chosen.append(pool[j])
                if len(chosen) >= starts:
                    break
            runs = 0
            for x0 in chosen:
                if self._out_of_budget(len(x0) + 1) or self._best[0] >= (1.0 - stop_within) * bound.distance_from_base:
                    break
                self._local(x0)
                runs += 1
                best = f"best {self._best[0]:.4f} m" if self._best[1] is not None else "no feasible throw yet"
                report(self.evaluations / evaluations, f"local run {runs}/{len(chosen)}, {self.evaluations} evaluations: {best}")
            if self._best[1] is None:
                raise VHCError("the optimizer found no throw that satisfies every constraint; raise the budget")
            for _attempt in range(4):   # dense verification; tighten the margin if something slipped between nodes
                best = self._best[1]
                spec = self.to_spec(best)
                throw = self.arm.solve(spec)
                feas = throw.check(q1_min=Q1_MIN_EQ_4_5)
                if feas.feasible:
                    break
                self.margin *= 0.995
                self._best = (-np.inf, None)
                self._deadline = np.inf      # the repair is bounded by evaluations only
                self._max_evaluations = self.evaluations + max(2000, evaluations // 10)
                self._local(best)
                if self._best[1] is None:
                    self._best = (-np.inf, best)
            rel = throw.release
            d = rel.distance_from_base_thesis if self.objective == "thesis" else rel.distance_from_base
        finally:
            self._progress = None           # a cancelled or failed run leaves no report behind
        if progress:
            progress(1.0, f"best {d:.4f} m from the base")
        return OptimizationResult(spec, throw, feas, self.objective, float(d), bound, self.evaluations, runs,
                                  time.monotonic() - t0, list(self.history), evaluations, self._time_capped,
                                  list(self.evaluation_history))


# ====================================================================== the thesis, reproduced
#: Table 3.1 as printed: release angle [deg] -> distance [m], 30 m cliff, the text says 5 m/s.
TABLE_3_1 = {45: 7.8578, 30: 9.3025, 25: 9.6120, 20: 9.8348, 15: 9.9718, 10: 10.0250, 5: 9.9974, 0: 9.8924}


def thesis_comparison(arm: Optional[ThrowingArm] = None) -> List[dict]:
    """Every number of the thesis that the lab recomputes: rows {quantity, thesis, lab, note}.

    Distances from the thesis's own release speeds use its convention (speed theta_dot along psi,
    release height from eq. 3.1 plus the 0.63 m platform); the dynamic ones use the robot file's
    mass model (reading B of Appendix A).
    """
    from .ballistics import angle_table

    arm = arm or ThrowingArm()
    rows: List[dict] = []

    def row(quantity, thesis, lab, note=""):
        rows.append({"quantity": quantity, "thesis": thesis, "lab": lab, "note": note})

    at4 = angle_table(4.0, 30.0, list(TABLE_3_1))
    at5 = angle_table(5.0, 30.0, list(TABLE_3_1))
    for (angle, printed), d4, d5 in zip(TABLE_3_1.items(), at4, at5):
        row(f"Table 3.1, {angle} deg [m]", printed, round(d4, 5),
            f"with v = 4 m/s; the text's 5 m/s would give {d5:.4f} m")
    est = hand_estimate(arm)
    rounded = hand_estimate(arm, speed=4.18)
    row("hand estimate: ball speed, arm straight, joints at their limits [m/s]", 4.18, round(est.speed, 4))
    row("hand estimate: distance from the base at 14 deg with 4.18 m/s [m]", 2.75,
        round(rounded.distance_from_base, 4),
        f"platform included; with {est.speed:.4f} m/s it is {est.distance_from_base:.4f} m, and the best "
        f"angle is {est.best_angle_deg:.1f} deg ({est.best_distance:.4f} m)")
    for name in ("throw1", "throw2", "throw3"):
        cfg = load_throw_config(name)
        rep = cfg.thesis
        label = name.replace("throw", "throw ")
        try:
            throw = arm.solve(cfg.spec)
        except VHCError as exc:
            row(f"{label}: theta_dot at release [m/s]", rep["theta_dot_e"], None, f"rejected: {exc}")
            continue
        rel = arm.release(cfg.spec, rep["theta_dot_e"])
        ratios = np.abs(rel.dq) / arm.limits["speed"]
        if name == "throw2":
            row(f"{label}: release point x_r [m]", -0.365, round(float(rel.position[0]), 5), "kinematics only")
        if "distance_from_base" in rep:
            row(f"{label}: distance from the base, thesis's theta_dot [m]", rep["distance_from_base"],
                round(rel.distance_from_base_thesis, 4),
                f"thesis convention; with the true ball velocity J(q) q' it is {rel.distance_from_base:.4f} m")
            row(f"{label}: distance from the release point, thesis's theta_dot [m]", rep["distance_from_release"],
                round(rel.distance_from_release_thesis, 4), "thesis convention")
        row(f"{label}: joint speeds at release with the thesis's theta_dot [limit]", None,
            [round(float(r), 4) for r in ratios], "fractions of the Table A.2 limits")
        row(f"{label}: theta_dot at release [m/s]", rep["theta_dot_e"], round(throw.theta_dot_e, 4),
            "reduced dynamics with reading B; the thesis's value cannot be reproduced by any reading")
        row(f"{label}: duration [s]", rep["duration"], round(throw.duration, 4), "reading B")
    return rows
