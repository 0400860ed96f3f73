"""Registry of exercise task kinds. Each module of this package registers its kinds with
``@task("kind")``; a task is ``fn(ctx: TaskContext, spec: dict) -> None`` that adds steps and
answers to the context. Modules are discovered automatically.

>>> "dynamics" in TASKS
True
"""
from __future__ import annotations

import importlib
import pkgutil
from typing import Callable, Dict

TASKS: Dict[str, Callable] = {}


def task(kind: str):
    """Register a task function under ``kind``."""
    def register(fn):
        if kind in TASKS and TASKS[kind] is not fn:
            raise RuntimeError(f"task kind '{kind}' registered twice")
        TASKS[kind] = fn
        return fn
    return register


for _info in pkgutil.iter_modules(__path__):
    importlib.import_module(f"{__name__}.{_info.name}")
