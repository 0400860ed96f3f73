"""Robot panel: what the robot file says (coordinates and limits, parameters with units,
springs, friction, notes), a download of the file itself, and "Open a robot file": a robot file
(YAML, docs/robot-format.md) or a URDF file from the user's computer, shown like a shipped robot."""
from __future__ import annotations

import re
import tempfile
from pathlib import Path

import sympy as sp

from app.core.errors import UserError
from app.core.files import MAX_FILE_BYTES
from app.core.robot import RobotFileError, load_robot_text
from app.core.urdf import is_urdf

TITLE = "Robot"
ORDER = 90


def _cell(text) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


def coordinates_table(robot, ranges) -> str:
    """Markdown table of the coordinates: joint, actuation, slider range and limits."""
    moves = {c: [] for c in robot.coordinates}
    for body in robot.bodies:
        for s in body.joint.value.free_symbols:
            if s.name in moves:
                moves[s.name].append(f"{body.joint.type[0].upper()} {body.name}")
    for name in robot.motor_inertias:
        moves[name].append("motor")
    rows = ["| q | joint | actuated | range | max speed | max force |", "|---|---|---|---|---|---|"]
    for name, actuated in zip(robot.coordinates, robot.actuated):
        lim = robot.limits.get(name)
        lo, hi = ranges[name]
        speed = f"{lim.velocity:.3g}" if lim and lim.velocity else "-"
        force = f"{lim.torque:.3g}" if lim and lim.torque else "-"
        rows.append(f"| {name} | {_cell(', '.join(moves[name]) or '-')} | {'yes' if actuated else 'no'} "
                    f"| {lo:.3g} … {hi:.3g} | {speed} | {force} |")
    return "\n".join(rows)


def parameters_table(robot) -> str:
    rows = ["| parameter | default | unit | kind | meaning |", "|---|---|---|---|---|"]
    for p in robot.parameters.values():
        rows.append(f"| {p.name} | {p.value:g} | {_cell(p.unit) or '-'} | {p.kind} | {_cell(p.doc) or '-'} |")
    return "\n".join(rows)


def save_uploaded_robot(name: str, content: bytes) -> Path:
    """Check an uploaded robot file (at most 1 MB of UTF-8, a valid robot file or URDF file) and
    save it in a new private temporary directory, so that the page loads it by path like any
    robot file; bad content raises a ``UserError`` naming the problem.

    >>> save_uploaded_robot("arm.yaml", b"name: [")
    Traceback (most recent call last):
    ...
    app.core.robot.RobotFileError: arm.yaml: not valid YAML (line 1): expected the node content, but found '<stream end>'
    """
    if len(content) > MAX_FILE_BYTES:
        raise RobotFileError(f"{name}: larger than {MAX_FILE_BYTES // 1000} kB")
    try:
        text = content.decode("utf-8")
    except UnicodeDecodeError:
        raise RobotFileError(f"{name}: not a UTF-8 text file") from None
    load_robot_text(text, name)
    stem = re.sub(r"[^\w-]", "_", Path(name).stem, flags=re.ASCII)[:60] or "robot"
    path = Path(tempfile.mkdtemp(prefix="r2lab-robot-")) / (stem + (".urdf" if is_urdf(text, name) else ".yaml"))
    path.write_text(text, encoding="utf-8")
    return path


def build(session) -> None:
    gui = session.gui
    robot = session.robot
    gui.add_markdown(f"**{_cell(robot.title)}**\n\n{robot.description}")
    gui.add_markdown("**Coordinates** (SI units: rad or m; rad/s or m/s; N m or N)\n\n"
                     + coordinates_table(robot, session.ranges))
    extras = []
    for spring in robot.springs:
        extras.append(f"- spring *{spring.name}*: {spring.describe()}")
    for damper in robot.dampers:
        extras.append(f"- *{damper.name}*: {damper.describe()}")
    for name, coeff in robot.viscous.items():
        extras.append(f"- viscous friction on {name}: {sp.sstr(coeff)} d{name}")
    for name, coeff in robot.coulomb.items():
        extras.append(f"- Coulomb friction on {name}: {sp.sstr(coeff)} sign(d{name})")
    for name, inertia in robot.motor_inertias.items():
        extras.append(f"- motor coordinate {name}, rotor inertia {sp.sstr(inertia)}")
    if extras:
        gui.add_markdown("**Springs, friction, motors**\n\n" + "\n".join(extras))
    with gui.add_folder("Parameters (defaults of the file)", expand_by_default=False):
        gui.add_markdown(parameters_table(robot))
    if robot.notes:
        with gui.add_folder("Notes", expand_by_default=False):
            gui.add_markdown("\n\n".join(_cell(n) for n in robot.notes))
    path = Path(robot.source)
    if path.exists():
        gui.add_markdown(f"File: `{path.name}`")
        button = gui.add_button("Download the robot file", hint="the file this robot is read from (YAML or URDF)")
        button.on_click(lambda event: event.client.send_file_download(path.name, path.read_bytes()))
    upload = gui.add_upload_button("Open a robot file", mime_type=".yaml,.yml,.urdf",
                                   hint="a robot file (YAML, docs/robot-format.md) or a URDF file")

    @upload.on_upload
    def _(event):
        sent = event.target.value
        try:
            path = save_uploaded_robot(sent.name, sent.content)
        except UserError as exc:
            session.notify("Cannot open the robot file", str(exc), error=True)
            return
        session.load_robot(str(path))
