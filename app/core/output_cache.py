"""What ``derive`` and ``solve`` printed, kept on disk: a command whose answer is cached prints it
without importing the symbolic engine (issue 16: a cached command starts in at most 0.5 s of CPU;
importing sympy and numpy alone takes more).

This module uses the standard library only (and app.core.model_cache's envelope functions and
app.core.catalog's rule that finds the file a reference names, which do too). An entry is a JSON file in the cache's ``outputs/`` folder, written and read like a
derivation (``model_cache.write_entry`` / ``read_entry``: data, never code; a foreign, stale or
corrupt entry is ignored and overwritten by the next computation). Its envelope, all of which must
match:

- the command and its options (``--json``, ``--known``, ``--steps``, ``--set`` ...; the terminal's
  width for the text forms, which sympy's pretty printer wraps to);
- the file named on the command line: its resolved path and the hash of its content;
- the engine version: a hash of the source of app/core (every module), of the commands (which
  render), of the shipped throw data, and of the installed sympy and numpy versions.

The payload holds the text printed and the other files the answer read (an exercise's robot file),
each with the reference it was named by and the hash of its content; when one of them changed, or
the reference now names another file, the entry does not count. The computed text and the cached
text are the same bytes (tests/test_import_graph.py compares them).

>>> import tempfile, os
>>> saved = os.environ.get("R2LAB_CACHE")
>>> os.environ["R2LAB_CACHE"] = tempfile.mkdtemp()
>>> source = Path(tempfile.mkdtemp()) / "robot.yaml"
>>> _ = source.write_text("name: demo")
>>> def compute():
...     print("computed")
...     return 0, []
>>> run_cached("derive", source, {"json": True}, compute)
computed
0
>>> run_cached("derive", source, {"json": True}, lambda: 1 / 0)       # from the cache
computed
0
>>> if saved is None: del os.environ["R2LAB_CACHE"]
... else: os.environ["R2LAB_CACHE"] = saved
"""
from __future__ import annotations

import contextlib
import hashlib
import importlib.util
import io
import shutil
import sys
from pathlib import Path
from typing import Callable, Iterable, List, Mapping, Optional, Tuple

from . import model_cache
from .catalog import (EXERCISE_SUFFIXES, EXERCISES_DIR, ROBOT_SUFFIXES, ROBOTS_DIR,  # noqa: F401 (the folders: used by tests)
                      named_file, shipped_exercise, shipped_robot)

FORM = "robotics2lab-output"
FOLDER = "outputs"
MAX_FILE_BYTES = 1_000_000          # app.core.files.MAX_FILE_BYTES: a larger file is refused anyway

APP_DIR = Path(__file__).resolve().parent.parent

#: compute() -> (exit code, [(reference, path)] of the other files read); it prints its output
Compute = Callable[[], Tuple[int, Iterable[Tuple[str, str]]]]

_engine: Optional[str] = None


def engine_version() -> str:
    """Hash of everything a rendered output depends on besides its files (see the module's doc)."""
    global _engine
    if _engine is None:
        files = sorted((APP_DIR / "core").rglob("*.py")) + sorted((APP_DIR / "throws").rglob("*.yaml"))
        files += sorted((APP_DIR / "commands").glob("*.py"))
        for package, name in (("sympy", "release.py"), ("numpy", "version.py")):
            spec = importlib.util.find_spec(package)     # finds the package without importing it
            if spec is not None and spec.origin:
                files.append(Path(spec.origin).parent / name)
        _engine = digest_of_files(files, f"{sys.version_info[:2]}")
    return _engine


def digest_of_files(files, seed: str = "") -> str:
    """16 hex digits of sha256 over ``seed`` and every file's name (relative to app/ when inside it)
    and bytes ('-' for a file that cannot be read): a cache's version."""
    h = hashlib.sha256(seed.encode())
    for path in files:
        h.update(str(path.relative_to(APP_DIR) if APP_DIR in path.parents else path.name).encode())
        try:
            h.update(path.read_bytes())
        except OSError:
            h.update(b"-")
    return h.hexdigest()[:16]


def file_hash(path) -> Optional[str]:
    """sha256 of a regular file's content, None when it cannot be read or is too large."""
    try:
        with open(path, "rb") as fh:
            data = fh.read(MAX_FILE_BYTES + 1)
    except (OSError, ValueError):
        return None
    return None if len(data) > MAX_FILE_BYTES else hashlib.sha256(data).hexdigest()


def _existing(path: Path) -> Optional[Path]:
    try:
        return path.resolve() if path.is_file() else None
    except (OSError, ValueError, RuntimeError):
        return None


def robot_file(name_or_path: str) -> Optional[Path]:
    """The file ``app.core.robot.robot_path`` resolves a robot reference to (None: not found,
    the command then computes and says why)."""
    try:
        found = named_file(name_or_path, shipped_robot(name_or_path), ROBOT_SUFFIXES)
        return _existing(found) if found is not None else None
    except (OSError, ValueError):
        return None


def exercise_file(id_or_path: str) -> Optional[Path]:
    """The file ``app.core.exercise.exercise_path`` resolves an exercise reference to (or None)."""
    try:
        found = named_file(id_or_path, shipped_exercise(id_or_path), EXERCISE_SUFFIXES)
        return _existing(found) if found is not None else None
    except (OSError, ValueError):
        return None


def terminal_width() -> int:
    """The width sympy's pretty printer wraps to (its ``stringPict.terminal_width``)."""
    return shutil.get_terminal_size(fallback=(0, 0)).columns


def _envelope(command: str, primary: Path, digest: str, options: Mapping) -> dict:
    import json
    return {"command": command, "file": str(primary), "sha": digest, "engine": engine_version(),
            "options": json.dumps(dict(options), sort_keys=True)}


def lookup(command: str, primary: Optional[Path], options: Mapping) -> Optional[str]:
    """The cached output of ``command`` on the file ``primary`` with ``options``, or None."""
    if primary is None:
        return None
    digest = file_hash(primary)
    if digest is None:
        return None
    envelope = _envelope(command, primary, digest, options)
    path = model_cache.entry_path("|".join(envelope.values()), FOLDER)
    payload = model_cache.read_entry(path, envelope, FORM)
    if payload is None:
        return None
    text, deps = payload.get("text"), payload.get("files")
    if not isinstance(text, str) or not isinstance(deps, list):
        return None
    for dep in deps:
        if not (isinstance(dep, list) and len(dep) == 3 and all(isinstance(x, str) for x in dep)):
            return None
        ref, where, digest = dep
        found = robot_file(ref)
        if found is None or str(found) != where or file_hash(found) != digest:
            return None
    return text


def store(command: str, primary: Path, options: Mapping, text: str, deps: Iterable[Tuple[str, str]],
          digest: str) -> bool:
    """Keep an output computed from ``primary`` whose content hashed to ``digest`` before the
    computation (so that a file edited meanwhile is not stored under its new content)."""
    files: List[list] = []
    for ref, where in deps:
        found = robot_file(ref)
        dep_digest = file_hash(found) if found is not None else None
        if found is None or dep_digest is None or found != Path(where).resolve():
            return False
        files.append([ref, str(found), dep_digest])
    envelope = _envelope(command, primary, digest, options)
    path = model_cache.entry_path("|".join(envelope.values()), FOLDER)
    return model_cache.write_entry(path, envelope, {"text": text, "files": files}, FORM)


def run_cached(command: str, primary: Optional[Path], options: Mapping, compute: Compute) -> int:
    """Print the cached output when there is one (exit code 0); else run ``compute`` with its
    standard output captured, print what it printed, and keep it when it succeeded (code 0)."""
    text = lookup(command, primary, options)
    if text is not None:
        sys.stdout.write(text)
        return 0
    digest = file_hash(primary) if primary is not None else None
    buffer = io.StringIO()
    try:
        with contextlib.redirect_stdout(buffer):
            code, deps = compute()
    finally:
        sys.stdout.write(buffer.getvalue())
    if code == 0 and digest is not None and file_hash(primary) == digest:
        store(command, primary, options, buffer.getvalue(), deps, digest)
    return code
