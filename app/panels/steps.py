"""Steps panel: the derivation of the model one step at a time (energies per link, Lagrangian,
Christoffel symbols, M, C, g, regressor), with the step's links or joints lit up in 3D.

``session.state["steps"]["show"](k)`` opens step k (0-based) from outside, e.g. for screenshots."""
from __future__ import annotations

import html

from app.core.mathtext import to_unicode
from app.viewer import mathml

TITLE = "Steps"
ORDER = 20


def step_html(step, index: int, count: int) -> str:
    """The HTML of one derivation step: counter, title, explanation and formula (one line per
    top-level ``,\\quad`` part)."""
    parts = mathml.split_top_level(step.latex)
    lit = step.highlight.get("bodies", []) + step.highlight.get("joints", [])
    lit_note = f'<div class="r2-label">lit in 3D: {html.escape(", ".join(lit))}</div>' if lit else ""
    return (f'<div class="r2-step" data-step="{index}">'
            f'<div class="r2-label">Step {index + 1} of {count}</div>'
            f'<div style="font-weight:600;margin:2px 0 4px 0">{mathml.text_html(step.title)}</div>'
            f'<div style="font-size:0.88em;color:#333">{mathml.text_html(step.text)}</div>'
            + "".join(mathml.math_html(p) for p in parts) + lit_note + "</div>")


def build(session) -> None:
    gui = session.gui
    steps = session.dynamics.steps
    if not steps:
        gui.add_markdown("No derivation steps for this robot.")
        return
    state = session.state.setdefault("steps", {})
    index = min(state.get("index", 0), len(steps) - 1) if state.get("robot") == session.robot_name else 0
    state.update(robot=session.robot_name, index=index)     # Next and Previous start from here
    titles = [f"{k + 1}. {to_unicode(s.title)}" for k, s in enumerate(steps)]
    jump = gui.add_dropdown("Step", titles, initial_value=titles[index])
    buttons = gui.add_button_group("", ("◀ Previous", "Next ▶", "Clear light"))
    body = gui.add_html(step_html(steps[index], index, len(steps)))

    def show(k: int, light: bool = True) -> None:
        k = max(0, min(len(steps) - 1, k))
        state["index"] = k
        step = steps[k]
        body.content = step_html(step, k, len(steps))
        if jump.value != titles[k]:
            jump.value = titles[k]
        if light:
            session.scene.highlight(step.highlight.get("bodies", []), step.highlight.get("joints", []))

    state["show"] = show

    @buttons.on_click
    def _(event):
        if event.target.value == "Clear light":
            session.scene.clear_highlight()
            return
        show(state["index"] + (1 if event.target.value.startswith("Next") else -1))

    @jump.on_update
    def _(event):
        if event.client is None:
            return
        show(titles.index(jump.value))
