"""Option values shared by several commands.

>>> assignments(["m1=12", " l1 = pi/4 "])
{'m1': '12', 'l1': 'pi/4'}
"""
from __future__ import annotations

from typing import Dict, Iterable

from app.core.errors import UserError, excerpt


def assignments(items: Iterable[str], option: str = "--set") -> Dict[str, str]:
    """``NAME=VALUE`` items (a repeatable option) as ``{name: value text}``; the value is parsed by
    its owner (a given of an exercise, a parameter of a robot). UserError for an item without a
    name or an ``=``."""
    out: Dict[str, str] = {}
    for item in items:
        name, sign, value = item.partition("=")
        if not sign or not name.strip():
            raise UserError(f"{option} expects NAME=VALUE, got {excerpt(item, 40)}")
        out[name.strip()] = value.strip()
    return out
