"""Panels of the page: each module of this package is one tab, discovered automatically.

A panel module defines ``TITLE`` (the tab label), ``ORDER`` (tabs sorted by it) and
``build(session)``, which adds the panel's GUI (it runs inside the tab's container). Optional:
``available(robot) -> bool`` (the tab appears only for robots where it is true),
``REBUILD = False`` (the panel is built once per browser tab instead of after every robot switch;
it then follows robot changes through ``session.on_robot_change``) and ``warm(robot, dynamics)``
(what ``build`` computes that outlives the tab, such as compiled functions and typeset formulas,
done ahead while the server is idle, so that a switch to that robot finds it ready). Modules
whose name starts with ``_`` are skipped. docs/panels.md explains the session a panel receives (``PanelSession``
of app/viewer/panel_api.py). The viewer never imports this package: whoever starts a server
passes it ``registry()``.

>>> titles = [p.title for p in discover_panels()]
>>> titles.index("Model") < titles.index("Steps") < titles.index("Robot")
True
"""
from __future__ import annotations

import importlib
import pkgutil
import traceback
from typing import List

from app.viewer import PanelRegistry, PanelSpec


def registry() -> PanelRegistry:
    """Every panel module, sorted by ORDER, and a message for each module that failed to import:
    what the server is given (``LabServer(panels=registry())``)."""
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
                               getattr(mod, "available", None), bool(getattr(mod, "REBUILD", True)),
                               getattr(mod, "warm", None)))
    specs.sort(key=lambda s: (s.order, s.title))
    return PanelRegistry(tuple(specs), tuple(errors))


def discover_panels() -> List[PanelSpec]:
    return list(registry().specs)
