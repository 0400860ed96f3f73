"""Jacobians of points and links, symbolic and numeric, and their singularity analysis.

A *task function* r(q) is a column of expressions of the coordinates: the position components of a
point fixed in a link (``x``, ``y``, ``z``), the planar orientation of a link (``angle``, the sum of
the rotations about the plane normal), or any expression. Its analytic Jacobian is dr/dq; the
geometric Jacobian of a link stacks the linear velocity Jacobian of a point and the angular one.
Numeric values come from lambdified functions with the robot's parameters (file defaults, overridden
by an exercise's data).

Singularity analysis works on a numeric matrix: singular values, rank with an explicit absolute
threshold, an orthonormal basis of the null space (joint motions that leave the task still: self
motions) and of the left null space (task directions that cannot be produced; forces balanced by the
structure with zero joint torques, since J^T F = 0), and the manipulability sqrt(det(J J^T)).

>>> from app.core.robot import load_robot
>>> robot = load_robot("planar_2r")
>>> r = task_function(robot, point="ee", components=("x", "y"))
>>> J = analytic_jacobian(robot, r)
>>> J[0, 1]
-l2*sin(q1 + q2)
>>> Jn = evaluate(robot, J, [0.0, 1.5707963267948966], {"l1": 1.0, "l2": 1.0})
>>> (np.round(Jn, 6) + 0.0).tolist()         # + 0.0 turns a rounded -0.0 into 0.0
[[-1.0, -1.0], [1.0, 0.0]]
>>> analyze(Jn).rank
2
"""
from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations
from typing import Dict, List, Mapping, Optional, Sequence, Tuple

import numpy as np
import sympy as sp

from .errors import UserError
from .kinematics import Kinematics
from .numeric import compiled_model
from .robot import RobotModel
from .trig import TrigPoly

#: singular values at or below this absolute threshold count as zero (see ``analyze``)
DEFAULT_THRESHOLD = 1e-9

COMPONENTS = ("x", "y", "z", "angle", "wx", "wy", "wz")


class JacobianError(UserError):
    """A task or Jacobian request does not make sense for the robot."""


def _kinematics(robot: RobotModel) -> Kinematics:
    """The robot's symbolic kinematics, kept by its compiled model (one per robot content)."""
    return compiled_model(robot).kinematics


def point_location(robot: RobotModel, point) -> Tuple[Optional[str], sp.Matrix]:
    """(body, local position) of a named point or of ``{"body": name, "at": [x, y, z]}``."""
    if isinstance(point, str):
        if point in robot.points:
            pt = robot.points[point]
            return pt.body, pt.position
        raise JacobianError(f"robot {robot.name} has no point '{point}' (points: {', '.join(robot.points) or 'none'})")
    if isinstance(point, dict) and "body" in point:     # 'at' may use names of the exercise (l_c2)
        from .expressions import parse_expression
        at = point.get("at", [0, 0, 0])
        if not isinstance(at, (list, tuple)) or len(at) != 3:
            raise JacobianError(f"point 'at' must be a list of 3 numbers or expressions, got {at!r}")
        try:
            robot.body(point["body"])
        except KeyError as exc:
            raise JacobianError(str(exc).strip("'\"")) from None
        return point["body"], sp.Matrix([parse_expression(v) for v in at])
    raise JacobianError(f"a point is a name or {{body: ..., at: [x, y, z]}}, got {point!r}")


def planar_angle(robot: RobotModel, body: str) -> sp.Expr:
    """Orientation of a link of a planar robot: its rotation about the plane normal (z)."""
    frame = _kinematics(robot).body_frame(body)
    if frame.rotations is not None:
        angle = sp.Integer(0)
        for axis, value in frame.rotations:
            if tuple(axis) == (0, 0, 1):
                angle += value
            elif tuple(axis) == (0, 0, -1):
                angle -= value
            else:
                break
        else:
            return sp.expand(angle)
    R = frame.R
    return sp.atan2(R[1, 0], R[0, 0])


def task_function(robot: RobotModel, point=None, components: Sequence[str] = ("x", "y"),
                  body: Optional[str] = None) -> sp.Matrix:
    """r(q) for a point (or link, for angles): components among x, y, z, angle.

    ``angle`` is the planar orientation of the link holding the point (or ``body``)."""
    rows = []
    link, local = (None, None)
    if point is not None:
        link, local = point_location(robot, point)
    link = body or link
    for comp in components:
        if comp in ("x", "y", "z"):
            if local is None:
                raise JacobianError(f"component '{comp}' needs a point")
            rows.append(_kinematics(robot).point_position(link, local)["xyz".index(comp)])
        elif comp == "angle":
            if link is None:
                raise JacobianError("component 'angle' needs a link (a point or a body)")
            rows.append(planar_angle(robot, link))
        else:
            raise JacobianError(f"unknown task component '{comp}' for a task function (use x, y, z, angle)")
    return sp.Matrix(rows)


def analytic_jacobian(robot: RobotModel, r: sp.Matrix) -> sp.Matrix:
    """dr/dq (m x n)."""
    return sp.Matrix(r).jacobian(sp.Matrix(robot.q)).applyfunc(sp.expand)


def geometric_jacobian(robot: RobotModel, body: str, local=(0, 0, 0)) -> sp.Matrix:
    """6 x n geometric Jacobian (linear velocity of the point, angular velocity of the link)."""
    kin = _kinematics(robot)
    Jv = kin.point_jacobian(body, sp.Matrix(local))
    Jw = kin.angular_jacobian(body)
    return Jv.col_join(Jw)


def jacobian(robot: RobotModel, point=None, components: Sequence[str] = ("x", "y"),
             body: Optional[str] = None, frame: Optional[str] = None) -> sp.Matrix:
    """Jacobian rows for the listed components (x, y, z, angle, wx, wy, wz) of a point or link.

    With ``frame`` (a body name) the linear rows x, y, z are expressed in that body's frame
    (R^T J), as for contact forces written in link coordinates."""
    kin = _kinematics(robot)
    link, local = (None, None)
    if point is not None:
        link, local = point_location(robot, point)
    link = body or link
    lin = [c for c in components if c in ("x", "y", "z")]
    Jv = kin.point_jacobian(link, local) if lin else None
    if frame is not None and Jv is not None:
        Jv = (kin.rotation(frame).T * Jv).applyfunc(sp.expand)
        Jv = Jv.applyfunc(lambda e: TrigPoly.from_expr(e).to_expr())
    rows = []
    for comp in components:
        if comp in ("x", "y", "z"):
            rows.append(Jv.row("xyz".index(comp)))
        elif comp in ("angle", "wz", "wx", "wy"):
            if link is None:
                raise JacobianError(f"component '{comp}' needs a link")
            Jw = kin.angular_jacobian(link)
            rows.append(Jw.row({"wx": 0, "wy": 1}.get(comp, 2)))
        else:
            raise JacobianError(f"unknown Jacobian component '{comp}' (use {', '.join(COMPONENTS)})")
    return sp.Matrix.vstack(*rows).applyfunc(sp.expand)


def rotation(robot: RobotModel, body: str) -> sp.Matrix:
    """Rotation matrix of a body frame in base coordinates."""
    return _kinematics(robot).rotation(body)


# ---------------------------------------------------------------------- numeric evaluation
def evaluate(robot: RobotModel, expr, q: Sequence[float], values: Optional[Mapping[str, float]] = None) -> np.ndarray:
    """Numeric value of a symbolic expression/matrix of q at a configuration, with the robot's
    parameter values (defaults overridden by ``values``)."""
    params = robot.parameter_values({k: v for k, v in (values or {}).items() if k in robot.parameters})
    subs = {s: float(v) for s, v in zip(robot.q, q)}
    subs.update({sp.Symbol(k, real=True): float(v) for k, v in params.items()})
    out = sp.Matrix(expr).xreplace(subs) if isinstance(expr, sp.MatrixBase) else sp.sympify(expr).xreplace(subs)
    try:
        arr = np.array(sp.Matrix(out).evalf(), dtype=float) if isinstance(out, sp.MatrixBase) else float(out)
    except TypeError:
        free = sorted(str(s) for s in sp.sympify(out).free_symbols)
        raise JacobianError(f"cannot evaluate numerically: no value for {', '.join(free)}") from None
    return arr


# ---------------------------------------------------------------------- analysis
@dataclass
class SingularityAnalysis:
    singular_values: np.ndarray
    rank: int
    null_space: np.ndarray        # n x (n - rank), orthonormal columns (self motions)
    left_null_space: np.ndarray   # m x (m - rank), orthonormal columns (unreachable task directions)
    manipulability: float         # sqrt(det(J J^T)) (product of the singular values), 0 if rank < m
    threshold: float

    @property
    def singular(self) -> bool:
        """True when the rank is below the number of task rows."""
        return self.left_null_space.shape[1] > 0


def analyze(J, threshold: float = DEFAULT_THRESHOLD) -> SingularityAnalysis:
    """Rank, null spaces and manipulability of a numeric Jacobian (absolute threshold on the
    singular values).

    >>> a = analyze([[0, 0, 0, 0], [2, 1.5, 1, 0.5]])
    >>> a.rank, a.null_space.shape, np.round(np.abs(a.left_null_space.ravel()), 6).tolist()
    (1, (4, 3), [1.0, 0.0])
    """
    J = np.atleast_2d(np.asarray(J, dtype=float))
    m, n = J.shape
    U, s, Vt = np.linalg.svd(J)
    rank = int(np.sum(s > threshold))
    null = Vt[rank:].T.copy()
    left = U[:, rank:].copy()
    for B in (null, left):          # deterministic signs: first clearly nonzero entry positive
        for k in range(B.shape[1]):
            idx = np.flatnonzero(np.abs(B[:, k]) > 1e-12)
            if idx.size and B[idx[0], k] < 0:
                B[:, k] *= -1
            B[np.abs(B) < 1e-15] = 0.0
    manip = float(np.prod(s[:m])) if rank == m else 0.0
    return SingularityAnalysis(s, rank, null, left, manip, threshold)


def determinant_condition(J: sp.Matrix) -> sp.Expr:
    """det J (square) or det(J J^T) (wide), reduced to the exact trigonometric canonical form:
    the configurations where it vanishes are the singularities."""
    J = sp.Matrix(J)
    D = J.det(method="berkowitz") if J.rows == J.cols else (J * J.T).det(method="berkowitz")
    try:
        canonical = sp.factor(TrigPoly.from_expr(sp.expand(D)).to_expr())
    except Exception:
        return sp.simplify(D)
    forms = [canonical]
    if sp.count_ops(canonical) < 60:
        forms.append(sp.factor(sp.expand_trig(canonical)))
    return min(forms, key=sp.count_ops)


def column_minors(J) -> Dict[Tuple[int, ...], float]:
    """Determinants of the square submatrices of a wide numeric J obtained by deleting columns;
    keys are the 1-based indices of the deleted columns (J_{-i} in the exams)."""
    J = np.atleast_2d(np.asarray(J, dtype=float))
    m, n = J.shape
    out = {}
    for removed in combinations(range(n), n - m):
        keep = [j for j in range(n) if j not in removed]
        out[tuple(i + 1 for i in removed)] = float(np.linalg.det(J[:, keep]))
    return out


def manipulability(J) -> float:
    """sqrt(det(J J^T)) of a numeric Jacobian.

    >>> round(manipulability([[-1.0, -1.0], [1.0, 0.0]]), 6)
    1.0
    """
    J = np.atleast_2d(np.asarray(J, dtype=float))
    return float(np.sqrt(max(np.linalg.det(J @ J.T), 0.0)))
