"""Robot panel: what the robot file says (coordinates and limits, parameters with units,
springs, friction, notes) and a download of the file itself."""
from __future__ import annotations

from pathlib import Path

import sympy as sp

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
