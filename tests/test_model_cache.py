"""The derivation cache cannot run code (issue 15): models are stored as data in the user's cache
folder, read back through the whitelist parser; planted pickles and crafted entries are ignored and
rebuilt, never executed."""
import hashlib
import json
import os
import pickle
import stat
from pathlib import Path

import pytest

from app.commands.derive import model_json
from app.core import model_cache
from app.core.dynamics import ENGINE_VERSION, Dynamics, cache_entry_path, derive, forget_derivations
from app.core.robot import load_robot

REPO = Path(__file__).resolve().parents[1]


class _Payload:
    """A pickle that would create a file when unpickled."""

    def __init__(self, marker: Path):
        self.marker = marker

    def __reduce__(self):
        return (open, (str(self.marker), "w"))


@pytest.fixture()
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("R2LAB_CACHE", str(tmp_path / "cache"))
    forget_derivations()
    yield tmp_path
    forget_derivations()


def test_cache_lives_in_the_users_cache_folder(tmp_path, monkeypatch):
    monkeypatch.delenv("R2LAB_CACHE", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    folder = model_cache.cache_dir()
    expected = tmp_path.joinpath("xdg", "robotics2lab", "derivations")
    assert folder == expected
    assert stat.S_IMODE(folder.stat().st_mode) == 0o700
    monkeypatch.delenv("XDG_CACHE_HOME")
    home_cache = Path.home().joinpath(".cache", "robotics2lab")
    assert model_cache.cache_root() == home_cache
    assert REPO not in model_cache.cache_root().parents


def test_planted_pickle_is_never_loaded(cache):
    robot = load_robot("planar_2r")
    path = cache_entry_path(robot)
    marker = cache / "pwned"
    path.write_bytes(pickle.dumps(_Payload(marker)))
    legacy = hashlib.sha256((robot.content_hash + "|*" + ENGINE_VERSION).encode()).hexdigest()[:32]
    (path.parent / f"{legacy}.pkl").write_bytes(pickle.dumps(_Payload(marker)))   # the old pickle name
    dyn = derive(robot)
    assert not marker.exists(), "a pickle in the cache was executed"
    assert str(dyn.M[1, 1]) == "I2 + d2**2*m2"
    assert model_cache.read_entry(path, {"robot": robot.content_hash}) is not None, "the entry was not rebuilt"


@pytest.mark.parametrize("case", ["code in an expression", "wrong version", "not a mapping", "garbage",
                                  "another robot", "bad index"])
def test_crafted_or_corrupt_entry_is_rebuilt(cache, case):
    robot = load_robot("pendulum_payload")
    derive(robot)
    path = cache_entry_path(robot)
    good = json.loads(path.read_text())
    marker = cache / "pwned"
    entry = json.loads(path.read_text())
    payload = entry["payload"]
    if case == "code in an expression":
        payload["expressions"] = [1, f"[__import__('os').system('touch {marker}')]"]
        payload["M"] = [1, 1, [0]]
    elif case == "wrong version":
        entry["version"] = 999
    elif case == "not a mapping":
        entry = ["M", 1]
    elif case == "another robot":
        entry["envelope"]["robot"] = "0" * 64
    elif case == "bad index":
        payload["M"][2][0] = 10 ** 6
    text = json.dumps(entry) if case != "garbage" else "\x00{not json"
    path.write_text(text)
    forget_derivations()
    dyn = derive(robot)
    assert not marker.exists()
    assert str(dyn.M[0, 0]) == "l**2*m"
    assert json.loads(path.read_text()) == good, "the entry was not rewritten"


def test_cache_folder_writable_by_others_is_made_private(cache):
    folder = cache / "cache" / "derivations"
    folder.mkdir(parents=True)
    os.chmod(folder, 0o777)
    assert model_cache.cache_dir() == folder and stat.S_IMODE(folder.stat().st_mode) == 0o700


@pytest.mark.parametrize("name", ["spatial_3r_2017_03_29", "throwing_arm", "elastic_pendulum_damped"])
def test_stored_model_reads_back_identically(name):
    robot = load_robot(name)
    dyn = derive(robot)
    back = Dynamics.from_data(json.loads(json.dumps(dyn.to_data())))
    assert model_json(robot, back) == model_json(robot, dyn)
    assert [s.as_dict() for s in back.steps] == [s.as_dict() for s in dyn.steps]
    for table in ("kinetic", "potential", "com_positions", "com_velocities", "angular_velocities"):
        mine, theirs = getattr(dyn, table), getattr(back, table)
        assert list(mine) == list(theirs) and all(str(mine[k]) == str(theirs[k]) for k in mine)
