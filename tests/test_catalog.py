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


def test_the_warm_up_of_every_robot_waits_for_an_idle_server(monkeypatch):
    """``warm_up(every_robot=True)`` (what ``serve`` starts) warms every robot of the picker, the
    largest first, only while no tab is loading a robot and none asked for one in the last
    IDLE_QUIET seconds."""
    import threading
    import time
    from types import SimpleNamespace

    import app.viewer.server as server
    monkeypatch.setattr(server, "IDLE_QUIET", 0.3)
    lab = server.LabServer(port=0, verbose=False)
    try:
        warmed = []
        monkeypatch.setattr(lab, "warm_robot", lambda name: warmed.append((name, time.monotonic())))
        loading = SimpleNamespace(ready=threading.Event(), closed=False)     # a tab building its panels
        lab.sessions[1] = loading
        lab.warm_up(every_robot=True)
        time.sleep(1.0)
        assert warmed == []
        lab.note_load()                                  # the tab asked for a robot: then it is ready
        asked = time.monotonic()
        loading.ready.set()
        assert lab.warmed.wait(30)
        dof = {info.name: info.dof for info in lab.catalog()}
        assert sorted(name for name, _ in warmed) == sorted(dof)
        assert [dof[name] for name, _ in warmed] == sorted(dof.values(), reverse=True)
        assert warmed[0][1] - asked >= 0.3
    finally:
        lab.sessions.clear()
        lab.stop()
