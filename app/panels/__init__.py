"""Panels of the page: each module of this package is one tab, discovered automatically.

A panel module defines ``TITLE`` (the tab label), ``ORDER`` (tabs sorted by it) and
``build(session)``, which adds the panel's GUI (it runs inside the tab's container). Optional:
``available(robot) -> bool`` (the tab appears only for robots where it is true) and
``REBUILD = False`` (the panel is built once per browser tab instead of after every robot switch;
it then follows robot changes through ``session.on_robot_change``). Modules whose name starts
with ``_`` are skipped. docs/panels.md explains the ``Session`` a panel receives.

>>> titles = [p.title for p in discover_panels()]
>>> titles.index("Model") < titles.index("Steps") < titles.index("Robot")
True
"""
from __future__ import annotations

import importlib
import pkgutil
import traceback
from dataclasses import dataclass
from typing import Callable, List, Optional, Tuple


@dataclass(frozen=True)
class PanelSpec:
    """A discovered panel module."""
    name: str                     # module name, e.g. "model"
    title: str
    order: float
    build: Callable
    available: Optional[Callable] = None
    rebuild: bool = True

    def applies_to(self, robot) -> bool:
        return self.available is None or bool(self.available(robot))


def discover_panels_with_errors() -> Tuple[List[PanelSpec], List[str]]:
    """All panel modules, sorted by ORDER, and a message for each module that failed to import."""
    import app.panels as pkg
    specs, errors = [], []
    for info in pkgutil.iter_modules(pkg.__path__):
        if info.name.startswith("_"):
            continue
        try:
            mod = importlib.import_module(f"app.panels.{info.name}")
        except Exception:   # a broken panel must not take the page down
            errors.append(f"panel '{info.name}' failed to load:\n{traceback.format_exc(limit=3)}")
            continue
        if not (hasattr(mod, "TITLE") and hasattr(mod, "build")):
            continue
        specs.append(PanelSpec(info.name, str(mod.TITLE), float(getattr(mod, "ORDER", 50)), mod.build,
                               getattr(mod, "available", None), bool(getattr(mod, "REBUILD", True))))
    specs.sort(key=lambda s: (s.order, s.title))
    return specs, errors


def discover_panels() -> List[PanelSpec]:
    return discover_panels_with_errors()[0]
