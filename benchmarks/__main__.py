"""``python -m benchmarks``: every figure of issue 16 (speed a user feels) with its goal, measured
in this run, CPU time beside wall time, and the machine's load average (a busy machine inflates wall
time much more than CPU time). The figures come from each benchmark module's ``figures()``:
start-up of the commands (benchmarks/startup.py), the page (benchmarks/viewer.py), the screenshot
command (benchmarks/screenshot.py), and any other module that defines ``figures()``.

``python -m benchmarks --all`` runs every benchmark module's own ``main()`` in turn instead.
A figure is ``(name, wall s, CPU s or None, goal s or None, note[, "cpu"])``: its goal is checked
against the wall time unless the sixth item says ``"cpu"`` (the start-up goals are CPU time).
"""
import importlib
import os
import pkgutil
import sys
import time

import benchmarks

FIRST = ["startup", "viewer", "screenshot"]


def _modules():
    names = [m.name for m in pkgutil.iter_modules(benchmarks.__path__) if not m.name.startswith("_")]
    return FIRST + sorted(n for n in names if n not in FIRST)


def run_all() -> None:
    for name in sorted(_modules()):
        mod = importlib.import_module(f"benchmarks.{name}")
        if hasattr(mod, "main"):
            print(f"\n=== {name} ===")
            mod.main()


def issue16() -> None:
    rows = []
    load = os.getloadavg()
    start = time.perf_counter()
    for name in _modules():
        mod = importlib.import_module(f"benchmarks.{name}")
        if not hasattr(mod, "figures"):
            continue
        print(f"measuring {name} ...", flush=True)
        rows += mod.figures()
    print(f"\nIssue 16 figures (load average {load[0]:.1f} at start, {os.getloadavg()[0]:.1f} at the end; "
          f"{time.perf_counter() - start:.0f} s)")
    print(f"{'figure':<58}{'wall s':>8}{'CPU s':>8}{'goal s':>8}  {'':<11} note")
    for name, wall, cpu, goal, note, *on in rows:
        measure = cpu if on == ["cpu"] else wall
        verdict = "" if goal is None else ("met" if measure <= goal else "MISSED") + (" (CPU)" if on else "")
        cpu_text = f"{cpu:8.2f}" if cpu is not None else f"{'-':>8}"
        goal_text = f"{goal:8.2f}" if goal is not None else f"{'':>8}"
        print(f"{name:<58}{wall:8.2f}{cpu_text}{goal_text}  {verdict:<11} {note}")


if __name__ == "__main__":
    run_all() if "--all" in sys.argv[1:] else issue16()
