"""The cache of printed outputs (app/core/output_cache.py) stays safe: it holds data, never code, and
an entry counts only while the files it was computed from are unchanged. Commands are stood in for
by small functions (no engine), so these tests take milliseconds; tests/test_import_graph.py runs
the real ``derive`` and ``solve`` through it."""
import pickle

import pytest

from app.core import output_cache
from test_model_cache import _Payload          # a pickle that would create a file when unpickled


@pytest.fixture()
def files(tmp_path, monkeypatch):
    monkeypatch.setenv("R2LAB_CACHE", str(tmp_path / "cache"))
    robot = tmp_path / "arm.yaml"
    robot.write_text("name: arm\n")
    exercise = tmp_path / "ex.yaml"
    exercise.write_text("id: x\nrobot: arm.yaml\n")
    return exercise, robot


def _compute(text, deps=(), calls=None):
    def compute():
        if calls is not None:
            calls.append(text)
        print(text, end="")
        return 0, list(deps)
    return compute


def _entries(tmp_path):
    return list((tmp_path / "cache" / "outputs").glob("*.json"))


def test_an_output_is_kept_and_read_back_only_for_the_same_file_and_options(files, tmp_path, capsys):
    exercise, robot = files
    calls = []
    for _ in range(2):
        assert output_cache.run_cached("solve", exercise, {"json": True}, _compute("A", [(str(robot), str(robot))], calls)) == 0
    assert calls == ["A"] and capsys.readouterr().out == "AA"
    assert output_cache.lookup("solve", exercise, {"json": False}) is None      # other options
    assert output_cache.lookup("derive", exercise, {"json": True}) is None      # another command
    robot.write_text("name: arm\n# edited\n")                                 # the robot file changed
    assert output_cache.lookup("solve", exercise, {"json": True}) is None
    output_cache.run_cached("solve", exercise, {"json": True}, _compute("B", [(str(robot), str(robot))], calls))
    exercise.write_text("id: x\nrobot: arm.yaml\n# edited\n")                 # the exercise changed
    assert output_cache.lookup("solve", exercise, {"json": True}) is None
    assert calls == ["A", "B"]


def test_a_failed_command_is_not_kept(files, tmp_path, capsys):
    exercise, _ = files
    assert output_cache.run_cached("derive", exercise, {}, lambda: (print("half", end="") or (2, []))) == 2
    assert capsys.readouterr().out == "half" and _entries(tmp_path) == []


def test_corrupt_foreign_and_pickled_entries_are_ignored_and_rebuilt(files, tmp_path, capsys):
    exercise, _ = files
    output_cache.run_cached("derive", exercise, {}, _compute("good"))
    (entry,) = _entries(tmp_path)
    marker = tmp_path / "pwned"
    planted = [pickle.dumps(_Payload(marker)), b"{not json", b'{"format": "robotics2lab-derivation", "version": 1}',
               entry.read_bytes().replace(b'"text":"good"', b'"text":7'),
               entry.read_bytes().replace(b"robotics2lab-output", b"robotics2lab-derivation")]
    for content in planted:
        entry.write_bytes(content)
        assert output_cache.lookup("derive", exercise, {}) is None
        calls = []
        output_cache.run_cached("derive", exercise, {}, _compute("good", calls=calls))
        assert calls == ["good"] and output_cache.lookup("derive", exercise, {}) == "good"
    assert not marker.exists()


def test_references_resolve_like_the_engine(tmp_path):
    assert output_cache.robot_file("planar_2r") == output_cache.ROBOTS_DIR / "planar_2r.yaml"
    assert output_cache.exercise_file("2004-03-25#1") == output_cache.EXERCISES_DIR / "2004-03-25_1.yaml"
    assert output_cache.robot_file("no_such_robot") is None
    assert output_cache.robot_file(str(tmp_path / "missing.yaml")) is None
    assert output_cache.exercise_file("x" * 5000) is None
