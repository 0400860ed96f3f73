"""Every bad command-line input of issue 15's list is refused in one line on stderr with exit code 2,
before any long work, and the message never echoes more than an excerpt of the input."""
from pathlib import Path

import pytest

from app.cli import MAX_MESSAGE, main

ROBOT = (Path(__file__).resolve().parents[1] / "app" / "robots" / "planar_2r.yaml").read_text(encoding="utf-8")
LONG = "9" * 5000
ALIAS_BOMB = "b0: &b0 [x, x, x, x, x, x, x, x, x]\n" + "".join(
    f"b{i}: &b{i} [" + ", ".join([f"*b{i - 1}"] * 9) + "]\n" for i in range(1, 9))


def files(tmp: Path) -> dict:
    """The hostile files, written into ``tmp``."""
    made = {
        "bomb": ROBOT.replace("description:", ALIAS_BOMB + "description: *b8\nx_description:"),
        "deep": "[" * 3000 + "]" * 3000,
        "big": ROBOT + "# " + "x" * 1_100_000 + "\n",
        "binary": "\x00\x01\x02 not yaml \ufffe",
        "exercise_shape": "id: x\nrobot: planar_2r\nquestion: q\ntasks: [{kind: [dynamics]}]\n",
        "exercise_given": "id: x\nrobot: planar_2r\nquestion: q\ntasks: [dynamics]\ngiven: [1, 2]\n",
        "throw_shape": "theta_b: -0.3\ntheta_e: 0.3\npsi_deg: 19\nk: 20\na: 1.5\nb: [0.6, 0.3]\n",
        "throw_huge": "theta_b: -0.3\ntheta_e: 0.3\npsi_deg: 19\nk: " + "9" * 400 + "\na: [1.7, 1.3]\nb: [0.6, 0.3]\n",
    }
    for name, text in made.items():
        (tmp / f"{name}.yaml").write_text(text, encoding="utf-8")
    return {name: str(tmp / f"{name}.yaml") for name in made}


CASES = [
    # OS errors, directories, special and oversized files
    ("derive {tmp}", "not a regular file"),
    ("derive /dev/zero", "not a regular file"),
    ("derive /dev/urandom", "not a regular file"),
    ("derive {big}", "larger than"),
    ("derive {binary}", ""),
    ("solve {tmp}", "not a regular file"),
    ("throw /dev/zero", ""),
    ("solve 2004-03-25#1 --out /nonexistent/dir/x.md", "does not exist"),
    ("export planar_2r --urdf {tmp}", "Is a directory"),
    # YAML alias bombs and recursion
    ("derive {bomb}", "aliases"),
    ("solve {bomb}", "aliases"),
    ("derive {deep}", "nested too deeply"),
    ("throw {deep}", "nested too deeply"),
    ("check-answer planar_2r --entry m22 --answer=" + "-" * 1200 + "1", ""),
    # shapes of exercise and throw fields
    ("solve {exercise_shape}", "tasks[0]"),
    ("solve {exercise_given}", "given"),
    ("throw {throw_shape}", "a:"),
    ("throw {throw_huge}", "finite"),
    # options
    ("throw --optimize --seed -1", "seed"),
    ("throw --optimize --seed 4294967296", "seed"),
    ("throw --optimize --budget 1e308", "budget"),
    ("simulate planar_2r -c pd -T 1e308", "integration steps"),
    ("simulate planar_2r -c pd -T 1e999", "finite"),
    ("simulate planar_2r -c pd -T nan", "finite"),
    ("simulate planar_2r -c pd --rate 1e308", "integration steps"),
    ("simulate planar_2r -c pd -T 1e4", "integration steps"),
    ("simulate planar_2r -c pd --substeps 1000000", "integration steps"),
    ("check planar_2r --states 1000000000", "states"),
    ("derive planar_2r --bogus " + LONG, "unrecognized arguments"),
    ("solve 2004-03-25#1 --set m1=" + LONG, ""),
    ("solve 2004-03-25#1 --set m1=((((9**64)**64)**64)**64)", "too large"),
    ("solve 2004-03-25#1 --set m1=sqrt(-1)", "real"),
    ("solve 2004-03-25#1 --set m1", "expects NAME=VALUE"),
    ("screenshot --robot planar_2r --out {tmp}/x.png --set m1=-1", "must not be negative"),
    ("screenshot --robot planar_2r --out {tmp}/x.png --set nosuch=1", "unknown parameter"),
    ("screenshot --robot planar_2r --out {tmp}/x.png --set =1", "expects NAME=VALUE"),
    ("screenshot --robot planar_2r --out {tmp}/x.png --set m1=" + LONG, ""),
    ("derive " + LONG, ""),
    ("derive planar_2r --known=m1\x00", "null character"),
]


@pytest.mark.parametrize("command, says", CASES, ids=[c[0][:50] for c in CASES])
def test_refused_in_one_line(command, says, tmp_path, capsys):
    paths = files(tmp_path)
    argv = [part.format(tmp=tmp_path, **paths) for part in command.split(" ")]
    assert main(argv) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), lines[:3]
    assert len(lines[0]) <= len("error: ") + MAX_MESSAGE and LONG[:400] not in lines[0]
    assert says in lines[0]
