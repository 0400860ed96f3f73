"""A long seeded walk through the page (app/viewer/walk.py): random user actions on many robots,
the page checked after every one. Prints every action, every violation and a summary line
(actions, violations, time); exits 1 when a violation was found.

Run: ``python -m benchmarks.soak --seed 7 --actions 1000`` (needs /usr/bin/chromium; about an hour
on a shared 2-core machine). The result of the last long run is in docs/viewer.md.
"""
from __future__ import annotations

import argparse
import sys
import time


def soak(seed: int, actions: int, verbose: bool = True):
    """Walk ``actions`` random actions with ``seed`` over the soak's robots; the walk's Report."""
    from app.viewer import walk
    from app.viewer.screenshot import Browser
    from app.commands.serve import lab_server
    start = time.perf_counter()
    # straight to the terminal: the walk reads the process's own output for server exceptions
    log = ((lambda text: print(f"{time.perf_counter() - start:7.1f} s  {text}", file=sys.__stdout__, flush=True))
           if verbose else None)
    lab = lab_server(port=0)
    try:
        with Browser() as browser:
            return walk.Walk(lab, browser, seed, pool=walk.SOAK_POOL, log=log).run(actions)
    finally:
        lab.stop()


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, required=True, help="seed of the walk (the same seed walks the same way)")
    parser.add_argument("--actions", type=int, default=1000)
    args = parser.parse_args()
    cpu = time.process_time()
    report = soak(args.seed, args.actions)
    print(report.line() + f"; server process CPU {time.process_time() - cpu:.0f} s")
    for line in report.violations:
        print("  " + line)
    sys.exit(1 if report.violations else 0)
