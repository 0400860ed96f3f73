"""Dimensional analysis of a robot's symbols (for app/core/answer_check.py): the (mass, length,
time) exponents of a unit string, of each parameter and coordinate, and of a product term."""

from __future__ import annotations

import re
from typing import Dict, Optional, Tuple

import sympy as sp

from .expressions import symbol


_UNIT_DIMS = {"kg": (1, 0, 0), "g": (1, 0, 0), "m": (0, 1, 0), "cm": (0, 1, 0), "mm": (0, 1, 0), "s": (0, 0, 1),
              "N": (1, 1, -2), "J": (1, 2, -2), "W": (1, 2, -3), "rad": (0, 0, 0), "deg": (0, 0, 0)}
_KIND_DIMS = {"mass": (1, 0, 0), "length": (0, 1, 0), "com": (0, 1, 0), "inertia": (1, 2, 0),
              "gravity": (0, 1, -2), "angle": (0, 0, 0)}
Dim = Tuple[float, float, float]


def unit_dimension(unit: str) -> Optional[Dim]:
    """(mass, length, time) exponents of a unit string such as ``kg m^2`` or ``N m/rad``.

    >>> unit_dimension("kg m^2"), unit_dimension("m/s^2"), unit_dimension("N m/rad")
    ((1, 2, 0), (0, 1, -2), (1, 2, -2))
    """
    unit = unit.strip()
    if not unit:
        return None
    total = [0, 0, 0]
    for k, part in enumerate(unit.split("/")):
        sign = 1 if k == 0 else -1
        for factor in part.replace("*", " ").replace("·", " ").split():
            m = re.fullmatch(r"([A-Za-z]+)(?:\^?(-?\d+))?", factor)
            if not m or m.group(1) not in _UNIT_DIMS:
                return None
            power = int(m.group(2) or 1) * sign
            for i, e in enumerate(_UNIT_DIMS[m.group(1)]):
                total[i] += e * power
    return tuple(total)


def unit_text(dim: Dim) -> str:
    names = ("kg", "m", "s")
    parts = []
    for n, e in zip(names, dim):
        if e:
            power = int(e) if float(e).is_integer() else e
            parts.append(rf"\mathrm{{{n}}}" + ("" if power == 1 else f"^{{{power}}}"))
    return r"\,".join(parts) if parts else r"\text{no unit}"


class Dimensions:
    """Dimensions of the symbols of a robot: parameters from their units (or kinds), revolute
    coordinates dimensionless, prismatic ones lengths, velocities and accelerations per second."""

    def __init__(self, robot, dyn=None):
        self.dims: Dict[sp.Symbol, Dim] = {}
        for p in robot.parameters.values():
            d = unit_dimension(p.unit) if p.unit else None
            d = d if d is not None else _KIND_DIMS.get(p.kind)
            if d is not None:
                self.dims[p.symbol] = d
        angles = _angle_coordinates(robot, dyn)
        for c in robot.coordinates:
            base = (0, 0, 0) if c in angles else (0, 1, 0)
            for prefix, t in (("", 0), ("d", -1), ("dd", -2)):
                for suffix in ("", "_r"):
                    if prefix or not suffix:
                        self.dims[symbol(prefix + c + suffix)] = (base[0], base[1], base[2] + t)
        self.dims[symbol("t")] = (0, 0, 1)

    def of(self, expr) -> Optional[Dim]:
        """Dimension of a product term (None when unknown or inconsistent)."""
        expr = sp.sympify(expr)
        if expr.is_number:
            return (0, 0, 0)
        if expr.is_Symbol:
            return self.dims.get(expr)
        if expr.is_Mul:
            total = [0.0, 0.0, 0.0]
            for f in expr.args:
                d = self.of(f)
                if d is None:
                    return None
                total = [a + b for a, b in zip(total, d)]
            return tuple(total)
        if expr.is_Pow and expr.exp.is_number:
            d = self.of(expr.base)
            return None if d is None else tuple(float(expr.exp) * e for e in d)
        if expr.is_Add:
            dims = {self.of(a) for a in expr.args}
            return dims.pop() if len(dims) == 1 else None
        if isinstance(expr, (sp.sin, sp.cos, sp.tan, sp.exp, sp.log, sp.sign)):
            return (0, 0, 0)
        if isinstance(expr, sp.Abs):
            return self.of(expr.args[0])
        return None


def _angle_coordinates(robot, dyn) -> set:
    """Coordinates that appear inside a sine or cosine of the kinematics (revolute ones)."""
    types = {}
    for b in robot.bodies:
        jt = getattr(b.joint, "type", None)
        coord = getattr(b.joint, "coordinate", None)
        if coord is not None and jt in ("revolute", "prismatic"):
            types[str(coord)] = jt
    angles = {c for c, t in types.items() if t == "revolute"}
    if dyn is not None:
        for p in dyn.com_positions.values():
            for f in sp.Matrix(p).atoms(sp.sin, sp.cos):
                angles |= {s.name for s in f.free_symbols if s.name in robot.coordinates}
    return angles
