"""``python -m app derive ROBOT [--json] [--known l1,g0] [--steps] [--latex FILE]``: the symbolic model of a robot.

``--latex FILE`` writes the model as a LaTeX fragment (amsmath; app/core/tex.py; ``-``: standard
output), with the derivation steps when ``--steps`` is given too.

JSON output (a stable contract): one object with keys
  "robot", "q" (coordinate names), "dq" (velocity symbol names), "params" (parameter names),
  "M" (rows), "C" (rows), "c", "g", "spring", "friction" (lists), "christoffel" (one matrix per
  coordinate, c_i = dq^T C_i dq), "Y" (rows), "a" (list), "Y_r" (rows, adaptive regressor with
  reference symbols dq1_r, ddq1_r ...), "known" (parameters treated as known in Y), "known_terms"
  and "known_terms_r" (y0, y0_r: terms with no unknown parameter, so that Y a + y0 = the model;
  zero for most robots).
Every entry is a string that ``sympy.sympify`` parses back with exactly the file's symbol names.
"""
from __future__ import annotations

import json
import sys

NAME = "derive"
HELP = "derive the dynamic model of a robot (shipped name or robot file)"


def add_arguments(p):
    p.add_argument("robot", help="a shipped robot's name (see `python -m app robots`) or a path to a robot file")
    p.add_argument("--json", action="store_true", help="print one JSON object (stable format)")
    p.add_argument("--known", default=None,
                   help="comma-separated parameters treated as known in the regressor (default: lengths, gravity, angles)")
    p.add_argument("--steps", action="store_true", help="also print the derivation steps")
    p.add_argument("--latex", metavar="FILE",
                   help="write the model as a LaTeX fragment (amsmath) to FILE ('-': standard output)")
    p.add_argument("--no-cache", action="store_true", help="derive from scratch")


def _rows(m):
    """A sympy matrix as rows of expression texts."""
    return [[str(m[i, j]) for j in range(m.cols)] for i in range(m.rows)]


def _vec(m):
    """A sympy column as a list of expression texts."""
    return [str(e) for e in m]


def model_json(robot, dyn) -> dict:
    par = dyn.parametrization
    return {
        "robot": robot.name,
        "q": list(robot.coordinates),
        "dq": [str(s) for s in robot.dq],
        "params": list(robot.parameters),
        "M": _rows(dyn.M), "C": _rows(dyn.C), "c": _vec(dyn.c), "g": _vec(dyn.g),
        "spring": _vec(dyn.spring), "friction": _vec(dyn.friction),
        "christoffel": [_rows(Ci) for Ci in dyn.christoffel],
        "Y": _rows(par.Y), "a": [str(e) for e in par.a], "Y_r": _rows(par.Y_ref), "known": par.known,
        "known_terms": _vec(par.known_terms), "known_terms_r": _vec(par.known_terms_ref),
    }


def write_text(path: str, text: str, option: str, quiet: bool = False) -> int:
    """Write ``text`` to the file ``path`` (``-``: standard output) and say so unless ``quiet``;
    exit code 0."""
    from app.core.errors import UserError
    if path == "-":
        sys.stdout.write(text)
        return 0
    try:
        with open(path, "w", encoding="utf-8") as fh:
            fh.write(text)
    except OSError as exc:
        raise UserError(f"{option} {path}: {exc.strerror or exc}") from None
    if not quiet:
        print(f"wrote {path}")
    return 0


def run(args) -> int:
    """The model as text, JSON or LaTeX; the text and JSON forms come from app.core.output_cache
    (no sympy imported) when this robot file was derived and printed so before."""
    if args.latex or args.no_cache:
        return _run(args)
    from app.core import output_cache
    options = {"json": args.json, "known": args.known, "steps": args.steps,
               "width": None if args.json else output_cache.terminal_width()}
    return output_cache.run_cached("derive", output_cache.robot_file(args.robot), options, lambda: (_run(args), ()))


def _run(args) -> int:
    from app.core.dynamics import derive
    from app.core.errors import UserError
    from app.core.robot import load_robot
    from app.core.mathtext import to_unicode

    robot = load_robot(args.robot)
    known = None
    if args.known is not None:
        known = [k.strip() for k in args.known.split(",") if k.strip()]
        bad = [k for k in known if k not in robot.parameters]
        if bad:
            raise UserError(f"--known: unknown parameter(s) {bad}; the robot has {list(robot.parameters)}")
    dyn = derive(robot, use_cache=not args.no_cache, known=known)
    if args.latex:
        from app.core.tex import model_tex
        return write_text(args.latex, model_tex(robot, dyn, steps=args.steps), "--latex")
    if args.json:
        json.dump(model_json(robot, dyn), sys.stdout)
        sys.stdout.write("\n")
        return 0
    import sympy as sp
    out = sys.stdout
    print(f"{robot.title}  [{robot.name}]", file=out)
    print(f"coordinates q = {list(robot.coordinates)}", file=out)
    print("\nM(q) =", file=out)
    print(sp.pretty(dyn.M, use_unicode=True), file=out)
    print("\nc(q, dq) =", file=out)
    print(sp.pretty(dyn.c, use_unicode=True), file=out)
    print("\nC(q, dq) =", file=out)
    print(sp.pretty(dyn.C, use_unicode=True), file=out)
    print("\ng(q) =", file=out)
    print(sp.pretty(dyn.g, use_unicode=True), file=out)
    if robot.springs:
        print("\nspring terms k(q) =", file=out)
        print(sp.pretty(dyn.spring, use_unicode=True), file=out)
    if robot.has_friction:
        print("\nfriction =", file=out)
        print(sp.pretty(dyn.friction, use_unicode=True), file=out)
    par = dyn.parametrization
    print(f"\nlinear parametrization Y a = tau with {par.count} coefficients (known: {', '.join(par.known) or 'none'}):", file=out)
    if any(e != 0 for e in par.known_terms):
        print("known terms y0 (tau = Y a + y0):", [str(e) for e in par.known_terms], file=out)
    for i, a in enumerate(par.a, 1):
        print(f"  a{i} = {a}", file=out)
    print("Y =", file=out)
    print(sp.pretty(par.Y, use_unicode=True), file=out)
    if args.steps:
        print("\nsteps:", file=out)
        for k, st in enumerate(dyn.steps, 1):
            print(f"{k:2d}. {to_unicode(st.title)}: {to_unicode(st.text)}", file=out)
    return 0
