"""The listings of ``robots`` and ``exercises`` read the files' headers only (app/core/catalog.py):
they must say what the loaded, validated files say."""
from app.core.catalog import exercise_entries, robot_entries
from app.core.exercise import list_exercises
from app.core.robot import load_robot


def test_robot_entries_agree_with_the_loaded_robots():
    for entry in robot_entries():
        robot = load_robot(entry["name"])
        assert entry == {"name": entry["name"], "group": robot.group, "title": robot.title,
                         "description": robot.description, "dof": robot.n}


def test_exercise_entries_agree_with_the_loaded_exercises():
    loaded = [{"id": e.id, "title": e.title, "robot": e.robot, "topics": e.topics} for e in list_exercises()]
    assert exercise_entries() == loaded
    assert len(loaded) > 100


def test_shipped_files_read_with_libyaml_give_the_same_data():
    """Shipped robot and exercise files are read with libyaml's loader (app.core.files.load_yaml
    ``shipped``), user files with the bounded pure-Python one: the same data (every robot file and
    every fourth exercise file: the pure-Python loader takes 4 ms per file)."""
    from app.core.catalog import ROBOTS_DIR, exercise_files
    from app.core.files import load_yaml
    paths = sorted(ROBOTS_DIR.glob("*.yaml")) + exercise_files()[::4]     # every robot, every 4th exercise
    for path in paths:
        text = path.read_text(encoding="utf-8")
        assert load_yaml(text, path.name, shipped=True) == load_yaml(text, path.name), path.name
    assert len(paths) > 100


def test_the_server_warms_up_the_catalog_in_the_background(lab):
    """``LabServer.warm_up`` (what ``serve`` starts once listening) reads the picker's catalog, the
    first robot's model and drawing, then the given extras."""
    from app.core.catalog import list_robot_names
    extras = []
    lab.warm_up(lambda: extras.append("done")).join(60)
    assert extras == ["done"]
    assert {entry.name for entry in lab.catalog()} == set(list_robot_names())
