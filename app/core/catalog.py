"""The shipped robots and exercises as listed by ``python -m app robots`` and ``exercises``.

A listing reads only the header fields of the shipped files (name, group, title, description,
coordinates; id, title, robot, topics), so it needs neither sympy nor the task modules and answers
at once. The files themselves are validated when loaded (app.core.robot, app.core.exercise) and by
the tests, which also check that these entries agree with the loaded files.

>>> next(e for e in robot_entries() if e["name"] == "rp_2004_03_25")["dof"]
2
"""
from __future__ import annotations

from pathlib import Path
from typing import Callable, List, Optional, Sequence

APP_DIR = Path(__file__).resolve().parent.parent
ROBOTS_DIR = APP_DIR / "robots"
EXERCISES_DIR = APP_DIR / "exercises"


def _load_shipped(path: Path):
    import yaml     # here: the file rules below need the standard library only (app.core.output_cache)
    # libyaml's loader when PyYAML was built with it (ten times faster); the shipped files are
    # trusted, user files go through app.core.files.load_yaml
    return yaml.load(path.read_text(encoding="utf-8"), Loader=getattr(yaml, "CSafeLoader", yaml.SafeLoader))


#: what makes a reference to a robot or an exercise a path rather than a shipped name
ROBOT_SUFFIXES = (".yaml", ".yml", ".json", ".urdf")
EXERCISE_SUFFIXES = (".yaml", ".yml")


def shipped_robot(name) -> Path:
    return ROBOTS_DIR / f"{name}.yaml"


def shipped_exercise(exercise_id) -> Path:
    return EXERCISES_DIR / (str(exercise_id).replace("#", "_") + ".yaml")


def named_file(name_or_path, shipped: Path, suffixes: Sequence[str],
               error: Optional[Callable[[str], Exception]] = None) -> Optional[Path]:
    """The file a user names: a path when the text ends in one of ``suffixes`` or names an existing
    file (``error`` raised when it does not exist; None without ``error``), else the shipped file
    ``shipped`` when it exists, else None (the caller says what it knows). The one rule of robots
    and exercises (app.core.robot.robot_path, app.core.exercise.exercise_path, and the output
    cache, which must find the same file without loading it).

    >>> named_file("planar_2r", ROBOTS_DIR / "planar_2r.yaml", (".yaml",), ValueError).name
    'planar_2r.yaml'
    >>> named_file("nothing_here", ROBOTS_DIR / "nothing_here.yaml", (".yaml",), ValueError) is None
    True
    >>> named_file("nothing.yaml", ROBOTS_DIR / "x.yaml", (".yaml",), ValueError)
    Traceback (most recent call last):
    ...
    ValueError: nothing.yaml: no such file
    """
    path = Path(name_or_path)
    if path.suffix in suffixes or path.exists():
        if not path.exists():
            if error is None:
                return None
            raise error(f"{path}: no such file")
        return path
    return shipped if shipped.exists() else None


def list_robot_names() -> List[str]:
    return sorted(p.stem for p in ROBOTS_DIR.glob("*.yaml"))


def exercise_files() -> List[Path]:
    """The shipped exercise files (without the expected answers beside them), in id order."""
    return [p for p in sorted(EXERCISES_DIR.glob("*.yaml")) if not p.name.endswith(".expected.yaml")]


def robot_entries() -> List[dict]:
    """One entry per shipped robot: name, group, title, description, dof (as the loaded robot has them)."""
    rows = []
    for name in list_robot_names():
        data = _load_shipped(ROBOTS_DIR / f"{name}.yaml")
        rows.append({"name": name, "group": data.get("group", "other"), "title": str(data.get("title", data["name"])),
                     "description": str(data.get("description", "")), "dof": len(data["coordinates"])})
    return rows


def exercise_entries() -> List[dict]:
    """One entry per shipped exercise: id, title, robot, topics (as the loaded exercise has them)."""
    rows = []
    for path in exercise_files():
        data = _load_shipped(path)
        rows.append({"id": str(data["id"]), "title": str(data.get("title", data["id"])), "robot": str(data["robot"]),
                     "topics": list(data.get("topics") or [])})
    return rows
