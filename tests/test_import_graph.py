"""The light commands import only what they need (issue 16: a command answers at once).

Asserted on the import graph, not on a time: each check runs the commands in a fresh interpreter
and reads ``sys.modules`` afterwards. The listings read the files' headers only (app/core/catalog.py),
so ``robots`` and ``exercises`` import neither sympy nor any heavy library. A derivation and a
solution computed import the engine but nothing of the page (viser, the panels, playwright) and
neither pinocchio nor scipy, and of the task modules only those the exercise's tasks need; printed
again from the output cache (app/core/output_cache.py) they import neither sympy nor numpy, and
print the same bytes. Three subprocesses in all.
"""
import importlib
import json
import os
import pkgutil
import subprocess
import sys
from pathlib import Path

import app.core.tasks as tasks

ROOT = Path(__file__).resolve().parents[1]

#: runs the commands given as one JSON list of argument lists, then prints the imported modules
#: and what each command printed
CHILD = """
import contextlib, io, json, sys
from app.cli import main
outputs = []
for argv in json.loads(sys.argv[1]):
    with contextlib.redirect_stdout(io.StringIO()) as out:
        code = main(argv)
    if code != 0:
        sys.exit(f"{argv}: exit code {code}")
    outputs.append(out.getvalue())
print(json.dumps({"modules": sorted(sys.modules), "outputs": outputs}))
"""

PAGE = {"viser", "playwright", "plotly", "app.viewer", "app.panels"}


def _imported(commands, cache: Path) -> set:
    return _run(commands, cache)[0]


def _run(commands, cache: Path):
    """(the modules imported, the outputs) of the commands run in one fresh interpreter."""
    env = {**os.environ, "R2LAB_CACHE": str(cache)}
    done = subprocess.run([sys.executable, "-c", CHILD, json.dumps(commands)], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    result = json.loads(done.stdout)
    return set(result["modules"]), result["outputs"]


def _heavy(modules: set, names: set) -> set:
    """The modules among ``names`` that were imported (a package counts when any of its modules was)."""
    return {name for name in names if any(m == name or m.startswith(name + ".") for m in modules)}


def test_listings_import_no_engine_and_no_heavy_library(tmp_path):
    modules = _imported([["robots"], ["robots", "--json"], ["exercises"], ["exercises", "--json"]], tmp_path)
    assert _heavy(modules, PAGE | {"pinocchio", "scipy", "sympy", "numpy", "app.core.tasks"}) == set()
    assert "app.core.catalog" in modules


def test_derivation_and_solution_import_nothing_of_the_page_and_cached_ones_not_the_engine(tmp_path):
    commands = [["derive", "rp_2004_03_25"], ["derive", "rp_2004_03_25", "--json"],
                ["solve", "2004-03-25#1", "--json"], ["solve", "2004-03-25#1"]]
    modules, computed = _run(commands, tmp_path)
    assert _heavy(modules, PAGE | {"pinocchio", "scipy"}) == set()
    assert {"sympy", "app.core.dynamics", "app.core.tasks"} <= modules
    used = {tasks.TASKS[kind].__module__ for kind in ("dynamics", "parametrization", "adaptive_law", "pfl")}
    used.add("app.core.tasks.context")          # TaskView, which the tasks read their exercise through
    assert {m for m in modules if m.startswith("app.core.tasks.")} == used
    assert list((tmp_path / "derivations").glob("*")), "the first run left no derivation in the cache"
    assert len(list((tmp_path / "outputs").glob("*.json"))) == len(commands)

    modules, cached = _run(commands, tmp_path)
    assert cached == computed               # the JSON contracts and the texts, byte for byte
    assert _heavy(modules, PAGE | {"pinocchio", "scipy", "sympy", "numpy", "app.core.dynamics",
                                   "app.core.robot", "app.core.tasks", "app.core.exercise"}) == set()
    assert "app.core.output_cache" in modules
    assert json.loads(cached[1])["robot"] == "rp_2004_03_25" and json.loads(cached[1])["M"]
    assert json.loads(cached[2])["id"] == "2004-03-25#1" and json.loads(cached[2])["steps"]
    assert cached[0].startswith("Planar RP") and "M(q) =" in cached[0]


def test_the_task_registry_knows_every_kind_its_modules_register():
    """The registry reads the kinds from the ``@task("kind")`` lines; importing every task module
    registers exactly those kinds, each in the module the registry names."""
    for info in pkgutil.iter_modules(tasks.__path__):
        importlib.import_module(f"{tasks.__name__}.{info.name}")
    assert len(tasks.TASKS) > 70
    for kind in tasks.TASKS:
        assert tasks.TASKS[kind].__module__ == f"{tasks.__name__}.{tasks.TASKS._module_of[kind]}"
