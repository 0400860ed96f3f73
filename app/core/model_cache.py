"""The derivation cache on disk: derived models stored as data that cannot run code.

An entry is a JSON file holding the format's name and version, the engine version (a hash of the
engine's source), the robot file's content hash, the key of the derivation and the model, whose
expressions are exact texts (``expressions.dump_exact``) read back through the ``ast`` whitelist
(``expressions.load_exact``). Nothing is unpickled or evaluated. An entry that is foreign, stale or
corrupt (not JSON, wrong type, wrong version, another robot, garbage, a planted pickle) is ignored,
and the caller rebuilds and overwrites it.

Location: ``$R2LAB_CACHE`` when set (the tests use it), else ``$XDG_CACHE_HOME/robotics2lab``
(``~/.cache/robotics2lab`` by default), never the working tree; entries live in its
``derivations/`` folder, created with mode 0700 and used only when it belongs to the user and no
one else may write to it.

>>> import tempfile
>>> path = Path(tempfile.mkdtemp()) / "entry.json"
>>> write_entry(path, {"robot": "abc"}, {"M": "m1"})
True
>>> read_entry(path, {"robot": "abc"})
{'M': 'm1'}
>>> read_entry(path, {"robot": "other"}) is None
True
"""
from __future__ import annotations

import hashlib
import json
import os
import stat
from pathlib import Path
from typing import Dict, List, Mapping, Optional

# sympy is imported where an expression table needs it: the envelope functions are standard library
# only, so that app.core.output_cache can read the cache without the symbolic engine

FORMAT = "robotics2lab-derivation"
FORMAT_VERSION = 1
MAX_ENTRY_BYTES = 64_000_000
LAB_FOLDER = "robotics2lab"


def cache_root() -> Path:
    """The lab's cache folder: $R2LAB_CACHE, else $XDG_CACHE_HOME/robotics2lab or ~/.cache/robotics2lab."""
    override = os.environ.get("R2LAB_CACHE")
    if override:
        return Path(override)
    base = os.environ.get("XDG_CACHE_HOME")
    base_path = Path(base) if base and Path(base).is_absolute() else Path.home() / ".cache"
    return base_path / LAB_FOLDER


def cache_dir(name: str = "derivations") -> Optional[Path]:
    """The cache's folder ``name`` (``derivations``; ``outputs``: app.core.output_cache), created
    with mode 0700, or None when it cannot be used safely: not a real directory, not the user's
    own, or writable by others."""
    folder = cache_root() / name
    try:
        folder.mkdir(mode=0o700, parents=True, exist_ok=True)
        info = os.lstat(folder)
        if not stat.S_ISDIR(info.st_mode) or info.st_uid != os.getuid():
            return None
        if info.st_mode & 0o077:
            os.chmod(folder, 0o700)
        return folder
    except OSError:
        return None


def entry_path(key: str, folder_name: str = "derivations") -> Optional[Path]:
    """Where the entry of a derivation key lives (a hash of the key), or None without a usable folder."""
    folder = cache_dir(folder_name)
    if folder is None:
        return None
    return folder / f"{hashlib.sha256(key.encode()).hexdigest()[:32]}.json"


def read_entry(path: Optional[Path], expect: Mapping[str, str], form: str = FORMAT) -> Optional[dict]:
    """The payload of a valid entry whose envelope matches ``expect`` (engine version, robot hash,
    key ...), or None for a missing, foreign, stale or corrupt file. Never executes anything."""
    if path is None:
        return None
    try:
        info = os.lstat(path)
        if not stat.S_ISREG(info.st_mode) or info.st_size > MAX_ENTRY_BYTES:
            return None
        with open(path, "rb") as fh:
            data = json.loads(fh.read(MAX_ENTRY_BYTES + 1).decode("utf-8"))
    except (OSError, ValueError, RecursionError):
        return None
    if not isinstance(data, dict) or data.get("format") != form or data.get("version") != FORMAT_VERSION:
        return None
    envelope = data.get("envelope")
    if not isinstance(envelope, dict) or any(envelope.get(k) != v for k, v in expect.items()):
        return None
    payload = data.get("payload")
    return payload if isinstance(payload, dict) else None


def write_entry(path: Optional[Path], envelope: Mapping[str, str], payload: dict, form: str = FORMAT) -> bool:
    """Write an entry atomically (a private temporary file renamed over the old one); False when
    the folder cannot be written (the model then lives in memory only)."""
    if path is None:
        return False
    tmp = path.with_name(f".{path.stem}.{os.getpid()}.tmp")
    try:
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            json.dump({"format": form, "version": FORMAT_VERSION, "envelope": dict(envelope),
                       "payload": payload}, fh, separators=(",", ":"))
        os.replace(tmp, path)
        return True
    except OSError:
        try:
            tmp.unlink()
        except OSError:
            pass
        return False


# ------------------------------------------------------------------------------ typed readers
class ExprTable:
    """Distinct expressions of a stored model, referred to by index (equal trees share an entry):
    ``index``/``matrix`` when writing, ``expr_of``/``matrix_of`` (checked) when reading."""

    def __init__(self, exprs: Optional[list] = None):
        self.exprs: list = list(exprs or [])
        self._index: Dict[sp.Basic, int] = {}

    def index(self, expr) -> int:
        import sympy as sp
        expr = sp.sympify(expr)
        found = self._index.get(expr)
        if found is None or self.exprs[found] != expr or type(self.exprs[found]) is not type(expr):
            found = self._index[expr] = len(self.exprs)
            self.exprs.append(expr)
        return found

    def matrix(self, m: sp.Matrix) -> list:
        return [m.rows, m.cols, [self.index(e) for e in m]]

    def expr_of(self, value) -> sp.Expr:
        if type(value) is not int or not 0 <= value < len(self.exprs):
            raise ValueError("stored model: bad expression index")
        return self.exprs[value]

    def matrix_of(self, value) -> sp.Matrix:
        import sympy as sp
        rows, cols, entries = sized(value, 3)
        if type(rows) is not int or type(cols) is not int or not 0 <= rows <= 1000 or not 0 <= cols <= 1000 \
                or len(as_list(entries)) != rows * cols:
            raise ValueError("stored model: bad matrix shape")
        return sp.Matrix(rows, cols, [self.expr_of(e) for e in entries])


def as_list(value) -> list:
    if not isinstance(value, list):
        raise ValueError("stored model: expected a list")
    return value


def as_mapping(value) -> dict:
    if not isinstance(value, dict):
        raise ValueError("stored model: expected a mapping")
    return value


def as_text(value) -> str:
    if not isinstance(value, str):
        raise ValueError("stored model: expected a text")
    return value


def as_texts(value) -> List[str]:
    return [as_text(v) for v in as_list(value)]


def sized(value, n: int) -> list:
    if len(as_list(value)) != n:
        raise ValueError(f"stored model: expected {n} items")
    return value


def pair(value) -> list:
    return sized(value, 2)
