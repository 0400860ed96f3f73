"""Command-line entry point. Each subcommand is a module in ``app/commands/`` that defines
``NAME``, ``HELP``, ``add_arguments(parser)`` and ``run(args) -> int``; they are discovered
automatically, so adding a command never touches this file.

Errors caused by user input print one line ``error: ...`` on stderr and exit with code 2: a
``UserError``, a usage error (argparse's usage text is left out), an option that is not a finite
number or a seed outside 0 ... 2**32 - 1, a file that cannot be opened or written (``OSError``),
input nested too deeply for the interpreter (``RecursionError``) or too big for the memory. A
message is cut to ``MAX_MESSAGE`` characters, so it never echoes more than an excerpt of the input.

>>> import contextlib, io
>>> err = io.StringIO()
>>> with contextlib.redirect_stderr(err):
...     code = main(["simulate", "planar_2r", "-T", "1e999"])
>>> code, err.getvalue().strip()
(2, "error: argument --duration/-T: '1e999' is not a finite number")
"""
from __future__ import annotations

import argparse
import importlib
import math
import pkgutil
import sys
import warnings
from pathlib import Path
from typing import List, Optional

from app.core.errors import UserError, excerpt

MAX_MESSAGE = 300
MAX_SEED = 2 ** 32 - 1


class UsageError(UserError):
    """A command line argparse refuses (wrong option, missing value, bad number)."""


class _Parser(argparse.ArgumentParser):
    """argparse with usage errors raised as one-line ``UsageError`` instead of usage text."""

    def error(self, message):
        raise UsageError(message)


def finite_float(text: str) -> float:
    """An option's number: finite (``1e308`` is, ``1e999``, ``nan``, ``inf`` are not)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{excerpt(text, 30)} is not a number") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"{excerpt(text, 30)} is not a finite number")
    return value


def seed(text: str) -> int:
    """A random seed: a whole number from 0 to 2**32 - 1 (what numpy's generators accept)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{excerpt(text, 30)} is not a whole number") from None
    if not 0 <= value <= MAX_SEED:
        raise argparse.ArgumentTypeError(f"a seed is a whole number from 0 to {MAX_SEED}, got {excerpt(text, 30)}")
    return value


def _bounded_types(parser) -> None:
    """Every float option finite, every ``--seed`` a valid seed (one rule for all commands)."""
    for action in parser._actions:      # argparse keeps the options here; no public accessor
        if action.type is float:
            action.type = finite_float
        elif action.type is int and action.dest == "seed":
            action.type = seed


def one_line(message: str) -> str:
    """A message as one line of at most ``MAX_MESSAGE`` characters."""
    message = " ".join(str(message).split())
    return message if len(message) <= MAX_MESSAGE else message[:MAX_MESSAGE - 3] + "..."


def _commands():
    import app.commands as pkg
    mods = []
    for info in sorted(pkgutil.iter_modules(pkg.__path__), key=lambda m: m.name):
        if info.name.startswith("_"):
            continue
        mod = importlib.import_module(f"app.commands.{info.name}")
        if hasattr(mod, "NAME") and hasattr(mod, "run"):
            mods.append(mod)
    return mods


def build_parser():
    parser = _Parser(prog="python -m app",
                                     description="Robotics II Lab: robot dynamics and control, interactively.")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    handlers = {}
    for mod in _commands():
        p = sub.add_parser(mod.NAME, help=mod.HELP, description=getattr(mod, "DESCRIPTION", mod.HELP))
        mod.add_arguments(p)
        _bounded_types(p)
        handlers[mod.NAME] = mod
    return parser, handlers


def main(argv: Optional[List[str]] = None) -> int:
    """Run a command; warnings it raised (numpy's overflow on the way to a refusal, ...) are shown
    only when it did not refuse its input, so that a refusal stays one line."""
    with warnings.catch_warnings(record=True) as caught:     # the filters in force still apply
        code = _main(argv)
    if code != 2:
        for w in caught:
            warnings.showwarning(w.message, w.category, w.filename, w.lineno)
    return code


def _main(argv: Optional[List[str]]) -> int:
    argv = sys.argv[1:] if argv is None else argv
    parser, handlers = build_parser()
    if not argv or (argv[0].startswith("-") and argv[0] not in ("-h", "--help")):
        argv = ["serve"] + list(argv)
    if any("\x00" in arg for arg in argv):    # no file name or value holds one; the OS refuses them
        return _refuse("an argument contains a null character")
    try:
        args = parser.parse_args(argv)
        if args.command is None:
            parser.print_help()
            return 0
        _check_output_folders(args)
        return int(handlers[args.command].run(args) or 0)
    except SystemExit as exc:   # --help, --version
        return int(exc.code or 0)
    except UserError as exc:
        return _refuse(str(exc))
    except OSError as exc:      # BrokenPipeError first: output piped into `head` and the like
        if isinstance(exc, BrokenPipeError):
            sys.stderr.close()
            return 0
        where = f"{exc.filename}: " if exc.filename else ""
        return _refuse(f"{where}{exc.strerror or exc}")
    except RecursionError:
        return _refuse("the input is nested too deeply")
    except MemoryError:
        return _refuse("the input needs more memory than this machine has")
    except KeyboardInterrupt:
        return 130


def _check_output_folders(args) -> None:
    """Refuse before any work an output (``--out``, ``--urdf``) whose folder does not exist."""
    for dest in ("out", "urdf"):
        value = getattr(args, dest, None)
        if isinstance(value, str) and value not in ("", "-"):
            folder = Path(value).expanduser().parent
            if not folder.is_dir():
                raise UserError(f"--{dest}: the folder {excerpt(str(folder), 80)} does not exist")


def _refuse(message: str) -> int:
    print(f"error: {one_line(message)}", file=sys.stderr)
    return 2
