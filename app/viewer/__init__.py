"""The web viewer: a viser server (``server.LabServer``) with one ``session.Session`` per browser
tab, the robot's 3D scene (``scene_view``), typeset math (``mathml``) and headless screenshots
(``screenshot``). Panels live in app/panels; docs/panels.md explains how to write one.

The names below are what a panel may import (``from app.viewer import ...``): the session
interface and the widgets and helpers built for panels. tests/test_architecture.py holds panels to
them. They are loaded on first use, so importing one does not start the rest of the viewer.
"""
import importlib

#: public name -> the module of app/viewer that defines it (a module itself when the names match)
_PUBLIC = {
    "PanelSession": "panel_api", "PanelSpec": "panel_api", "PanelRegistry": "panel_api",
    "JobCancelled": "panel_api",
    "SceneView": "scene_view", "SceneGroup": "scene_view", "SIDE_PANEL_PX": "scene_view",
    "Coalescer": "coalescer", "parse_parameter": "fields", "CommittedField": "fields",
    "AnswerBox": "answer_box",
    "mathml": "mathml", "html_cache": "html_cache", "parse_exercise_ids": "sheets", "sheet_files": "sheets",
    "in_worker": "worker",
}
__all__ = sorted(_PUBLIC)


def __getattr__(name):
    module = _PUBLIC.get(name)
    if module is None:
        raise AttributeError(f"module 'app.viewer' has no attribute {name!r}")
    loaded = importlib.import_module(f"app.viewer.{module}")
    return loaded if module == name else getattr(loaded, name)
