"""Text input of a simulation, shared by the command line (app/commands/simulate.py) and the page's
Control tab: numbers and constant expressions (``0.1, -pi/4``), ``name=value`` lists, and forces and
surfaces written as ``'POINT F=fx,fy [M=m] [from=t0] [to=t1] [at=x,y,z]'`` or
``'POINT normal=nx,ny [offset=o] [k=.. d=..]'``. Bad text raises a SimulationError naming the option.
"""
from __future__ import annotations

import math
from typing import Dict, List, Optional, Union

import numpy as np  # noqa: F401 (doctests)

from .errors import SimulationError
from .expressions import ExpressionError, parse_number
from .sim_plant import PointForce, Surface


def parse_numbers(text: Optional[str], what: str) -> Optional[List[float]]:
    """'0.1, -pi/4' -> [0.1, -0.785...]; None for None; a UserError names ``what`` otherwise.

    >>> np.round(parse_numbers("1, pi/2", "--q0"), 6).tolist()
    [1.0, 1.570796]
    """
    if text is None:
        return None
    out = []
    for part in str(text).split(","):
        part = part.strip()
        if not part:
            continue
        try:
            out.append(parse_number(part))
        except (ExpressionError, TypeError) as exc:
            raise SimulationError(f"{what}: '{part}' is not a number ({exc})") from None
    if not out:
        raise SimulationError(f"{what}: no values given")
    return out


def parse_assignments(text: Optional[str], what: str) -> Dict[str, float]:
    """'m2=7, I2=0.3' -> {'m2': 7.0, 'I2': 0.3}.

    >>> parse_assignments("m2=7, d2=1/2", "--plant")        # exact: 1/2 is a float
    {'m2': 7.0, 'd2': 0.5}
    """
    out = {}
    for item in (text or "").split(","):
        item = item.strip()
        if not item:
            continue
        if "=" not in item:
            raise SimulationError(f"{what}: expected name=value, got '{item}'")
        key, raw = (x.strip() for x in item.split("=", 1))
        out[key] = parse_numbers(raw, f"{what} {key}")[0]
    return out


def parse_contact(kind: str, text: str) -> Union[PointForce, Surface]:
    """A force ('POINT F=fx,fy [M=moment] [from=t0] [to=t1] [at=x,y,z]') or a surface ('POINT normal=nx,ny
    [offset=o] [k=stiffness d=damping] [at=x,y,z]') from text; POINT is a named point, or a body
    with ``at=`` its local position.

    >>> parse_contact("force", "link2 F=-10,0 from=1 at=0.4,0,0")     # exact: numbers as typed
    PointForce(point=('link2', [0.4, 0.0, 0.0]), force=[-10.0, 0.0], start=1.0, end=inf, moment=None)
    >>> parse_contact("surface", "ee normal=0,1 k=5000")              # exact: numbers as typed
    Surface(point='ee', normal=[0.0, 1.0], offset=None, stiffness=5000.0, damping=0.0)
    """
    keys = {"force": ("F", "M", "from", "to", "at"), "surface": ("normal", "offset", "k", "d", "at")}[kind]
    parts = text.split()
    if not parts or "=" in parts[0]:
        raise SimulationError(f"{kind}: start with the point's name, e.g. 'ee {keys[0]}=...'")
    point, v = parts[0], {}
    for item in parts[1:]:
        if "=" not in item:
            raise SimulationError(f"{kind}: expected key=value, got '{item}'")
        key, raw = item.split("=", 1)
        if key not in keys:
            raise SimulationError(f"{kind}: unknown key '{key}' (allowed: {', '.join(keys)})")
        v[key] = parse_numbers(raw, f"{kind} {key}")
    where = (point, v["at"]) if "at" in v else point
    if kind == "force":
        if "F" not in v:
            raise SimulationError("force: give the force, e.g. F=-10,0 (newtons, world frame)")
        return PointForce(where, v["F"], v.get("from", [0.0])[0], v.get("to", [math.inf])[0], v.get("M"))
    if "normal" not in v:
        raise SimulationError("surface: give the normal pointing to the free side, e.g. normal=0,1")
    return Surface(where, v["normal"], v["offset"][0] if "offset" in v else None,
                   v["k"][0] if "k" in v else None, v["d"][0] if "d" in v else 0.0)
