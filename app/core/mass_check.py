"""A robot file's inertia matrix M(q) computed numerically from the file alone (no derivation), to
refuse files whose M(q) is singular: a body with its mass on its joint's axis and no inertia about
it, a chain of massless links. ``singular_directions`` is called by ``parse_robot`` at the file's
default parameter values; it costs a few milliseconds.

M(q) = sum over bodies of m J_c^T J_c + J_w^T R I R^T J_w, plus the rotor inertias of the motors,
with the Jacobians of each body's CoM (J_c) and angular velocity (J_w) built by walking the chain
in numbers. Masses are non-negative and inertia tensors positive semi-definite (checked before), so
M(q) is positive semi-definite; it is singular at a random configuration only when it is singular
at almost every configuration, which is what the check looks for.

>>> from app.core.robot import load_robot
>>> robot = load_robot("planar_2r")
>>> values = {p.symbol: p.value for p in robot.parameters.values()}
>>> M = mass_matrix(robot, values, [0.3, -0.2])
>>> from app.core.numeric import NumericModel
>>> bool(np.allclose(M, NumericModel(robot).M([0.3, -0.2]), rtol=1e-12, atol=1e-12))
True
"""
from __future__ import annotations

import math
from typing import Dict, List, Mapping, Optional, Sequence

import numpy as np
import sympy as sp

from .robot_model import RobotModel, Transform

# M(q) counts as singular when its smallest eigenvalue is below this fraction of its largest.
RELATIVE_TOLERANCE = 1e-10


def _skew(v: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def _rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    ux = _skew(axis)
    return np.eye(3) + math.sin(angle) * ux + (1.0 - math.cos(angle)) * (ux @ ux)


def _number(expr, values) -> float:
    return float(sp.sympify(expr).xreplace(values))


class _Numbers:
    """The robot's constant parts in numbers, and its joint variables and their gradients."""

    def __init__(self, robot: RobotModel, values: Mapping[sp.Symbol, float]):
        self.robot = robot
        q = robot.q
        self.q = q

        def tf(t: Transform):
            return (np.array(t.R.xreplace(values), dtype=float),
                    np.array([_number(e, values) for e in t.p], dtype=float))

        self.bodies = []
        for body in robot.bodies:
            j = body.joint
            axis = np.array([float(a) for a in j.axis], dtype=float)
            grad = [sp.diff(j.value, qk) for qk in q]
            self.bodies.append(dict(
                name=body.name, parent=body.parent, type=j.type, axis=axis, value=j.value, grad=grad,
                pre=tf(j.pre), post=tf(j.post), mass=_number(body.mass, values),
                com=np.array([_number(e, values) for e in body.com], dtype=float),
                inertia=np.array(body.inertia.xreplace(values), dtype=float)))
        self.motors = [(robot.coordinates.index(c), _number(i, values)) for c, i in robot.motor_inertias.items()]

    def mass_matrix(self, qv: Sequence[float]) -> np.ndarray:
        n = self.robot.n
        at = dict(zip(self.q, (float(x) for x in qv)))
        frames: Dict[Optional[str], tuple] = {None: (np.eye(3), np.zeros(3), np.zeros((3, n)), np.zeros((3, n)))}
        M = np.zeros((n, n))

        def move(frame, R_t, p_t):
            """The frame followed by a constant transform: orientation, origin and their Jacobians."""
            R, p, Jp, Jw = frame
            r = R @ p_t
            return R @ R_t, p + r, Jp - _skew(r) @ Jw, Jw

        for b in self.bodies:
            frame = move(frames[b["parent"]], *b["pre"])
            if b["type"] != "fixed":
                R, p, Jp, Jw = frame
                theta = _number(b["value"], at)
                dtheta = np.array([_number(g, at) for g in b["grad"]], dtype=float)
                a = R @ b["axis"]
                if b["type"] == "revolute":
                    frame = (R @ _rotation(b["axis"], theta), p, Jp, Jw + np.outer(a, dtheta))
                else:
                    frame = move(frame, np.eye(3), b["axis"] * theta)
                    R, p, Jp, Jw = frame
                    frame = (R, p, Jp + np.outer(a, dtheta), Jw)
            frame = move(frame, *b["post"])
            frames[b["name"]] = frame
            R, p, Jp, Jw = frame
            Jc = Jp - _skew(R @ b["com"]) @ Jw
            M += b["mass"] * (Jc.T @ Jc) + Jw.T @ (R @ b["inertia"] @ R.T) @ Jw
        for k, inertia in self.motors:
            M[k, k] += inertia
        return 0.5 * (M + M.T)


def mass_matrix(robot: RobotModel, values: Mapping[sp.Symbol, float], q: Sequence[float]) -> np.ndarray:
    """M(q) of ``robot`` with the parameter values ``values`` (symbol -> number)."""
    return _Numbers(robot, values).mass_matrix(q)


def configurations(robot: RobotModel, seed: int = 0, count: int = 3) -> List[np.ndarray]:
    """q = 0 and ``count`` seeded random configurations (within the position limits, else in
    [-pi, pi])."""
    rng = np.random.default_rng(seed)
    return [np.zeros(robot.n)] + [robot.random_configuration(rng) for _ in range(count)]


def singular_directions(robot: RobotModel, values: Mapping[sp.Symbol, float]) -> Optional[str]:
    """None when M(q) is positive definite at one of the checked configurations (q = 0 and three
    seeded random ones); else what is wrong, naming the joints whose motion moves no mass."""
    numbers = _Numbers(robot, values)
    worst = None
    for q in configurations(robot):
        M = numbers.mass_matrix(q)
        if not np.all(np.isfinite(M)):
            worst = worst or (q, None)
            continue
        eigenvalues, vectors = np.linalg.eigh(M)
        top = float(np.abs(eigenvalues).max())
        if top > 0 and eigenvalues[0] > RELATIVE_TOLERANCE * top:
            return None
        worst = worst if worst is not None else (q, vectors[:, 0])
    q, vector = worst
    shown = "(" + ", ".join(f"{x:.3g}" for x in q) + ")"
    if vector is None:
        return f"the inertia matrix M(q) is not finite at q = {shown}"
    big = np.abs(vector) > 0.1 * np.abs(vector).max()
    coords = [c for c, on in zip(robot.coordinates, big) if on]
    joints = []
    for c in coords:
        sym = robot.q[robot.coordinates.index(c)]
        owners = [b.name for b in robot.bodies if sym in b.joint.value.free_symbols]
        joints.append(f"{c} (joint of {', '.join(owners)})" if owners else c)
    if len(joints) > 3:
        joints = joints[:3] + [f"{len(joints) - 3} more"]
    moving = " and ".join(joints) + (" together" if len(joints) > 1 else "")
    return (f"M(q) is singular at the default parameter values (at q = {shown} and 3 random q): moving "
            f"{moving} moves no mass and no inertia; give a body a mass off that joint's axis or an inertia about it")
