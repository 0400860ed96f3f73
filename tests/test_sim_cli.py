"""`python -m app simulate`: the CSV it writes, its summary, and its exit codes (0 completed,
1 stopped early, 2 bad input)."""
import json
import re

import numpy as np
import pytest

from app.cli import main
from app.core.control import CONTROLLERS


def run(capsys, *args):
    code = main(["simulate", *args])
    out, err = capsys.readouterr()
    return code, out, err


def test_a_run_writes_every_signal_as_csv(tmp_path, capsys):
    out = tmp_path / "run.csv"
    code, text, err = run(capsys, "planar_2r", "--controller", "adaptive", "--gains", "Gamma=2,Kd2=30",
                          "--reference", "quintic goal=0.5,-0.3 T=0.5", "--duration", "0.5", "--model", "m2=5",
                          "--observer", "40", "--out", str(out))
    assert code == 0, err
    assert "completed" in text and "Kd=20,30" in text
    data = np.genfromtxt(out, delimiter=",", names=True)
    assert data.shape == (501,)
    for column in ("t", "q1", "dq2", "tau_q1", "ref_q2", "e_q1", "a_hat1", "r_q2"):
        assert column in data.dtype.names
    assert data["t"][-1] == pytest.approx(0.5)
    assert data["ref_q1"][-1] == pytest.approx(0.5)


def test_json_summary_and_contacts(capsys):
    code, text, err = run(capsys, "planar_2r", "-c", "hybrid", "--surface", "ee normal=0,1", "--q0=-0.4,1.6",
                          "-r", "quintic goal=-0.6 T=0.5", "-g", "Fd=12,KF=0", "-T", "0.6", "--json")
    assert code == 0, err
    info = json.loads(text)
    assert info["controller"] == "hybrid" and info["reference_coordinates"] == ["s"]
    assert info["status"] == "completed" and abs(info["final_error"][0]) < 5e-3
    assert "surface_ee" in info


def test_stopped_runs_exit_with_1_and_keep_their_samples(tmp_path, capsys):
    out = tmp_path / "fall.csv"
    code, text, err = run(capsys, "throwing_arm", "-c", "pd", "-g", "Kp=1,Kd=1", "--q0", "1.73,0.67,0.63", "-T", "3",
                          "-o", str(out))
    assert code == 1
    match = re.search(r"error: q1 left its limits \[-0\.5236, 3\.665\] at t = (\d\.\d{3}) s", err)
    assert match, err
    data = np.genfromtxt(out, delimiter=",", names=True)
    assert data["t"][-1] == pytest.approx(float(match.group(1)) - 0.001)


@pytest.mark.parametrize("args,message", [
    (["planar_2r", "-c", "pid"], "unknown controller 'pid'"),
    (["planar_2r", "-c", "pd", "-g", "Kq=3"], "unknown gain 'Kq'"),
    (["planar_2r", "-c", "pd", "-g", "Kp=-3"], "Kp must be positive"),
    (["planar_2r", "-c", "pd", "-r", "quintic goal=1 T=0"], "T must be positive"),
    (["planar_2r", "-c", "pd", "-r", "quintic goal=1,2,3 T=1"], "goal needs 2 values"),
    (["planar_2r", "-c", "pd", "--q0", "1,open('x')"], "--q0"),
    (["planar_2r", "-c", "pd", "-T", "0"], "duration"),
    (["nonexistent_robot", "-c", "pd"], "unknown robot 'nonexistent_robot'"),
    (["planar_2r", "-c", "pd", "--force", "ee 10,0"], "expected key=value"),
    (["planar_2r", "-c", "pd", "--surface", "ee offset=1"], "give the normal"),
    (["planar_2r", "-c", "pd", "--plant", "m9=3"], "unknown parameter 'm9'"),
    (["planar_2r", "-c", "pd", "--plant", "m2=-3"], "must not be negative"),
    (["planar_2r"], "--controller"),
])
def test_bad_input_exits_with_2_and_a_message(capsys, args, message):
    code, text, err = run(capsys, *args)
    assert code == 2
    assert err.startswith("error: ") and message in err and "Traceback" not in err


def test_list_shows_every_controller_with_its_law(capsys):
    code, text, err = run(capsys, "--list")
    assert code == 0
    for name, cls in CONTROLLERS.items():
        assert f"{name}: {cls.title}" in text
        assert cls.law_latex in text
