"""The house of docs/architecture.md: each folder imports only from the rooms below it.

Read from the syntax of every module of app/ (imports at any depth, relative ones resolved), so a
lazy import inside a function counts too. No edge goes upwards: the viewer gets its panels from a
registry the command that starts the server passes (``app.commands.serve.lab_server``). Panels
see the page only through the session interface (the public names of ``app.viewer``) and the
core's public names, and never reach into the session or viser. A breach fails, naming file and
line."""
import ast
import functools
import inspect
import textwrap
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
#: third-party packages that belong to the page: the computing core and the scene never import them
GUI_PACKAGES = {"viser", "playwright", "websockets"}


@functools.lru_cache(maxsize=None)
def parse(text: str) -> ast.Module:
    """The syntax tree of a module's text (each file is read by several tests: parsed once)."""
    return ast.parse(text)


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
    for node in ast.walk(parse(text)):
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
            if other in (None, own) or other in ALLOWED[own]:
                continue
            found.append(f"{path.relative_to(ROOT)}:{line}: {own} imports {target} ({other})")
    assert not found, "imports against docs/architecture.md:\n" + "\n".join(found)


def test_the_core_and_the_scene_import_no_page_packages():
    found = [f"{path.relative_to(ROOT)}:{line}: imports {target}"
             for path, name in modules() if room(name) in ("core", "core.tasks", "scene", "lab")
             for line, target in imports(path) if target.split(".")[0] in GUI_PACKAGES]
    assert not found, "\n".join(found)


def test_the_core_imports_neither_viewer_nor_panels():
    found = [f"{path.relative_to(ROOT)}:{line}: imports {target}"
             for path, name in modules() if room(name) in ("core", "core.tasks")
             for line, target in imports(path) if room(target) in ("viewer", "panels", "commands", "cli")]
    assert not found, "\n".join(found)


def names_imported(text: str, module: str):
    """(line, dotted module, imported name or None) of every import in ``text`` of ``module``
    (``None`` for ``import a.b``), relative imports resolved.

    >>> list(names_imported("from app.viewer import mathml, SceneView", "app.panels.x"))
    [(1, 'app.viewer', 'mathml'), (1, 'app.viewer', 'SceneView')]
    """
    package = module.rsplit(".", 1)[0]
    for node in ast.walk(parse(text)):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield node.lineno, alias.name, None
        elif isinstance(node, ast.ImportFrom):
            target = node.module or ""
            if node.level:
                base = package.split(".")[:len(package.split(".")) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            for alias in node.names:
                yield node.lineno, target, alias.name


def panel_files():
    return [(path, name) for path, name in modules() if room(name) == "panels"]


def test_panels_use_only_the_session_interface_and_the_cores_public_names():
    """``from app.viewer import X`` with X among ``app.viewer.__all__`` (the session interface and
    the widgets for panels), and from the core (and app/scene.py) only names without a leading
    underscore; no page package (viser, playwright) and no server."""
    import app.viewer
    found = []
    for path, name in panel_files():
        for line, target, imported in names_imported(path.read_text(encoding="utf-8"), name):
            where = f"{path.relative_to(ROOT)}:{line}"
            other = room(target)
            if target.split(".")[0] in GUI_PACKAGES:
                found.append(f"{where}: imports {target} (a page package: the viewer's job)")
            elif other == "viewer" and (target != "app.viewer" or imported not in app.viewer.__all__):
                found.append(f"{where}: imports {imported or ''} from {target} (not a public name of app.viewer)")
            elif other in ("core", "core.tasks", "scene") and (
                    any(part.startswith("_") for part in target.split(".")) or (imported or "").startswith("_")):
                found.append(f"{where}: imports the private {imported or target} of {target}")
    assert not found, "\n".join(found)


#: what a panel must not reach through: the session's server and viser client, and viser's
#: private attributes (the page is built on viser's public API only)
SESSION_INSIDES = {"lab", "client"}
VISER_PRIVATE = {"_children", "_impl", "_container_handle_from_uuid", "_websock_interface",
                 "_gui_input_handle_from_uuid", "_handle_gui_updates"}
#: the one module allowed viser's insides: app/viewer/guard.py checks every widget update a browser
#: sends before viser applies it, and viser has no public hook for that (docs/architecture.md)
VISER_INSIDES_ALLOWED = {"app.viewer.guard"}


def attribute_chains(text: str):
    """(line, dotted chain) of every attribute read such as ``self.session.client.camera``.

    >>> [c for _, c in attribute_chains("x = self.session.lab.robot(1)")]
    ['self.session.lab.robot', 'self.session.lab', 'self.session']
    """
    for node in ast.walk(parse(text)):
        if isinstance(node, ast.Attribute):
            parts, inner = [node.attr], node.value
            while isinstance(inner, ast.Attribute):
                parts.append(inner.attr)
                inner = inner.value
            if isinstance(inner, ast.Name):
                yield node.lineno, ".".join([inner.id] + parts[::-1])


def test_panels_do_not_reach_around_the_session():
    found = []
    for path, _ in panel_files():
        for line, chain in attribute_chains(path.read_text(encoding="utf-8")):
            parts = chain.split(".")
            for before, after in zip(parts, parts[1:]):
                if before == "session" and (after in SESSION_INSIDES or after.startswith("_")):
                    found.append(f"{path.relative_to(ROOT)}:{line}: {chain}")
    assert not found, "panels use the session interface (docs/panels.md), not:\n" + "\n".join(sorted(set(found)))


def panel_interface() -> set:
    """The names ``PanelSession`` (app/viewer/panel_api.py) offers a panel."""
    from app.viewer.panel_api import PanelSession
    return set(PanelSession.__annotations__) | {k for k in vars(PanelSession) if not k.startswith("_")}


def test_panels_use_only_the_panel_interface_of_the_session():
    offered = panel_interface()
    found = []
    for path, _ in panel_files():
        for line, chain in attribute_chains(path.read_text(encoding="utf-8")):
            parts = chain.split(".")
            if len(parts) > 1 and parts[-2] == "session" and parts[-1] not in offered:
                found.append(f"{path.relative_to(ROOT)}:{line}: {chain}")
    assert not found, "not in PanelSession (app/viewer/panel_api.py):\n" + "\n".join(sorted(set(found)))


def test_the_session_implements_the_panel_interface():
    """Every name of ``PanelSession`` is a method or property of ``Session`` or set in its
    ``__init__`` (read from the source: no server needed)."""
    from app.viewer.session import Session
    init = ast.parse(textwrap.dedent(inspect.getsource(Session.__init__)))
    assigned = {t.attr for node in ast.walk(init) if isinstance(node, (ast.Assign, ast.AnnAssign))
                for t in (node.targets if isinstance(node, ast.Assign) else [node.target])
                if isinstance(t, ast.Attribute)}
    build = ast.parse(textwrap.dedent(inspect.getsource(Session._build_page)))
    assigned |= {t.attr for node in ast.walk(build) if isinstance(node, ast.Assign)
                 for t in node.targets if isinstance(t, ast.Attribute)}
    missing = {name for name in panel_interface() if not hasattr(Session, name) and name not in assigned}
    assert not missing, f"Session lacks {sorted(missing)}"


def test_no_private_viser_attributes():
    found = [f"{path.relative_to(ROOT)}:{line}: {chain}"
             for path, name in modules() if name not in VISER_INSIDES_ALLOWED
             for line, chain in attribute_chains(path.read_text(encoding="utf-8"))
             if chain.split(".")[-1] in VISER_PRIVATE]
    assert not found, "\n".join(sorted(set(found)))


@pytest.mark.parametrize("source, module, package, target", [
    ("from app.viewer import session", "app.core.x", False, "app.viewer"),
    ("from ..panels import model", "app.viewer.session", False, "app.panels"),
    ("from . import fields", "app.viewer", True, "app.viewer"),
    ("from .tasks.energy import x", "app.core.exercise", False, "app.core.tasks.energy")])
def test_the_reader_resolves_imports(source, module, package, target):
    assert list(imports_in(source, module, package)) == [(1, target)]


def test_only_the_numeric_package_compiles_expressions():
    """``sympy.lambdify`` is called in one place, app/core/numeric/compile.py: everything else uses
    ``app.core.numeric.numeric_function`` or a robot's ``CompiledModel``."""
    numeric = APP / "core" / "numeric"
    found = [f"{path.relative_to(ROOT)}:{i}: {line.strip()}"
             for path, _ in modules() if numeric not in path.parents
             for i, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1) if "lambdify" in line]
    assert not found, "lambdify outside app/core/numeric/:\n" + "\n".join(found)
