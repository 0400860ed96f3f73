"""Reading user files safely: a regular file of bounded size, UTF-8 text, and YAML through the safe
loader with a cap on aliases (so an alias bomb is refused instead of filling the memory). Every
problem becomes one line naming the file, raised as the caller's error class.

>>> load_yaml("a: [1, 2]", "<text>")
{'a': [1, 2]}
"""
from __future__ import annotations

from pathlib import Path
from typing import Type

import yaml

from .errors import UserError

MAX_FILE_BYTES = 1_000_000
MAX_YAML_ALIASES = 20


def read_user_file(path: Path, error: Type[UserError] = UserError, limit: int = MAX_FILE_BYTES) -> str:
    """The text of a regular UTF-8 file of at most ``limit`` bytes (not a directory or a device)."""
    path = Path(path)
    if not path.is_file():
        raise error(f"{path}: not a regular file")
    try:
        with path.open("rb") as fh:
            raw = fh.read(limit + 1)
    except OSError as exc:
        raise error(f"{path}: cannot be read ({exc.strerror or exc})") from None
    if len(raw) > limit:
        raise error(f"{path}: larger than {limit // 1000} kB")
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError:
        raise error(f"{path}: not a UTF-8 text file") from None


class _BoundedLoader(yaml.SafeLoader):
    """PyYAML's safe loader with a cap on aliases (``*name``)."""

    def compose_node(self, parent, index):
        if self.check_event(yaml.AliasEvent):
            self.aliases_seen = getattr(self, "aliases_seen", 0) + 1
            if self.aliases_seen > MAX_YAML_ALIASES:
                raise yaml.YAMLError(f"more than {MAX_YAML_ALIASES} aliases (*name)")
        return super().compose_node(parent, index)


#: libyaml's safe loader when PyYAML was built with it: for the shipped files only (trusted, and
#: about seven times faster: the page reads every robot and exercise file when its first tab opens)
_SHIPPED_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


def load_yaml(text: str, source: str, error: Type[UserError] = UserError, shipped: bool = False):
    """YAML text to Python data through the bounded safe loader (``shipped``: a file of the lab's
    own, through libyaml's safe loader, the same data); errors become one line.

    >>> load_yaml("a: [1", "f.yaml")
    Traceback (most recent call last):
    ...
    app.core.errors.UserError: f.yaml: not valid YAML (line 1): expected ',' or ']', but got '<stream end>'
    """
    loader = None
    try:
        loader = (_SHIPPED_LOADER if shipped else _BoundedLoader)(text)    # a control character fails here
        return loader.get_single_data()
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" (line {mark.line + 1})" if mark is not None else ""
        problem = getattr(exc, "problem", None) or str(exc)
        raise error(f"{source}: not valid YAML{where}: {str(problem).splitlines()[0][:120]}") from None
    except RecursionError:
        raise error(f"{source}: YAML nested too deeply") from None
    finally:
        if loader is not None:
            loader.dispose()
