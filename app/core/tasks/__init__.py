"""Registry of exercise task kinds. Each module of this package registers its kinds with
``@task("kind")`` (a line of its own); a task is ``fn(ctx: TaskContext, spec: dict) -> None`` that
adds steps and answers to the context. Modules are discovered automatically.

The registry knows every kind from those decorator lines without importing anything, and imports a
module when one of its kinds is first used: solving an exercise imports only the task modules (and
libraries) its tasks need.

>>> "dynamics" in TASKS, "no_such_kind" in TASKS
(True, False)
>>> TASKS["dynamics"].__module__
'app.core.tasks.modelling'
"""
from __future__ import annotations

import importlib
import re
from collections.abc import Mapping
from pathlib import Path
from typing import Callable, Dict, Iterator

#: a registration: ``@task("kind")`` at the start of a line
_DECORATOR = re.compile(r'^@task\("([^"]+)"\)', re.MULTILINE)


class _Registry(Mapping):
    """Task kind -> task function; a kind's module is imported on first use."""

    def __init__(self, folder: Path):
        self._module_of: Dict[str, str] = {}
        self._functions: Dict[str, Callable] = {}
        for path in sorted(folder.glob("*.py")):
            if path.name.startswith("_"):
                continue
            for kind in _DECORATOR.findall(path.read_text(encoding="utf-8")):
                if kind in self._module_of:
                    raise RuntimeError(f"task kind '{kind}' registered twice")
                self._module_of[kind] = path.stem

    def register(self, kind: str, fn: Callable) -> None:
        if self._module_of.get(kind) != fn.__module__.rsplit(".", 1)[-1]:
            raise RuntimeError(f"task kind '{kind}' must be registered by a line @task(\"{kind}\") of its module")
        if kind in self._functions and self._functions[kind] is not fn:
            raise RuntimeError(f"task kind '{kind}' registered twice")
        self._functions[kind] = fn

    def __getitem__(self, kind: str) -> Callable:
        if kind not in self._functions:
            importlib.import_module(f"{__name__}.{self._module_of[kind]}")     # KeyError: unknown kind
        return self._functions[kind]

    def __iter__(self) -> Iterator[str]:
        return iter(self._module_of)

    def __len__(self) -> int:
        return len(self._module_of)


TASKS = _Registry(Path(__file__).resolve().parent)


def task(kind: str):
    """Register a task function under ``kind``."""
    def register(fn):
        TASKS.register(kind, fn)
        return fn
    return register
