"""HTML of the Exercises panel: the question, the notes on the printed solution, a solution step
with what it shows in 3D, timing-law sketches, and the table of numeric answers with units.

>>> paragraphs("(a) Derive the model.\\n(b) Design a law\\n    with two gains.")
['(a) Derive the model.', '(b) Design a law with two gains.']
>>> answer_unit("T_min", 1.5, ["revolute"])
's'
>>> answer_unit("dq", [0.1, 0.2], ["revolute", "prismatic"])
['rad/s', 'm/s']
"""
from __future__ import annotations

import html
import re
from typing import Any, Dict, List, Optional, Sequence, Union

import numpy as np
import sympy as sp

from app.core.formula_layout import wrap_latex
from app.viewer import mathml

ACCENT = "#2e5eaa"
NOTE_STYLE = ("border-left:4px solid #e8a317;background:#fff6e0;border-radius:4px;padding:6px 9px;"
              "margin:6px 0;font-size:0.88em;color:#4a3b12")
CARD_STYLE = (f"border:2px solid {ACCENT};border-radius:8px;padding:6px 9px;margin:4px 0;"
              "background:#f7f9fd")
STEP_STYLE = "border-left:3px solid #c9d3e6;padding:2px 0 2px 8px;margin:6px 0"

#: colours of the 3D hints by role (RGB), also used for the legend of a step
ROLE_COLORS = {"desired": (31, 119, 180), "achieved": (44, 160, 44), "error": (214, 39, 40),
               "force": (230, 85, 13), "gradient": (148, 103, 189), "point": (214, 39, 40),
               "path": (31, 119, 180), "joint": (44, 160, 44), "saturated": (230, 140, 0),
               "violating": (214, 39, 40), "bounds": (150, 150, 150)}


def _hex(rgb) -> str:
    return "#%02x%02x%02x" % tuple(rgb)


# ---------------------------------------------------------------------- question and notes
_NEW_PARAGRAPH = re.compile(r"^\s*(\([a-z0-9]+\)|[-*•]\s|\d+[.)]\s)")


def paragraphs(text: str) -> List[str]:
    """The question's lines joined into paragraphs; a blank line or an item mark such as (a),
    1. or - starts a new one."""
    out: List[str] = []
    for line in text.strip().splitlines():
        if not line.strip():
            if out and out[-1]:
                out.append("")
            continue
        if not out or not out[-1] or _NEW_PARAGRAPH.match(line):
            out.append(line.strip())
        else:
            out[-1] += " " + line.strip()
    return [p for p in out if p]


def question_html(exercise, robot_title: str) -> str:
    topics = " ".join(f'<span style="background:#e8eef8;border-radius:8px;padding:0 6px;margin-right:3px;'
                      f'font-size:0.78em;color:#2e4a7a">{html.escape(t)}</span>' for t in exercise.topics)
    body = "".join(f'<p style="margin:0 0 5px 0">{html.escape(p)}</p>' for p in paragraphs(exercise.question))
    return (f'<div class="r2-exercise" data-exercise="{html.escape(exercise.id)}">'
            f'<div style="font-weight:600;font-size:1.02em">{html.escape(exercise.id)} — {html.escape(exercise.title)}</div>'
            f'<div style="font-size:0.8em;color:#666;margin:1px 0 3px 0">Robot: {html.escape(robot_title)}</div>'
            f'<div style="margin-bottom:4px">{topics}</div>'
            f'<div class="r2-question" style="font-size:0.9em;line-height:1.4;color:#222">{body}</div></div>')


def notes_html(notes: Sequence[str]) -> str:
    """The notes on the printed solution (text with $...$ math) in an amber box."""
    if not notes:
        return ""
    items = "".join(f'<li style="margin:2px 0">{mathml.text_html(n)}</li>' for n in notes)
    return (f'<div class="r2-notes" style="{NOTE_STYLE}"><b>&#9888; Note on the printed solution</b>'
            f'<ul style="margin:3px 0 0 0;padding-left:18px">{items}</ul></div>')


def variant_html(changes: Dict[str, str]) -> str:
    """A line saying which numbers differ from the exam's."""
    if not changes:
        return ""
    text = ", ".join(f"{k} = {v}" for k, v in changes.items())
    return (f'<div class="r2-variant" style="font-size:0.85em;color:#6a3d9a;margin:3px 0">'
            f"<b>Variant:</b> {html.escape(text)}</div>")


# ---------------------------------------------------------------------- steps
def hint_legend(highlight: Dict[str, Any], arrow_scale: Optional[float] = None) -> str:
    """One line per kind of 3D hint of a step (what is lit, which arrows, bounds, scaling)."""
    parts = []
    lit = list(highlight.get("bodies", [])) + [f"joint of {j}" for j in highlight.get("joints", [])]
    if lit:
        parts.append("lit in 3D: " + ", ".join(lit))
    for v in highlight.get("vectors", []) or []:
        color = ROLE_COLORS.get(v.get("role", "desired"), ROLE_COLORS["desired"])
        where = "at the joints" if v.get("joint_space") else ("at the end effector" if "origin" not in v else "")
        parts.append(f'<span style="color:{_hex(color)}">&#10230;</span> {html.escape(str(v.get("label", "")))} '
                     f'({html.escape(v.get("role", "vector"))}) {where}'.rstrip())
    for jv in (highlight.get("joint_values") or [])[:1]:
        has_bounds = jv.get("lower") is not None or jv.get("upper") is not None
        parts.append(f'<span style="color:{_hex(ROLE_COLORS["joint"])}">&#8635;</span> '
                     f'{html.escape(str(jv.get("label", "values")))} at the joints'
                     + (f' (grey arcs: bounds; <span style="color:{_hex(ROLE_COLORS["saturated"])}">orange</span>: '
                        f'saturated, <span style="color:{_hex(ROLE_COLORS["violating"])}">red</span>: out of bounds)'
                        if has_bounds else ""))
    if highlight.get("points"):
        parts.append("points: " + ", ".join(html.escape(str(p.get("label", ""))) for p in highlight["points"]))
    if highlight.get("path"):
        parts.append("path drawn in 3D")
    if highlight.get("scale") is not None:
        parts.append(f"task scaling s = {float(highlight['scale']):.4g}")
    if arrow_scale and (highlight.get("vectors") or highlight.get("joint_values")):
        parts.append(f"arrows: 1 unit = {arrow_scale:.3g} m")
    if not parts:
        return ""
    return '<div class="r2-label">' + "<br>".join(parts) + "</div>"


def step_html(step, index: int, count: int, current: bool = False, arrow_scale: Optional[float] = None,
              notes: Sequence[str] = ()) -> str:
    """A solution step: counter, title, explanation, the formula (one line per top-level part),
    the timing-law sketch, the notes on the printed solution about this step and the legend of
    the 3D hints."""
    parts = mathml.split_top_level(step.latex) if step.latex else []
    profile = step.highlight.get("profile")
    style = CARD_STYLE if current else STEP_STYLE
    return (f'<div class="r2-step" data-step="{index}" style="{style}">'
            f'<div class="r2-label" style="margin-top:0">Step {index + 1} of {count}</div>'
            f'<div style="font-weight:600;margin:1px 0 3px 0">{mathml.text_html(step.title)}</div>'
            + (f'<div style="font-size:0.87em;color:#333">{mathml.text_html(step.text)}</div>' if step.text else "")
            + "".join(mathml.math_html(wrap_latex(p)) for p in parts)
            + (profile_svg(profile) if isinstance(profile, dict) else "")
            + (phase_plane_svg(step.highlight["phase_plane"]) if isinstance(step.highlight.get("phase_plane"), dict) else "")
            + notes_html(notes)
            + (hint_legend(step.highlight, arrow_scale) if current else "") + "</div>")


def plot_svg(series, x_label: str, y_label: str, vlines=(), y_max: Optional[float] = None,
             width: int = 330, height: int = 130, css_class: str = "r2-plot") -> str:
    """A small line plot as inline SVG (scripts do not run in the panel's HTML): ``series`` is
    [(xs, ys, colour, label, dashed)], ``vlines`` x positions marked with dashed lines."""
    xs_all = np.concatenate([np.asarray(x, float) for x, *_ in series])
    ys_all = np.concatenate([np.asarray(y, float) for _, y, *_ in series])
    finite = np.isfinite(ys_all)
    if not finite.any() or not np.isfinite(xs_all).all():
        return ""
    x0, x1 = float(xs_all.min()), float(xs_all.max())
    top = y_max if y_max is not None else float(np.max(np.abs(ys_all[finite])))
    if not x1 > x0 or not top > 0:
        return ""
    pad_l, pad_r, pad_b, pad_t = 38, 8, 18, 12
    y0 = height - pad_b

    def X(x):
        return pad_l + (width - pad_l - pad_r) * (np.asarray(x, float) - x0) / (x1 - x0)

    def Y(y):
        return pad_t + (y0 - pad_t) * (1 - np.clip(np.asarray(y, float), 0, top) / top)

    body = ""
    for v in vlines:
        body += f'<line x1="{X(v):.1f}" y1="{pad_t}" x2="{X(v):.1f}" y2="{y0}" stroke="#bbb" stroke-dasharray="3,3"/>'
    legend = ""
    for k, (xs, ys, color, label, dashed) in enumerate(series):
        ok = np.isfinite(np.asarray(ys, float))
        pts = " ".join(f"{a:.1f},{b:.1f}" for a, b in zip(X(np.asarray(xs, float)[ok]), Y(np.asarray(ys, float)[ok])))
        dash = ' stroke-dasharray="5,3"' if dashed else ""
        body += f'<polyline points="{pts}" fill="none" stroke="{color}" stroke-width="2"{dash}/>'
        if label:
            legend += (f'<text x="{width - pad_r - 4}" y="{pad_t + 4 + 11 * k}" font-size="10" fill="{color}" '
                       f'text-anchor="end">{html.escape(label)}</text>')
    return (f'<svg class="{css_class}" width="{width}" height="{height}" style="display:block;margin:4px 0">'
            f'<line x1="{pad_l}" y1="{y0}" x2="{width - 4}" y2="{y0}" stroke="#555"/>'
            f'<line x1="{pad_l}" y1="{pad_t - 4}" x2="{pad_l}" y2="{y0}" stroke="#555"/>{body}{legend}'
            f'<text x="{pad_l - 4}" y="{pad_t + 4}" font-size="10" fill="#333" text-anchor="end">{top:.3g}</text>'
            f'<text x="{pad_l - 4}" y="{y0}" font-size="10" fill="#333" text-anchor="end">0</text>'
            f'<text x="{pad_l + 4}" y="{pad_t - 2}" font-size="10" fill="#666">{html.escape(y_label)}</text>'
            f'<text x="{width - 4}" y="{height - 4}" font-size="10" fill="#333" text-anchor="end">'
            f'{html.escape(x_label)}</text></svg>')


def profile_svg(profile: Dict[str, float], width: int = 330, height: int = 120) -> str:
    """A sketch of a timing law's velocity profile (bang-bang, trapezoidal, cubic, quintic)."""
    kind, T, V = profile.get("kind"), float(profile.get("T", 0)), float(profile.get("V", 0))
    if not T > 0 or not np.isfinite(V):
        return ""
    Ts = float(profile.get("Ts") or 0.0)
    t = np.linspace(0, T, 121)
    x = t / T
    if kind in ("bang_bang", "trapezoidal") and Ts > 0:
        v = np.where(t < Ts, V * t / Ts, np.where(t < T - Ts, V, V * (T - t) / Ts))
    elif kind == "cubic":
        v = V * 4 * x * (1 - x)
    elif kind == "quintic":
        v = V * 16 * x ** 2 * (1 - x) ** 2
    else:
        return ""
    marks = sorted({Ts, T - Ts}) if kind in ("bang_bang", "trapezoidal") and Ts > 0 else []
    return plot_svg([(t, np.abs(v), ACCENT, "", False)], f"t [s], T = {T:.3g} s", "|velocity|", marks,
                    width=width, height=height, css_class="r2-profile")


def phase_plane_svg(plane: Dict[str, Any]) -> str:
    """The phase plane of a time-optimal path motion: s'(s) of the optimum, the backward
    (controllable) curve and the maximum-velocity curve, switching points dashed."""
    s = np.asarray(plane.get("s", []), float)
    if s.size < 2:
        return ""
    curves = [(plane.get("mvc"), "#d62728", "MVC", True), (plane.get("backward"), "#999999", "backward", False),
              (plane.get("sdot"), ACCENT, "optimal s'", False)]
    series = [(s, np.asarray(y, float), c, label, dashed) for y, c, label, dashed in curves
              if y is not None and len(y) == s.size]
    if not series:
        return ""
    reached = np.concatenate([y[np.isfinite(y)] for _, y, c, label, _ in series if label != "MVC"] or [np.zeros(1)])
    top = 1.6 * float(reached.max()) if reached.size and reached.max() > 0 else None
    return plot_svg(series, "s", "s'", plane.get("switches") or [], y_max=top, css_class="r2-phase")


# ---------------------------------------------------------------------- answers
_TIME = re.compile(r"^(T_min|T_scaled|T_star|Ts|T_[xy](_switch)?|.*_time)$")
_NOT_JOINT_VECTOR = re.compile(r"(error|grad|objective|_task_\d+$|_pinv|_projector|_identities|minors)")


def numeric_value(value) -> Optional[np.ndarray]:
    """The answer as a float array, or None when it is symbolic (or not a number)."""
    if isinstance(value, bool) or value is None:
        return None
    try:
        if isinstance(value, sp.MatrixBase):
            if value.free_symbols:
                return None
            return np.array(value.evalf(), dtype=float)
        if isinstance(value, sp.Basic):
            if value.free_symbols:
                return None
            return np.array(float(value))
        arr = np.asarray(value, dtype=float)
        return arr if arr.size else None
    except (TypeError, ValueError):
        return None


def answer_unit(name: str, value, joint_types: Sequence[str]) -> Union[str, List[str]]:
    """Unit of a numeric answer from its name (the names of the task kinds, docs/exercise-format.md):
    times in s; joint-space velocities and accelerations (dq..., ddq... with one entry per joint)
    and joint torques (tau...) per joint type; forces F_<label> in N; positions p_<label> in m.
    Empty when the name does not say (counts, scalings, norms of mixed quantities, ...)."""
    arr = np.atleast_1d(np.asarray(value, dtype=float))
    n = len(joint_types)
    revolute = ["revolute" == t for t in joint_types]

    def per_joint(rev_unit: str, pri_unit: str):
        return [rev_unit if r else pri_unit for r in revolute]

    if _TIME.match(name):
        return "s"
    if arr.ndim == 1 and arr.size == n and n > 0 and not _NOT_JOINT_VECTOR.search(name):
        if name.startswith("ddq"):
            return per_joint("rad/s²", "m/s²")
        if name.startswith("dq") and not name.endswith(("_norm", "_cost", "_half_norm2", "_scale")):
            return per_joint("rad/s", "m/s")
        if name.startswith("tau"):
            return per_joint("N m", "N")
    if name.startswith("tau") and arr.size == 1 and n and len(set(revolute)) == 1:
        return "N m" if revolute[0] else "N"
    if re.match(r"^F_\w+$", name) or name == "force_max":
        return "N"
    if re.match(r"^p_\w+$", name) and arr.ndim == 1 and arr.size in (2, 3):
        return "m"
    return ""


def number_tex(x: float) -> str:
    """4 decimals as in the printed solutions; tiny non-zero values in scientific notation.

    >>> number_tex(-1.26794), number_tex(2.5e-6)
    ('-1.2679', '2.5 \\\\cdot 10^{-6}')
    """
    from app.core.latex import num
    if x != 0 and abs(x) < 5e-4 and np.isfinite(x):
        return mathml.number_latex(x, 3)
    return num(x, 4)


def _vector_tex(value: np.ndarray) -> str:
    arr = np.atleast_2d(value.reshape(-1, 1) if value.ndim == 1 else value)
    body = r"\\".join(" & ".join(number_tex(float(v)) for v in row) for row in arr)
    return r"\left(\begin{matrix}" + body + r"\end{matrix}\right)"


def _unit_tex(unit: str) -> str:
    return r"\ \mathrm{" + unit.replace(" ", r"\,").replace("²", "^2") + "}" if unit else ""


def answer_latex(name: str, value: np.ndarray, unit) -> str:
    """``name = value unit`` (vectors as columns with a unit per entry when the joints differ)."""
    from app.core.steps import symbol_latex
    lhs = symbol_latex(name)
    if value.ndim == 0 or value.size == 1:
        u = unit[0] if isinstance(unit, list) else unit
        return f"{lhs} = {number_tex(float(value.reshape(-1)[0]))}{_unit_tex(u)}"
    if value.ndim == 1 and isinstance(unit, list) and len(set(unit)) > 1:
        rows = r"\\".join(f"{number_tex(float(v))}{_unit_tex(u)}" for v, u in zip(value, unit))
        return rf"{lhs} = \left(\begin{{matrix}}{rows}\end{{matrix}}\right)"
    u = unit[0] if isinstance(unit, list) and unit else (unit if isinstance(unit, str) else "")
    return f"{lhs} = {_vector_tex(value)}{_unit_tex(u)}"


def answers_html(answers: Dict[str, Any], joint_types: Sequence[str], limit: int = 60) -> str:
    """The numeric answers of a solution (symbolic ones are in the steps), with units."""
    blocks = []
    for name, value in answers.items():
        arr = numeric_value(value)
        if arr is None or arr.ndim > 2 or arr.size > 36:
            continue
        blocks.append(answer_latex(name, arr, answer_unit(name, arr, joint_types)))
        if len(blocks) >= limit:
            break
    if not blocks:
        return mathml.label_html("The answers of this exercise are symbolic: they are in the steps above.")
    return '<div class="r2-answers">' + "".join(mathml.math_html(b) for b in blocks) + "</div>"
