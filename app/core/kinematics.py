"""Symbolic forward kinematics of a RobotModel: body frames, CoM positions, angular velocities,
point Jacobians. Rotations about the same axis are merged, so planar chains come out with
``cos(q1 + q2)`` rather than products of sines and cosines.

>>> from app.core.robot import load_robot
>>> kin = Kinematics(load_robot("planar_2r"))
>>> kin.com_position("link2")[0]
d2*cos(q1 + q2) + l1*cos(q1)
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import Dict, List, Optional, Tuple

import sympy as sp

from .robot import Body, RobotModel, Transform, elementary_rotation


@dataclass
class Frame:
    """A symbolic frame: elementary rotations (merged when about the same axis) or a generic R, and
    the origin p, both in base coordinates."""
    rotations: Optional[List[Tuple[tuple, sp.Expr]]]
    generic: Optional[sp.Matrix]
    p: sp.Matrix

    @staticmethod
    def base() -> "Frame":
        return Frame([], None, sp.zeros(3, 1))

    @property
    def R(self) -> sp.Matrix:
        if self.rotations is None:
            return self.generic
        R = sp.eye(3)
        for axis, angle in self.rotations:
            R = R * elementary_rotation(axis, angle)
        return R

    def rotate(self, axis, angle) -> "Frame":
        if self.rotations is None or not isinstance(axis, tuple):
            return Frame(None, self.R * elementary_rotation(axis, angle), self.p)
        rots = list(self.rotations)
        if rots and rots[-1][0] == axis:
            rots[-1] = (axis, rots[-1][1] + angle)
        elif rots and rots[-1][0] == tuple(-a for a in axis):
            rots[-1] = (rots[-1][0], rots[-1][1] - angle)
        else:
            rots.append((axis, angle))
        return Frame(rots, None, self.p)

    def translate(self, t: sp.Matrix) -> "Frame":
        if all(e == 0 for e in t):
            return self
        return Frame(self.rotations, self.generic, self.p + self.R * t)

    def apply(self, tf: Transform) -> "Frame":
        out = self.translate(tf.p)
        if tf.rotations is None:
            return Frame(None, out.R * tf.R, out.p)
        for axis, angle in tf.rotations:
            out = out.rotate(axis, angle)
        return out

    def point(self, local: sp.Matrix) -> sp.Matrix:
        return self.p + self.R * local


def _tidy(expr):
    return sp.expand(expr)


class Kinematics:
    """Frames and velocities of every body of a robot, computed once and cached."""

    def __init__(self, robot: RobotModel):
        self.robot = robot
        self.q = robot.q
        self.dq = robot.dq

    @cached_property
    def frames(self) -> Dict[str, Dict[str, Frame]]:
        """For each body: 'joint' (frame where the joint moves, before the motion) and 'body'."""
        out: Dict[str, Dict[str, Frame]] = {}
        for body in self.robot.bodies:
            parent = Frame.base() if body.parent is None else out[body.parent]["body"]
            j = body.joint
            before = parent.apply(j.pre)
            if j.type == "revolute":
                moved = before.rotate(j.axis, j.value)
            elif j.type == "prismatic":
                moved = before.translate(sp.Matrix(j.axis) * j.value)
            else:
                moved = before
            out[body.name] = {"joint": before, "body": moved.apply(j.post)}
        return out

    def body_frame(self, name: str) -> Frame:
        return self.frames[name]["body"]

    def rotation(self, name: str) -> sp.Matrix:
        return self.body_frame(name).R.applyfunc(_tidy)

    def point_position(self, body: Optional[str], local: sp.Matrix) -> sp.Matrix:
        if body is None:
            return sp.Matrix(local)
        return self.body_frame(body).point(sp.Matrix(local)).applyfunc(_tidy)

    def com_position(self, name: str) -> sp.Matrix:
        return self.point_position(name, self.robot.body(name).com)

    def joint_axis(self, name: str) -> Tuple[sp.Matrix, sp.Matrix]:
        """World position and unit direction of a body's joint axis."""
        frame = self.frames[name]["joint"]
        return frame.p.applyfunc(_tidy), (frame.R * sp.Matrix(self.robot.body(name).joint.axis)).applyfunc(_tidy)

    def parallel_revolute_axes(self) -> bool:
        """True when every revolute joint turns about one fixed direction of the base (planar
        chains, SCARA arms): the links' angles are then sums of the coordinates.

        >>> from app.core.robot import load_robot
        >>> Kinematics(load_robot("planar_2r")).parallel_revolute_axes()
        True
        """
        directions = [self.joint_axis(b.name)[1] for b in self.robot.bodies if b.joint.type == "revolute"]
        if any(e.free_symbols for d in directions for e in d):
            return False
        return all(d.cross(directions[0]).is_zero_matrix for d in directions[1:])

    def point_jacobian(self, body: Optional[str], local: sp.Matrix) -> sp.Matrix:
        """Linear-velocity Jacobian (3 x n) of a point fixed in a body."""
        p = self.point_position(body, local)
        return p.jacobian(sp.Matrix(self.q)).applyfunc(_tidy)

    def angular_jacobian(self, name: str, in_body_frame: bool = False) -> sp.Matrix:
        """Angular-velocity Jacobian (3 x n) of a body, in base or body coordinates."""
        n = len(self.q)
        J = sp.zeros(3, n)
        for body in self.robot.chain(name):
            if body.joint.type != "revolute":
                continue
            frame = self.frames[body.name]["joint"]
            axis = frame.R * sp.Matrix(body.joint.axis)
            grad = [sp.diff(body.joint.value, qk) for qk in self.q]
            for k in range(n):
                if grad[k] != 0:
                    J[:, k] += axis * grad[k]
        if in_body_frame:
            J = self._body_angular_jacobian(name)
        return J.applyfunc(_tidy)

    def _body_angular_jacobian(self, name: str) -> sp.Matrix:
        """Moving-frames recursion: ^i J_i = R_rel^T (^(i-1) J_(i-1) + axis * dvalue/dq), using only
        relative rotations so that the entries stay compact."""
        cache = self.__dict__.setdefault("_body_jw", {})
        if name in cache:
            return cache[name]
        body = self.robot.body(name)
        n = len(self.q)
        J = sp.zeros(3, n) if body.parent is None else self._body_angular_jacobian(body.parent)
        j = body.joint
        J = j.pre.R.T * J
        rel = Frame.base()
        if j.type == "revolute":
            grad = sp.Matrix([[sp.diff(j.value, qk) for qk in self.q]])
            J = J + sp.Matrix(j.axis) * grad
            rel = rel.rotate(j.axis, j.value)
        rel = rel.apply(j.post)
        J = (rel.R.T * J).applyfunc(_tidy)
        cache[name] = J
        return J

    def body_angular_velocity(self, name: str) -> sp.Matrix:
        """Angular velocity of a body in its own frame (the 'moving frames' quantity ^i omega_i)."""
        return (self.angular_jacobian(name, in_body_frame=True) * sp.Matrix(self.dq)).applyfunc(_tidy)

    def com_velocity(self, name: str) -> sp.Matrix:
        return (self.point_jacobian(name, self.robot.body(name).com) * sp.Matrix(self.dq)).applyfunc(_tidy)
