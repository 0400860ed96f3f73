"""``python -m app screenshot``: the time of one picture (the whole command: start-up, server,
browser, page, picture; the robots derived before, their models in the disk cache) and of each picture after the first when the server and the browser are
reused (what ``--all-docs`` does), wall and CPU time.

CPU: for the command, the process and its children (Chromium among them, reaped when the command
ends); for the pictures after the first, the benchmark's own process (the server and the
picture-taking code; the browser's processes are not in it).

Goal (issue 16): at most 5 s per picture after the first.

Run: ``python -m benchmarks.screenshot``.
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
GOAL = 5.0
#: (robot, panel, q, step index): the kind of pictures docs/screenshots holds
SHOTS = [("rp_2004_03_25", "model", [0.5, 0.25], None), ("planar_2r", "steps", [0.6, 0.9], 3),
         ("throwing_arm", "model", None, None), ("viewer_demo_spatial_3r", "model", None, None),
         ("planar_2r", "model", [0.3, -0.6], None)]


def one_command(out_dir: Path, env) -> tuple:
    """(wall, CPU) of ``python -m app screenshot --robot rp_2004_03_25 --panel model --out ...``."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "app", "screenshot", "--robot", "rp_2004_03_25", "--panel", "model",
                    "--out", str(out_dir / "one.png")], cwd=ROOT, env=env, check=True,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def pictures(out_dir: Path) -> list:
    """(wall, CPU of this process) of each picture of SHOTS taken with one server and one browser."""
    from app.commands.screenshot import shoot
    from app.viewer.screenshot import Browser
    from benchmarks.viewer import _lab
    times = []
    lab = _lab()
    try:
        with Browser() as browser:
            for k, (robot, panel, q, step) in enumerate(SHOTS):
                t0, c0 = time.perf_counter(), time.process_time()
                shoot(robot, out_dir / f"shot{k}.png", panel, q, step, lab=lab, browser=browser)
                times.append((time.perf_counter() - t0, time.process_time() - c0))
    finally:
        lab.stop()
    return times


def figures() -> list:
    """(name, wall s, CPU s, goal or None, note) of the screenshot command."""
    with tempfile.TemporaryDirectory(prefix="r2lab-shots-") as tmp:
        env = {**os.environ, "R2LAB_CACHE": str(Path(tmp) / "cache")}
        saved = os.environ.get("R2LAB_CACHE")
        os.environ["R2LAB_CACHE"] = env["R2LAB_CACHE"]
        try:
            from app.core.dynamics import derive, forget_derivations
            from app.core.robot import load_robot
            for robot in {shot[0] for shot in SHOTS}:     # derived before, as a user's robots are
                derive(load_robot(robot))
            forget_derivations()                          # ... on disk, not in this process
            one = one_command(Path(tmp), env)
            shots = pictures(Path(tmp))
        finally:
            if saved is None:
                os.environ.pop("R2LAB_CACHE", None)
            else:
                os.environ["R2LAB_CACHE"] = saved
    later = shots[1:]
    wall = statistics.median(w for w, _ in later)
    cpu = statistics.median(c for _, c in later)
    slowest = max(w for w, _ in later)
    return [("screenshot: one picture, whole command", one[0], one[1], None, "CPU with Chromium's"),
            ("screenshot: first picture in one browser", shots[0][0], shots[0][1], None, "server's process CPU"),
            (f"screenshot: each later picture (median of {len(later)})", wall, cpu, GOAL, f"slowest {slowest:.2f} s")]


def main() -> None:
    print(f"load average at start: {' '.join(f'{x:.1f}' for x in os.getloadavg())}")
    for name, wall, cpu, goal, note in figures():
        target = f"goal <= {goal} s" if goal else ""
        print(f"  {name:<48}{wall:>7.2f} s wall{cpu:>7.2f} s CPU  {target:<14}{note}")
    print(f"load average at end: {' '.join(f'{x:.1f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
