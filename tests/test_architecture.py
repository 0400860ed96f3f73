"""The house of docs/architecture.md: each folder imports only from the rooms below it.

Read from the syntax of every module of app/ (imports at any depth, relative ones resolved), so a
lazy import inside a function counts too. The one edge that goes upwards is listed with its reason
in docs/architecture.md and here; a new one fails this test, naming file and line."""
import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
APP = ROOT / "app"

#: room -> the rooms it may import (besides itself); see docs/architecture.md
ALLOWED = {
    "core": {"core.tasks"},           # app/core/exercise.py runs the task kinds it looks up by name
    "core.tasks": {"core"},
    "scene": {"core"},
    "lab": {"core", "scene"},
    "viewer": {"core", "scene"},
    "panels": {"core", "scene", "viewer"},
    "commands": {"core", "scene", "viewer", "panels", "lab"},
    "cli": {"core", "commands"},
    "__main__": {"cli"},
    "app": {"core"},                   # app/__init__.py makes sympy's factoring reproducible first
}
#: (module, imported room): upward edges kept on purpose, each with its reason in docs/architecture.md
EXCEPTIONS = {("app.viewer.session", "panels")}       # the session discovers the panel plug-ins
#: third-party packages that belong to the page: the computing core and the scene never import them
GUI_PACKAGES = {"viser", "playwright", "websockets"}


def room(module: str):
    """The room of a dotted module name of app (None outside app)."""
    parts = module.split(".")
    if parts[0] != "app":
        return None
    if len(parts) == 1:
        return "app"
    if parts[1] == "core":
        return "core.tasks" if len(parts) > 2 and parts[2] == "tasks" else "core"
    return parts[1]


def imports_in(text: str, module: str, is_package: bool = False):
    """(line, imported dotted name) of every import in the source ``text`` of ``module``, relative
    imports resolved.

    >>> list(imports_in("import numpy\\nfrom ..panels import model", "app.core.x"))
    [(1, 'numpy'), (2, 'app.panels')]
    """
    package = module if is_package else module.rsplit(".", 1)[0]
    for node in ast.walk(ast.parse(text)):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield node.lineno, alias.name
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[:len(package.split(".")) - node.level + 1]
                yield node.lineno, ".".join(base + ([node.module] if node.module else []))
            else:
                yield node.lineno, node.module or ""


def module_name(path: Path) -> str:
    return ".".join(path.relative_to(ROOT).with_suffix("").parts).removesuffix(".__init__")


def imports(path: Path):
    """``imports_in`` of a file of app/."""
    return imports_in(path.read_text(encoding="utf-8"), module_name(path), path.name == "__init__.py")


def modules():
    for path in sorted(APP.rglob("*.py")):
        yield path, module_name(path)


def test_every_module_lives_in_a_room_of_the_map():
    assert {room(name) for _, name in modules()} <= set(ALLOWED)


def test_no_room_imports_from_a_room_above_it():
    found = []
    for path, name in modules():
        own = room(name)
        for line, target in imports(path):
            other = room(target)
            if other in (None, own) or other in ALLOWED[own] or (name, other) in EXCEPTIONS:
                continue
            found.append(f"{path.relative_to(ROOT)}:{line}: {own} imports {target} ({other})")
    assert not found, "imports against docs/architecture.md:\n" + "\n".join(found)


def test_the_core_and_the_scene_import_no_page_packages():
    found = [f"{path.relative_to(ROOT)}:{line}: imports {target}"
             for path, name in modules() if room(name) in ("core", "core.tasks", "scene", "lab")
             for line, target in imports(path) if target.split(".")[0] in GUI_PACKAGES]
    assert not found, "\n".join(found)


def test_the_listed_exceptions_still_exist():
    """An exception that is gone is removed from the list (and from docs/architecture.md)."""
    for name, other in EXCEPTIONS:
        path = ROOT / (name.replace(".", "/") + ".py")
        assert any(room(t) == other for _, t in imports(path)), f"{name} no longer imports {other}"


@pytest.mark.parametrize("source, module, package, target", [
    ("from app.viewer import session", "app.core.x", False, "app.viewer"),
    ("from ..panels import model", "app.viewer.session", False, "app.panels"),
    ("from . import fields", "app.viewer", True, "app.viewer"),
    ("from .tasks.energy import x", "app.core.exercise", False, "app.core.tasks.energy")])
def test_the_reader_resolves_imports(source, module, package, target):
    assert list(imports_in(source, module, package)) == [(1, target)]
