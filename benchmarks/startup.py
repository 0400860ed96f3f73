"""Start-up of the light commands: the CPU and wall time of a whole ``python -m app ...`` process,
against ``python -c "import app"`` (the interpreter and the package, nothing else) in the same run.

Each command runs REPEATS times in a fresh interpreter, the commands interleaved round by round so
that a change in the machine's load touches them all alike; the figure is the median. CPU time is
user + system time of the child (``resource.getrusage``), which a busy machine inflates much less
than the wall time. ``derive`` and ``solve`` read a derivation cache filled before the first round
(a temporary ``R2LAB_CACHE``), so they measure what a user waits for once a robot was derived.
A second baseline, ``import sympy, numpy``, shows the floor of any command that touches the
symbolic engine. The solution of 2009-07-10#1 takes about 0.1 s, so its figure is nearly all
start-up; that of 2004-03-25#1 (partial feedback linearization) spends about 0.6 s solving.

Goal (issue 16): each light command at most 0.5 s of CPU.

Run: ``python -m benchmarks.startup``.
"""
from __future__ import annotations

import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
REPEATS = 3
GOAL_CPU = 0.5
BASELINE = ("import app", ["-c", "import app"])
ENGINE_FLOOR = ("import sympy, numpy", ["-c", "import sympy, numpy"])
COMMANDS = [
    ("robots", ["-m", "app", "robots"]),
    ("exercises", ["-m", "app", "exercises"]),
    ("derive rp_2004_03_25 (cached)", ["-m", "app", "derive", "rp_2004_03_25"]),
    ("derive rp_2004_03_25 --json (cached)", ["-m", "app", "derive", "rp_2004_03_25", "--json"]),
    ("solve 2009-07-10#1 --json (cached)", ["-m", "app", "solve", "2009-07-10#1", "--json"]),
    ("solve 2004-03-25#1 --json (cached)", ["-m", "app", "solve", "2004-03-25#1", "--json"]),
]


def measure(args, env) -> tuple:
    """(CPU seconds, wall seconds) of one ``python ARGS`` process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    subprocess.run([sys.executable, *args], cwd=ROOT, env=env, check=True,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), wall


def run(repeats: int = REPEATS) -> dict:
    """Label -> (median CPU, median wall) for the baselines and every command."""
    entries = [BASELINE, ENGINE_FLOOR, *COMMANDS]
    with tempfile.TemporaryDirectory(prefix="r2lab-startup-") as cache:
        env = {**os.environ, "R2LAB_CACHE": cache}
        for _, args in COMMANDS:         # fill the derivation cache (and Python's bytecode cache)
            measure(args, env)
        samples = {label: [] for label, _ in entries}
        for _ in range(repeats):
            for label, args in entries:
                samples[label].append(measure(args, env))
    return {label: (statistics.median(c for c, _ in s), statistics.median(w for _, w in s))
            for label, s in samples.items()}


#: the commands with the goal of at most GOAL_CPU s of CPU
GOAL_COMMANDS = {"robots", "exercises", "derive rp_2004_03_25 (cached)", "derive rp_2004_03_25 --json (cached)",
                 "solve 2009-07-10#1 --json (cached)", "solve 2004-03-25#1 --json (cached)"}


def figures(repeats: int = REPEATS) -> list:
    """(name, wall s, CPU s, goal or None, note) of every command, against the baselines."""
    measured = run(repeats)
    base_cpu, base_wall = measured[BASELINE[0]]
    out = []
    for label, (cpu, wall) in measured.items():
        if label == BASELINE[0]:
            continue
        note = f"{cpu / base_cpu:.1f}x `import app` ({base_cpu:.2f} s CPU)"
        out.append((f"start-up: {label}", wall, cpu, GOAL_CPU if label in GOAL_COMMANDS else None, note, "cpu"))
    return out


def main(repeats: int = REPEATS) -> None:
    figures = run(repeats)
    base_cpu, base_wall = figures[BASELINE[0]]
    print(f"Start-up of a command, whole process (seconds; median of {repeats}, interleaved); "
          f"goal: at most {GOAL_CPU} s CPU")
    print(f"{'command':<38}{'CPU':>7}{'wall':>7}{'CPU / baseline':>16}{'CPU - baseline':>16}{'goal':>8}")
    for label, (cpu, wall) in figures.items():
        if label == BASELINE[0]:
            print(f"{label:<38}{cpu:>7.2f}{wall:>7.2f}{'baseline':>16}")
            continue
        verdict = "" if label == ENGINE_FLOOR[0] else "met" if cpu <= GOAL_CPU else "MISSED"
        print(f"{label:<38}{cpu:>7.2f}{wall:>7.2f}{cpu / base_cpu:>15.1f}x{cpu - base_cpu:>16.2f}{verdict:>8}")
    print(f"(baseline `python -c \"import app\"`: {base_cpu:.3f} s CPU, {base_wall:.3f} s wall)")


if __name__ == "__main__":
    main()
