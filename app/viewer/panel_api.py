"""What a panel sees of the page: the ``PanelSession`` interface a panel's ``build(session)``
receives, and the ``PanelRegistry`` the server is given (the viewer never imports app.panels: the
command that starts the server passes ``app.panels.registry()``). docs/panels.md documents both.
"""
from __future__ import annotations

from concurrent.futures import Future
from dataclasses import dataclass, field
from typing import Callable, ContextManager, Dict, List, Mapping, Optional, Protocol, Tuple

import numpy as np


class JobCancelled(Exception):
    """Raised by a background job's ``progress`` when the student clicked Cancel or the browser
    tab that started it went away."""


@dataclass(frozen=True)
class PanelSpec:
    """One tab of the page: a panel module's ``TITLE``, ``ORDER``, ``build(session)``, optional
    ``available(robot)``, ``REBUILD`` and ``warm(robot, dynamics)`` (what ``build`` computes that
    outlives the tab, done ahead while the server is idle: compiled functions, typeset formulas)."""
    name: str                     # module name, e.g. "model"
    title: str
    order: float
    build: Callable
    available: Optional[Callable] = None
    rebuild: bool = True
    warm: Optional[Callable] = None

    def applies_to(self, robot) -> bool:
        return self.available is None or bool(self.available(robot))


@dataclass(frozen=True)
class PanelRegistry:
    """The panels a server offers (sorted by ``order``) and a message for every panel module that
    failed to load (each shown as a notification on every new page). Empty: a page with no tabs.

    >>> PanelRegistry().specs, PanelRegistry().errors
    ((), ())
    """
    specs: Tuple[PanelSpec, ...] = ()
    errors: Tuple[str, ...] = field(default=())

    def named(self, name: str) -> Optional[PanelSpec]:
        return next((s for s in self.specs if s.name == name), None)


class PanelSession(Protocol):
    """The session a panel receives (docs/panels.md, "The session"): a panel uses these and
    nothing else of the page. ``app.viewer.session.Session`` implements it."""
    robot: object                       # RobotModel (app/core/robot.py)
    robot_name: str
    dynamics: object                    # Dynamics of app.core.dynamics.derive
    numeric: object                     # NumericModel with the tab's parameter values
    drawing: object                     # RobotDrawing in use
    q: np.ndarray
    params: Dict[str, float]
    generation: int
    closed: bool
    state: Dict[str, object]
    gui: object                         # the panel's GUI container (viser's GuiApi, inside the tab)
    scene: object                       # SceneView: every drawing in the 3D view goes through it
    presenter: object

    @property
    def coordinates(self) -> List[str]: ...
    @property
    def ranges(self) -> Dict[str, tuple]: ...
    @property
    def tab_id(self) -> int: ...
    def robot_named(self, name: str): ...
    def load_robot(self, name: str) -> None: ...
    def set_q(self, q) -> None: ...
    def set_parameters(self, values: Mapping[str, float]) -> None: ...
    def on_q_change(self, callback: Callable) -> None: ...
    def on_parameters_change(self, callback: Callable) -> None: ...
    def on_presenter_change(self, callback: Callable) -> None: ...
    def on_robot_change(self, callback: Callable) -> None: ...
    def notify(self, title: str, body: str = "", error: bool = False) -> None: ...
    def run_in_background(self, fn: Callable, progress_title: str, on_done: Optional[Callable] = None,
                          on_cancel: Optional[Callable] = None) -> Future: ...
    def math_html(self, latex: str, display: bool = True) -> str: ...
    def holding(self, generation: int) -> ContextManager[bool]: ...
    def atomic(self) -> ContextManager[None]: ...
    def remember(self, **values: Optional[str]) -> None: ...

