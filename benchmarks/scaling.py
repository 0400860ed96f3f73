"""Derivation scaling: CPU seconds of a cold ``derive`` against the number of joints, for serial
chains written as robot files (benchmarks/robots/chain_*.yaml), beside sympy.physics.mechanics
``LagrangesMethod`` (with and without ``simplify`` of the mass matrix and the forcing) in the same run.

Chains: planar nR (n = 2..7, vertical plane, one CoM offset and one moment per link); spatial nR
(n = 2..4) made of the first n rows of a PUMA-like DH table; the whole 6R table (``chain_puma_6r``).
Spatial links have one CoM offset and three principal moments each (diagonal inertia tensors); the
same 6R with generic links (``chain_puma_6r_full``: a CoM vector of three parameters and a full
inertia tensor per link, 66 parameters) is the arm of the 120 s goal.

Each figure is one fresh interpreter (``python -m benchmarks.scaling --one KIND ROBOT``) stopped
after CAP seconds of CPU; the time is the CPU time (``time.process_time``) of the derivation alone, after
the imports, so a busy machine inflates it much less than the wall time (printed beside it).
Ours derives M, Christoffel symbols, C, c, g, the minimal and the adaptive regressor and the steps.
When a contender reaches the cap at n joints, the larger chains of that family (the 6R counts as
the next spatial chain) are not tried (shown as "> 120").

Goals (issue 16): planar chains up to 7 joints <= 10 s CPU; spatial 4 joints <= 10 s; the 6R arms <= 120 s.

Run: ``python -m benchmarks.scaling`` (``--write`` rewrites the robot files; ``--kinds ours,plain``
measures some columns only).
"""
from __future__ import annotations

import json
import resource
import signal
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
HERE = Path(__file__).resolve().parent / "robots"
CAP = 120.0
WALL_FACTOR = 20
PLANAR = [f"chain_planar_{n}r" for n in range(2, 8)]
SPATIAL = [f"chain_spatial_{n}r" for n in range(2, 5)]
PUMA = ["chain_puma_6r", "chain_puma_6r_full"]
GOALS = {"chain_planar_7r": 10.0, "chain_spatial_4r": 10.0, "chain_puma_6r": 120.0, "chain_puma_6r_full": 120.0}

# PUMA-like standard DH rows (alpha, a, d) and the CoM of each link in its own frame
_DH = [("pi/2", "0", "0"), ("0", "a2", "0"), ("-pi/2", "a3", "d3"), ("pi/2", "0", "d4"), ("-pi/2", "0", "0"),
       ("0", "0", "d6")]
_COM = [["0", "-c1", "0"], ["c2 - a2", "0", "0"], ["0", "c3", "0"], ["0", "0", "-c4"], ["0", "-c5", "0"],
        ["0", "0", "c6"]]
_LENGTHS = {"a2": 0.43, "a3": 0.02, "d3": 0.15, "d4": 0.43, "d6": 0.06}
_MASSES = [10.0, 17.4, 4.8, 0.82, 0.34, 0.09]
_COMS = [0.1, 0.25, 0.02, 0.1, 0.03, 0.03]
_MOMENTS = [(0.35, 0.35, 0.3), (0.13, 0.52, 0.54), (0.066, 0.086, 0.0125), (0.0018, 0.0013, 0.0018),
            (0.0003, 0.0004, 0.0003), (0.00015, 0.00015, 0.00004)]


def planar_text(n: int) -> str:
    lines = [f"name: chain_planar_{n}r", f"title: Planar {n}R chain (benchmark)", "plane: vertical",
             f"coordinates: [{', '.join(f'q{i}' for i in range(1, n + 1))}]", "parameters:"]
    for i in range(1, n + 1):
        lines.append(f"  m{i}: {{value: {round(6.0 - 0.5 * i, 2)}, kind: mass}}")
        if i < n:
            lines.append(f"  l{i}: {{value: {round(1.0 - 0.1 * i, 2)}, kind: length}}")
        lines.append(f"  d{i}: {{value: {round(0.5 - 0.05 * i, 3)}, kind: com}}")
        lines.append(f"  I{i}: {{value: {round(0.4 / i, 4)}, kind: inertia}}")
    lines += ["  g0: {value: 9.81, kind: gravity}", "gravity: [0, -g0, 0]", "bodies:"]
    for i in range(1, n + 1):
        origin = f", origin: [l{i - 1}, 0, 0]" if i > 1 else ""
        lines.append(f"  - {{name: link{i}, joint: {{type: revolute, axis: z, q: q{i}{origin}}}, mass: m{i}, "
                     f"com: [d{i}, 0, 0], inertia: I{i}}}")
    return "\n".join(lines) + "\n"


def spatial_text(n: int, name: str, title: str, full: bool = False) -> str:
    """A spatial chain from the first ``n`` DH rows; ``full``: every link with a CoM vector of three
    parameters and a full inertia tensor (three moments, three products), as a URDF gives them."""
    rows = _DH[:n]
    used = {s for _, a, d in rows for s in (a, d) if s != "0"}
    lines = [f"name: {name}", f"title: {title}",
             f"coordinates: [{', '.join(f'q{i}' for i in range(1, n + 1))}]", "parameters:"]
    for s, v in _LENGTHS.items():
        if s in used:
            lines.append(f"  {s}: {{value: {v}, kind: length}}")
    for i in range(1, n + 1):
        lines.append(f"  m{i}: {{value: {_MASSES[i - 1]}, kind: mass}}")
        if full:
            for k, axis in enumerate("xyz"):
                lines.append(f"  c{axis}{i}: {{value: {round(0.01 * (k + 1) + 0.02 * i, 3)}, kind: com}}")
        else:
            lines.append(f"  c{i}: {{value: {_COMS[i - 1]}, kind: com}}")
        for axis, v in zip("xyz", _MOMENTS[i - 1]):
            lines.append(f"  I{axis}{i}: {{value: {v}, kind: inertia}}")
        if full:                        # products of inertia: a tenth of the smallest moment
            for pair in ("xy", "xz", "yz"):
                lines.append(f"  I{pair}{i}: {{value: {min(_MOMENTS[i - 1]) / 10:.3g}, kind: other}}")
    lines += ["  g0: {value: 9.81, kind: gravity}", "gravity: [0, 0, -g0]", "bodies:"]
    for i, (alpha, a, d) in enumerate(rows, start=1):
        if full:
            com = f"[cx{i}, cy{i}, cz{i}]"
            inertia = f"{{xx: Ix{i}, yy: Iy{i}, zz: Iz{i}, xy: Ixy{i}, xz: Ixz{i}, yz: Iyz{i}}}"
        else:
            com, inertia = f"[{', '.join(_COM[i - 1])}]", f"[Ix{i}, Iy{i}, Iz{i}]"
        lines.append(f"  - {{name: link{i}, dh: {{alpha: {alpha}, a: {a}, d: {d}, theta: q{i}}}, mass: m{i}, "
                     f"com: {com}, inertia: {inertia}}}")
    return "\n".join(lines) + "\n"


def robot_texts() -> dict:
    """{robot name: the text of its file} for every chain of the benchmark."""
    out = {f"chain_planar_{n}r": planar_text(n) for n in range(2, 8)}
    for n in range(2, 5):
        out[f"chain_spatial_{n}r"] = spatial_text(
            n, f"chain_spatial_{n}r", f"Spatial {n}R chain, first {n} rows of a PUMA-like DH table (benchmark)")
    out["chain_puma_6r"] = spatial_text(6, "chain_puma_6r", "PUMA-like 6R arm from DH rows, principal inertias (benchmark)")
    out["chain_puma_6r_full"] = spatial_text(6, "chain_puma_6r_full", "PUMA-like 6R arm from DH rows, full CoM "
                                             "vectors and inertia tensors (benchmark)", full=True)
    return out


def write_robots() -> None:
    for name, text in robot_texts().items():
        (HERE / f"{name}.yaml").write_text(text)


# ------------------------------------------------------------------------------ one measurement
def _one(kind: str, name: str) -> None:
    """Run in a fresh interpreter: print {"cpu": s, "wall": s} of one cold derivation."""
    from app.core.robot import load_robot
    robot = load_robot(HERE / f"{name}.yaml")
    if kind == "ours":
        from app.core.dynamics import derive
        run = lambda: derive(robot, use_cache=False)   # noqa: E731
    else:
        from benchmarks.derive import mechanics_baseline
        run = lambda: mechanics_baseline(robot, simplify=(kind == "simplify"))   # noqa: E731
    c0, w0 = time.process_time(), time.perf_counter()
    run()
    print(json.dumps({"cpu": time.process_time() - c0, "wall": time.perf_counter() - w0}))


def _cpu_limit(cap: float):
    def set_limit():   # the imports (a few seconds) count too
        resource.setrlimit(resource.RLIMIT_CPU, (int(cap) + 15, int(cap) + 16))
    return set_limit


def measure(kind: str, name: str, cap: float = CAP):
    """(cpu, wall) of one cold run in a child process, or None when it passed the cap. The cap is
    on CPU time (RLIMIT_CPU: the child is stopped by SIGXCPU), so a busy machine does not cut a run
    that a quiet one would finish; the wall clock only guards against a hang (WALL_FACTOR x cap)."""
    try:
        out = subprocess.run([sys.executable, "-m", "benchmarks.scaling", "--one", kind, name], cwd=ROOT,
                             capture_output=True, text=True, timeout=cap * WALL_FACTOR,
                             preexec_fn=_cpu_limit(cap))
    except subprocess.TimeoutExpired:
        return None
    if out.returncode != 0:
        if out.returncode in (-signal.SIGXCPU, -signal.SIGKILL):
            return None
        raise RuntimeError(f"{kind} {name} failed: {out.stderr.strip()[-500:]}")
    data = json.loads(out.stdout.strip().splitlines()[-1])
    return (None if data["cpu"] > cap else (data["cpu"], data["wall"]))


def _cell(m, cap=CAP) -> str:
    return f"> {cap:.0f}" if m is None else f"{m[0]:.1f} ({m[1]:.1f})"


def figures(baseline_cap: float = 30.0) -> list:
    """(name, wall s, CPU s, goal, note, "cpu") of the three chains with a goal, ours beside
    LagrangesMethod without simplify (the cheaper baseline), capped at ``baseline_cap`` s of CPU
    here so that ``python -m benchmarks`` stays short (the full table: ``main``)."""
    out = []
    for name, goal in GOALS.items():
        ours, plain = measure("ours", name), measure("plain", name, baseline_cap)
        if not plain:          # a lower bound on the ratio only while ours finished within the cap
            note = f"LagrangesMethod alone (unfinished after {baseline_cap:.0f} s CPU)"
            if ours and ours[0] < baseline_cap:
                note = f"> {baseline_cap / ours[0]:.1f}x faster than " + note
        else:
            note = f"LagrangesMethod alone ({plain[0]:.1f} s CPU)"
            if ours:
                note = f"{plain[0] / ours[0]:.1f}x faster than " + note
        out.append((f"derive {name} (cold, fresh process)", ours[1] if ours else CAP, ours[0] if ours else CAP,
                    goal, note, "cpu"))
    return out


def main(families=(PLANAR, SPATIAL + PUMA), kinds=("ours", "plain", "simplify")) -> None:
    """Every contender over every family (ours first: the baselines take far longer); a line per
    figure as it comes, then the table."""
    print(f"Cold derivation, CPU seconds (wall in brackets); one fresh process each, capped at {CAP:.0f} s CPU")
    print("ours: M, Christoffel, C, c, g, minimal + adaptive regressor, steps; plain: LagrangesMethod; "
          "simplify: LagrangesMethod + simplify(M), simplify(forcing)")
    table = {}
    for kind in kinds:
        for family in families:
            gave_up = False
            for name in family:
                m = None if gave_up else measure(kind, name)
                gave_up = m is None
                table[name, kind] = m
                print(f"  {name:<20}{kind:<10}{_cell(m)}", flush=True)
    print(f"\n{'robot':<20}" + "".join(f"{k:>18}" for k in kinds) + f"{'goal':>8}")
    for family in families:
        for name in family:
            goal = GOALS.get(name)
            print(f"{name:<20}" + "".join(f"{_cell(table[name, k]):>18}" for k in kinds)
                  + (f"{goal:>8.0f}" if goal else ""), flush=True)


if __name__ == "__main__":
    if sys.argv[1:2] == ["--one"]:
        _one(sys.argv[2], sys.argv[3])
    elif sys.argv[1:2] == ["--write"]:
        write_robots()
    elif sys.argv[1:2] == ["--kinds"]:      # e.g. --kinds plain,simplify: some columns only
        main(kinds=tuple(sys.argv[2].split(",")))
    else:
        main()
