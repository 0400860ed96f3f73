"""Fuzzing the command line as a hostile user would (issue 15): robot files, exercise files, throw
configurations and options, made by mutating the shipped files and from the formats' grammar, each
run in-process through ``app.cli.main`` with a time limit.

The property: either a success whose result holds up (a robot's M symmetric positive definite at
the file's values and random states; a JSON result that parses, with finite numbers where
numbers are due) or a refusal, i.e. exit code 2 and exactly one line ``error: ...`` of at most
320 characters on stderr; never a traceback, never a hang.

Run: ``python -m benchmarks.fuzz --cases 5000 --seed 1`` (prints the counts per outcome and per
kind of input, and the first few cases of each bad outcome). tests/test_fuzz.py runs the same
generators on a few dozen cases under hypothesis.
"""
from __future__ import annotations

import argparse
import contextlib
import copy
import io
import json
import math
import os
import random
import re
import signal
import tempfile
import time
import traceback
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Dict, List, Optional

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
ROBOTS = ROOT / "app" / "robots"
MAX_REFUSAL_CHARS = 320

# robots and exercises cheap enough to derive and solve within a case's time limit
ROBOT_BASES = ("planar_2r", "rp_2004_03_25", "pendulum_payload", "elastic_pendulum_damped")
EXERCISE_BASES = ("2004-03-25_1", "2005-04-05_1")
THROW_BASES = ("throw1", "throw2", "throw3")

# values a hostile user types: out of domain, not real, not finite, huge, deep, of the wrong type
NASTY = [
    -1, 0, -0.0, 1e308, -1e308, 1e-320, 10 ** 400, float("nan"), float("inf"), True, None, "", " ",
    [], {}, [1, 2, 3], {"a": 1}, "nan", ".inf", "-.inf", "sqrt(-1)", "acos(2)", "log(0)", "tan(pi/2)",
    "0**-1", "1/0", "((((9**64)**64)**64)**64)", "((m1+d1)**64+l1)**64", "2**2**2**2**2**2",
    "-" * 1200 + "1", "(" * 300 + "1" + ")" * 300, "sin(q2)", "q1", "\uff4d1", "m1.__class__",
    "__import__('os').system('true')", "lambda: 1", "x" * 5000, "1e999", "-(m2)", "m1 +", "𝑚1",
    "\x00", "a" * 70, "I1 - 100", "-m1", "1e-300", "9" * 400,
]


def nasty_value(rnd: random.Random):
    """A value from the list above, or a random number of any magnitude and sign."""
    if rnd.random() < 0.25:
        return rnd.choice([-1, 1]) * 10 ** rnd.uniform(-12, 12)
    return copy.deepcopy(rnd.choice(NASTY))


# ---------------------------------------------------------------------------------- mutations
def _paths(data, prefix=()):
    """Every path (tuple of keys/indices) into nested dicts and lists."""
    yield prefix
    if len(prefix) > 12:        # below that, a node nested deeply by an earlier edit
        return
    if isinstance(data, dict):
        for key, value in data.items():
            yield from _paths(value, prefix + (key,))
    elif isinstance(data, list):
        for i, value in enumerate(data):
            yield from _paths(value, prefix + (i,))


def _set(data, path, value):
    if not path:
        return value
    node = data
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = value
    return data


def _get(data, path):
    for key in path:
        data = data[key]
    return data


def mutate_data(data, rnd: random.Random, count: int = 1):
    """``count`` random edits of nested data: a value replaced by a nasty one, a key deleted or
    added, a list emptied, lengthened or turned into a mapping, a node nested deeply."""
    data = copy.deepcopy(data)
    for _ in range(count):
        paths = list(_paths(data))
        path = rnd.choice(paths)
        node = _get(data, path)
        op = rnd.randrange(7)
        if op == 0 or not path:
            data = _set(data, path, nasty_value(rnd)) if path else data
        elif op == 1:
            parent = _get(data, path[:-1])
            del parent[path[-1]]
        elif op == 2 and isinstance(node, dict):
            node[rnd.choice(["extra", "mass", "q", "name", "value", "kind"])] = nasty_value(rnd)
        elif op == 3 and isinstance(node, list):
            data = _set(data, path, node * rnd.choice([0, 2, 7]))
        elif op == 4:
            data = _set(data, path, {"value": node} if rnd.random() < 0.5 else [node])
        elif op == 5:       # nested lists, written out by _dump (too deep for the YAML writer)
            data = _set(data, path, f"__DEEP_{rnd.choice([10, 200, 1500])}__")
        else:
            data = _set(data, path, nasty_value(rnd))
    return data


ALIAS_BOMB = "".join(f"b{i}: &b{i} [" + ", ".join([f"*b{i - 1}"] * 9) + "]\n" for i in range(1, 9))


def mutate_text(text: str, rnd: random.Random) -> str:
    """Edits of the file's text itself: cut short, an alias bomb, deep nesting, garbage bytes,
    tabs, a byte-order mark, a huge file."""
    op = rnd.randrange(7)
    if op == 0:
        return text[:rnd.randrange(len(text) + 1)]
    if op == 1:
        return text + "b0: &b0 [x, x, x, x, x, x, x, x, x]\n" + ALIAS_BOMB + "notes: *b8\n"
    if op == 2:
        return text + "notes: " + "[" * 5000 + "]" * 5000 + "\n"
    if op == 3:
        i = rnd.randrange(len(text) + 1)
        return text[:i] + "".join(chr(rnd.randrange(0x10000)) for _ in range(8)) + text[i:]
    if op == 4:
        return text.replace("  ", "\t", rnd.randrange(1, 4))
    if op == 5:
        return "\ufeff" + text
    return text + "# " + "x" * 1_100_000 + "\n"


# ---------------------------------------------------------------------------------- grammar
JOINT_AXES = ["x", "y", "z", [0, 0, 1], [1, 1, 0], "w", [0, 0, 0]]


def grammar_robot(rnd: random.Random) -> dict:
    """A robot file drawn from the format's grammar (docs/robot-format.md): a chain of one to
    three bodies, revolute or prismatic joints, parameters of each kind, sometimes wrong."""
    n = rnd.randint(1, 3)
    params, bodies = {}, []
    kinds = {"m": "mass", "l": "length", "d": "com", "I": "inertia"}
    for i in range(1, n + 1):
        for letter, kind in kinds.items():
            value = rnd.uniform(0.1, 5) if rnd.random() < 0.9 else nasty_value(rnd)
            params[f"{letter}{i}"] = {"value": value, "kind": kind}
        joint = {"type": rnd.choice(["revolute", "prismatic"] * 4 + ["helical", 3]),
                 "axis": rnd.choice(JOINT_AXES[:4] * 3 + JOINT_AXES[4:]), "q": f"q{i}"}
        if i > 1:
            joint["origin"] = [f"l{i - 1}", 0, 0]
        body = {"name": f"link{i}", "joint": joint, "mass": f"m{i}", "com": [f"d{i}", 0, 0],
                "inertia": f"I{i}"}
        if rnd.random() < 0.15:
            body[rnd.choice(["mass", "com", "inertia"])] = nasty_value(rnd)
        bodies.append(body)
    params["g0"] = {"value": 9.81, "kind": "gravity"}
    robot = {"name": "fuzzed", "coordinates": [f"q{i}" for i in range(1, n + 1)], "parameters": params,
             "gravity": rnd.choice([[0, "-g0", 0], [0, 0, "-g0"], ["g0", 0, 0]]), "bodies": bodies}
    if rnd.random() < 0.3:
        robot["friction"] = {f"q{i}": {"viscous": rnd.choice([0.1, -0.5, "fv"])} for i in range(1, n + 1)}
    return robot


def grammar_throw(rnd: random.Random) -> dict:
    """A throw configuration from its keys (docs/cli.md, throw): values in or out of range."""
    degree = rnd.randint(1, 8)
    cfg = {"theta_b": rnd.uniform(-1, 0), "theta_e": rnd.uniform(-0.2, 1), "psi_deg": rnd.uniform(-90, 90),
           "k": rnd.uniform(-5, 50), "a": [rnd.uniform(-3, 3) for _ in range(degree + 1)],
           "b": [rnd.uniform(-3, 3) for _ in range(degree + 1)]}
    if rnd.random() < 0.3:
        cfg["theta_dot_b"] = rnd.uniform(-1, 3)
    if rnd.random() < 0.3:
        cfg["model"] = {f"m{rnd.randint(1, 3)}": rnd.uniform(-1, 5), "g": rnd.uniform(-10, 20)}
    if rnd.random() < 0.3:
        cfg["branch"] = rnd.choice([1, -1, 0, 2, "x"])
    return cfg


# ---------------------------------------------------------------------------------- cases
@dataclass
class Case:
    """One command line and the files it reads (written into a fresh folder before the run)."""
    kind: str
    argv: List[str]
    files: Dict[str, str] = field(default_factory=dict)
    check: Optional[str] = None        # what a success must satisfy: "robot", "json"

    def describe(self) -> str:
        return f"[{self.kind}] python -m app " + " ".join(a if len(a) < 60 else a[:57] + "..." for a in self.argv)


def _dump(data) -> str:
    text = yaml.safe_dump(data, sort_keys=False, allow_unicode=True, width=120)
    return re.sub(r"__DEEP_(\d+)__", lambda m: "[" * int(m.group(1)) + "1" + "]" * int(m.group(1)), text)


def _shipped(folder: Path, stem: str) -> str:
    return (folder / f"{stem}.yaml").read_text(encoding="utf-8")


def robot_case(rnd: random.Random) -> Case:
    if rnd.random() < 0.35:
        text = _dump(grammar_robot(rnd))
        kind = "robot:grammar"
    else:
        text = _shipped(ROBOTS, rnd.choice(ROBOT_BASES))
        if rnd.random() < 0.7:
            text = _dump(mutate_data(yaml.safe_load(text), rnd, rnd.randint(1, 3)))
            kind = "robot:mutated"
        else:
            text = mutate_text(text, rnd)
            kind = "robot:text"
    return Case(kind, ["derive", "{dir}/robot.yaml", "--json"], {"robot.yaml": text}, "robot")


def exercise_case(rnd: random.Random) -> Case:
    text = _shipped(ROOT / "app" / "exercises", rnd.choice(EXERCISE_BASES))
    if rnd.random() < 0.75:
        data = yaml.safe_load(text)
        data = mutate_data(data, rnd, rnd.randint(1, 2))
        text, kind = _dump(data), "exercise:mutated"
    else:
        text, kind = mutate_text(text, rnd), "exercise:text"
    return Case(kind, ["solve", "{dir}/exercise.yaml", "--json"], {"exercise.yaml": text}, "json")


def throw_case(rnd: random.Random) -> Case:
    if rnd.random() < 0.35:
        text, kind = _dump(grammar_throw(rnd)), "throw:grammar"
    else:
        text = (ROOT / "app" / "throws" / f"{rnd.choice(THROW_BASES)}.yaml").read_text(encoding="utf-8")
        if rnd.random() < 0.7:
            text, kind = _dump(mutate_data(yaml.safe_load(text), rnd, rnd.randint(1, 3))), "throw:mutated"
        else:
            text, kind = mutate_text(text, rnd), "throw:text"
    return Case(kind, ["throw", "{dir}/throw.yaml", "--json"], {"throw.yaml": text}, "json")


def _text(value) -> str:
    return value if isinstance(value, str) else repr(value) if not isinstance(value, float) else f"{value!r}"


OPTION_TEMPLATES = [
    (["simulate", "planar_2r", "-c", "pd", "-T", "0.05", "--json", "-o", "{dir}/run.csv"],
     ["-T", "--rate", "--substeps", "--q0", "--dq0", "--gains", "--reference", "--plant", "--model",
      "--viscous", "--saturation", "--passive", "--observer", "--point", "-c", "--force", "--surface"]),
    (["solve", "2004-03-25#1", "--json"], ["--set", "--out"]),
    (["check-answer", "planar_2r", "--entry", "m22"], ["--answer", "--entry", "--hint"]),
    (["derive", "planar_2r", "--json"], ["--known", "robot"]),
    (["throw", "throw1", "--json"], ["--robot", "config", "--seed", "--degree"]),
    # a positive --budget is legitimate long work, not fuzzed: budget 0 makes valid cases end at once
    (["throw", "--optimize", "--json", "--budget", "0"], ["--seed", "--degree", "--objective"]),
    (["check", "planar_2r"], ["--states", "--seed"]),
    (["export", "planar_2r", "--urdf", "-"], ["--urdf", "robot"]),
    (["sheet", "2004-03-25#1", "--no-pdf", "--out", "{dir}/sheet"], ["--seed", "--out"]),
]


def option_case(rnd: random.Random) -> Case:
    """A command whose one option (or positional argument) gets a hostile value."""
    base, options = rnd.choice(OPTION_TEMPLATES)
    argv = list(base)
    option = rnd.choice(options)
    value = _text(nasty_value(rnd))
    if option in ("--set", "--gains", "--plant", "--model"):
        value = f"{rnd.choice(['m1', 'Kp', 'm2', 'x', ''])}={value}"
    elif option == "--reference":
        value = f"{rnd.choice(['quintic', 'sine', 'setpoint', 'bogus'])} goal={value} T={_text(nasty_value(rnd))}"
    elif option in ("--force", "--surface"):
        value = f"ee {rnd.choice(['F', 'normal', 'k'])}={value}"
    elif option in ("--out", "--urdf"):     # files are written only inside the case's folder
        value = rnd.choice(["/nonexistent/x", "/dev/null", "/", "{dir}", "{dir}/" + value.replace("/", "_")[:80]])
    positional = {"robot": 1, "config": 1}
    if option in positional:
        argv[positional[option]] = value
    elif option == "-T" or option in argv:
        i = argv.index(option)
        argv[i + 1] = value
    else:
        argv += [option, value] if option != "--entry" else []
        if option == "--entry":
            argv[argv.index("--entry") + 1] = value
    if argv[0] == "check-answer" and "--answer" not in argv:
        argv += ["--answer", "I2 + m2*d2**2"]
    if rnd.random() < 0.5:      # also written as --opt=value, so that leading '-' survives argparse
        for i, a in enumerate(argv[:-1]):
            if a == option and a.startswith("--"):
                argv[i:i + 2] = [f"{a}={argv[i + 1]}"]
                break
    check = "json" if "--json" in argv else None
    return Case("options:" + argv[0], argv, {}, check)


GENERATORS: Dict[str, Callable[[random.Random], Case]] = {
    "robot": robot_case, "exercise": exercise_case, "throw": throw_case, "options": option_case}


def make_case(rnd: random.Random, family: Optional[str] = None) -> Case:
    family = family or rnd.choice(list(GENERATORS))
    return GENERATORS[family](rnd)


# ---------------------------------------------------------------------------------- running
class Hang(BaseException):
    """Raised by the timer when a case runs past its time limit (BaseException: the lab's
    ``except Exception`` handlers must not swallow it)."""


@dataclass
class Outcome:
    case: Case
    verdict: str            # refusal, success, traceback, hang, messy refusal, wrong success
    code: Optional[int]
    stderr: str
    seconds: float
    detail: str = ""


def _alarm(signum, frame):
    raise Hang()


def _finite_numbers(obj) -> bool:
    if isinstance(obj, float):
        return math.isfinite(obj)
    if isinstance(obj, dict):
        return all(_finite_numbers(v) for v in obj.values())
    if isinstance(obj, list):
        return all(_finite_numbers(v) for v in obj)
    return True


def check_robot(path: Path, rnd: random.Random) -> str:
    """'' when M(q) of the robot file at its own values is symmetric positive definite at a few
    random states, else what is wrong."""
    from app.core.numeric import NumericModel
    from app.core.robot import load_robot
    robot = load_robot(str(path))
    model = NumericModel(robot)
    for _ in range(3):
        q = np.array([rnd.uniform(-1.5, 1.5) for _ in robot.coordinates])
        M = model.M(q)
        if not np.all(np.isfinite(M)):
            return f"M not finite at q = {q}"
        if not np.allclose(M, M.T, rtol=1e-9, atol=1e-12):
            return f"M not symmetric at q = {q}"
        if np.linalg.eigvalsh(0.5 * (M + M.T)).min() <= 0:
            return f"M not positive definite at q = {q}"
    return ""


def run_case(case: Case, limit_s: float = 10.0, seed: int = 0, cpu_clock: bool = False) -> Outcome:
    """Run one case in this process (the folder ``{dir}`` made fresh) and judge it. The time limit
    is wall time, or with ``cpu_clock`` the process's CPU time (SIGPROF: leaves SIGALRM to
    pytest-timeout, and a busy machine does not turn a slow case into a hang)."""
    timer, signum = (signal.ITIMER_PROF, signal.SIGPROF) if cpu_clock else (signal.ITIMER_REAL, signal.SIGALRM)
    from app.cli import main
    with tempfile.TemporaryDirectory(prefix="r2fuzz") as folder:
        for name, text in case.files.items():
            Path(folder, name).write_text(text, encoding="utf-8", errors="surrogatepass")
        argv = [a.replace("{dir}", folder) for a in case.argv]
        out, err = io.StringIO(), io.StringIO()
        cwd = os.getcwd()
        os.chdir(folder)        # a relative path in a hostile option writes there, not in the repository
        previous = signal.signal(signum, _alarm)
        start = time.perf_counter()
        code, verdict, detail = None, "", ""
        try:
            signal.setitimer(timer, limit_s)
            with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
                code = main(argv)
            signal.setitimer(timer, 0)
        except Hang:
            verdict = "hang"
        except BaseException as exc:   # noqa: BLE001 -- anything escaping main is a traceback
            signal.setitimer(timer, 0)
            where = [f"{Path(f.filename).name}:{f.lineno}" for f in traceback.extract_tb(exc.__traceback__)[-3:]]
            verdict, detail = "traceback", f"{type(exc).__name__}: {str(exc)[:200]} (at {' < '.join(reversed(where))})"
        finally:
            signal.setitimer(timer, 0)
            signal.signal(signum, previous)
            os.chdir(cwd)
        seconds = time.perf_counter() - start
        stderr = err.getvalue()
        if not verdict:
            verdict, detail = _judge(case, code, stderr, out.getvalue(), folder, random.Random(seed))
        return Outcome(case, verdict, code, stderr, seconds, detail)


def _judge(case, code, stderr, stdout, folder, rnd):
    if "Traceback (most recent call last)" in stderr:
        return "traceback", stderr.strip().splitlines()[-1][:200]
    if code == 2:
        lines = stderr.strip().splitlines()
        if len(lines) == 1 and lines[0].startswith("error: ") and len(lines[0]) <= MAX_REFUSAL_CHARS:
            return "refusal", lines[0]
        return "messy refusal", f"{len(lines)} lines, {len(stderr)} characters: {stderr[:200]!r}"
    if code not in (0, 1):
        return "traceback", f"exit code {code}"
    try:
        if case.check == "robot":
            problem = check_robot(Path(folder, "robot.yaml"), rnd)
            return ("wrong success", problem) if problem else ("success", "")
        if case.check == "json" and code == 0:
            data = json.loads(stdout)
            if not _finite_numbers(data):
                return "wrong success", "a number in the JSON output is not finite"
    except Hang:
        raise
    except Exception as exc:       # noqa: BLE001 -- a success that cannot be checked is wrong
        return "wrong success", f"{type(exc).__name__}: {str(exc)[:200]}"
    return "success", ""


BAD = ("traceback", "hang", "messy refusal", "wrong success")


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.fuzz", description=__doc__.split("\n\n")[0])
    parser.add_argument("--cases", type=int, default=200)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--limit", type=float, default=20.0,
                        help="seconds of CPU time per case before it counts as a hang (wall time with --wall)")
    parser.add_argument("--wall", action="store_true", help="limit wall time instead of CPU time")
    parser.add_argument("--memory-gb", type=float, default=4.0, help="address-space cap of this process")
    args = parser.parse_args(argv)
    import resource
    cap = int(args.memory_gb * 2 ** 30)
    resource.setrlimit(resource.RLIMIT_AS, (cap, resource.getrlimit(resource.RLIMIT_AS)[1]))
    os.environ.setdefault("R2LAB_CACHE", tempfile.mkdtemp(prefix="r2fuzz-cache"))
    rnd = random.Random(args.seed)
    counts, by_kind = Counter(), Counter()
    cpu0, wall0 = time.process_time(), time.perf_counter()
    for i in range(args.cases):
        case = make_case(rnd)
        outcome = run_case(case, args.limit, seed=args.seed + i, cpu_clock=not args.wall)
        counts[outcome.verdict] += 1
        by_kind[(case.kind, outcome.verdict)] += 1
        if outcome.verdict in BAD:
            print(f"case {i}: {outcome.verdict}: {case.describe()} -> {outcome.detail}", flush=True)
        if (i + 1) % 250 == 0:
            print(f"after {i + 1} cases: " + ", ".join(f"{v} {counts[v]}" for v in ("refusal", "success") + BAD)
                  + f" ({time.perf_counter() - wall0:.0f} s wall, {time.process_time() - cpu0:.0f} s CPU)", flush=True)
    print(f"\n{args.cases} cases, seed {args.seed}, limit {args.limit:g} s of {'wall' if args.wall else 'CPU'} "
          "time per case: "
          f"{time.perf_counter() - wall0:.0f} s wall, {time.process_time() - cpu0:.0f} s CPU")
    for verdict in ("refusal", "success") + BAD:
        print(f"  {verdict:14} {counts[verdict]}")
    print("by kind of input:")
    for kind in sorted({k for k, _ in by_kind}):
        parts = ", ".join(f"{v} {by_kind[(kind, v)]}" for v in ("refusal", "success") + BAD if by_kind[(kind, v)])
        print(f"  {kind:24} {parts}")


if __name__ == "__main__":
    main()
