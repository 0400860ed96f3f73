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
