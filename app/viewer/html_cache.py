"""Typeset formulas kept on disk: the Model panel's MathML of a robot already shown once is read
back instead of typeset again (issue 16: a robot switch waits on nothing that could be cached;
typesetting the throwing arm's model took about 0.9 s of CPU, its Y a and Y_r most of it).

Memory first, then the cache folder's ``pages/`` (app.core.model_cache's envelope: JSON data,
written atomically, a foreign or corrupt entry ignored and overwritten). The key is the caller's
(the robot file's content hash, the section, the layout ...) plus a version: the engine's
(app.core.output_cache.engine_version) and a hash of the modules that typeset (this package's
mathml.py, app/panels/model.py, app/core/formula_layout.py is in the engine) and of latex2mathml's
version.

>>> import os, tempfile
>>> saved = os.environ.get("R2LAB_CACHE")
>>> os.environ["R2LAB_CACHE"] = tempfile.mkdtemp()
>>> cached_html(("demo", 1), lambda: "<math/>")
'<math/>'
>>> _MEMORY.clear()
>>> cached_html(("demo", 1), lambda: 1 / 0)          # from the disk
'<math/>'
>>> if saved is None: del os.environ["R2LAB_CACHE"]
... else: os.environ["R2LAB_CACHE"] = saved
"""
from __future__ import annotations

import importlib.util
import threading
from pathlib import Path
from typing import Callable, Dict, Optional

from app.core import model_cache, output_cache

FORM = "robotics2lab-html"
FOLDER = "pages"
_MEMORY: Dict[tuple, str] = {}
_LOCK = threading.Lock()
_version: Optional[str] = None


def version() -> str:
    global _version
    if _version is None:
        app_dir = Path(__file__).resolve().parents[1]
        files = [app_dir / "viewer" / "mathml.py", app_dir / "panels" / "model.py"]
        spec = importlib.util.find_spec("latex2mathml")
        if spec is not None and spec.origin:
            files += sorted(Path(spec.origin).parent.glob("*.py"))
        _version = output_cache.digest_of_files(files, output_cache.engine_version())
    return _version


def cached_html(key: tuple, make: Callable[[], str]) -> str:
    """``make()``'s text for ``key`` (a tuple of texts and numbers), from memory, the disk, or made
    now and kept in both."""
    with _LOCK:
        html = _MEMORY.get(key)
    if html is not None:
        return html
    envelope = {"version": version(), "key": repr(key)}
    path = model_cache.entry_path("|".join(envelope.values()), FOLDER)
    payload = model_cache.read_entry(path, envelope, FORM)
    html = payload.get("html") if payload is not None else None
    if not isinstance(html, str):
        html = make()
        model_cache.write_entry(path, envelope, {"html": html}, FORM)
    with _LOCK:
        _MEMORY[key] = html
    return html
