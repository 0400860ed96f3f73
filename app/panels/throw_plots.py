"""The Throw studio's uPlot charts (phase portrait with equilibria, joint angles, joint speeds and
torques against their limits, a limit crossing filled in red) and HTML summaries, built from a
throw evaluated by the core (``app.core.throw.study.evaluate``).

>>> from app.core.throw.arm import ThrowingArm
>>> from app.core.throw.config import thesis_throw
>>> from app.core.throw.study import evaluate
>>> plot = speeds_plot(evaluate(ThrowingArm(), thesis_throw("throw1")))
>>> len(plot.data) == len(plot.series), plot.bands[0]["series"]
(True, (5, 4))
"""
from __future__ import annotations

import html
import math
from dataclasses import dataclass
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np

from app.core.errors import UserError

from app.core.throw.reduced import Feasibility
from app.core.throw.study import ThrowView
from app.scene import PALETTE

#: colours of q1, q2, q3 (the links' colours in the 3D view)
JOINT_COLORS = [PALETTE[0], PALETTE[1], PALETTE[2]]
OVER_LIMIT_FILL = "rgba(214, 39, 40, 0.45)"
LIMIT_STROKE = "#b3261e"
TRANSPARENT = "rgba(0,0,0,0)"
#: the ball's flights: key -> (label, RGB colour)
FLIGHTS = {"true": ("true velocity J(q) q̇", (200, 40, 40)),
           "thesis": ("thesis convention: θ̇ along ψ", (110, 110, 120))}
#: side margins of the studio's HTML blocks, aligned with viser's widgets and clear of the panel's scrollbar
BLOCK = "padding:0 14px 0 9px"


class StudioTab:
    """A tab of the Throw studio: its widgets go in ``studio.gui`` below a short introduction."""

    def __init__(self, studio, intro: str):
        self.studio = studio
        studio.gui.add_html(f'<div class="r2-label" style="font-size:0.8em;color:#444;{BLOCK}">{intro}</div>')

    def throw_on_display(self, to: str) -> ThrowView:
        """The studio's throw on display; UserError ("there is no throw to ``to``") when none is."""
        if self.studio.view is None or self.studio.error:
            raise UserError(f"there is no throw to {to}: " + (self.studio.error or "none solved yet"))
        return self.studio.view


def hex_color(rgb: Sequence[int]) -> str:
    """``#rrggbb`` of an RGB tuple.

    >>> hex_color((70, 114, 196))
    '#4672c4'
    """
    return "#" + "".join(f"{int(c):02x}" for c in rgb)


# ====================================================================== uPlot charts
@dataclass
class PlotSpec:
    """Arguments of ``gui.add_uplot`` (data, series, bands, a fixed y range) and an HTML legend."""
    data: Tuple[np.ndarray, ...]
    series: Tuple[dict, ...]
    bands: Tuple[dict, ...]
    y_range: Tuple[float, float]
    legend: str
    x_range: Optional[Tuple[float, float]] = None      # default: the data's x extent

    @property
    def scales(self) -> dict:
        """Both ranges fixed (uPlot's automatic range would break on the NaN that end partial curves)."""
        x = self.data[0]
        lo, hi = self.x_range or (float(x[0]), float(x[-1]))
        return {"x": {"time": False, "range": (float(lo), float(hi))},
                "y": {"range": tuple(float(v) for v in self.y_range)}}


def _range(arrays: Sequence[np.ndarray], pad: float = 0.08, minimum: float = 1e-3) -> Tuple[float, float]:
    """A y range holding every finite value of ``arrays``, padded."""
    vals = np.concatenate([np.asarray(a, float).ravel() for a in arrays])
    vals = vals[np.isfinite(vals)]
    if vals.size == 0:
        return -1.0, 1.0
    lo, hi = float(vals.min()), float(vals.max())
    span = max(hi - lo, minimum)
    return lo - pad * span, hi + pad * span


def _swatch(color: str, label: str, dashed: bool = False, fill: bool = False) -> str:
    if fill:
        mark = f'<span style="display:inline-block;width:14px;height:9px;background:{color};vertical-align:middle"></span>'
    else:
        style = "dashed" if dashed else "solid"
        mark = (f'<span style="display:inline-block;width:16px;border-top:2.5px {style} {color};'
                f'vertical-align:middle"></span>')
    return f'<span style="margin-right:9px;white-space:nowrap">{mark} {html.escape(label)}</span>'


def status_html(text: str, done: bool = False) -> str:
    """A status line of the studio (green when a job is done).

    >>> status_html("done & dusted", done=True).count("#1e7b34"), "&amp;" in status_html("a & b")
    (1, True)
    """
    color = "#1e7b34" if done else "#333"
    return f'<div class="r2-label" style="font-size:0.8em;color:{color};{BLOCK}">{html.escape(text)}</div>'


def legend_html(title: str, items: Sequence[str]) -> str:
    return (f'<div class="r2-plot-legend" style="font-size:0.8em;color:#333;margin:6px 0 0 0;{BLOCK}">'
            f'<b>{html.escape(title)}</b><br>{"".join(items)}</div>')


class _Builder:
    """Collects uPlot series and red bands where a signal leaves its limits."""

    def __init__(self, x: np.ndarray, x_label: str):
        self.data: List[np.ndarray] = [np.asarray(x, float)]
        self.series: List[dict] = [{"label": x_label}]
        self.bands: List[dict] = []
        self.visible: List[np.ndarray] = []

    def curve(self, label: str, values, color: str, width: float = 2.0, dash=None, visible: bool = True) -> int:
        cfg = {"label": label, "stroke": color, "width": width}
        if dash:
            cfg["dash"] = list(dash)
        self.data.append(np.asarray(values, float))
        self.series.append(cfg)
        if visible and color != TRANSPARENT:
            self.visible.append(self.data[-1])
        return len(self.data) - 1

    def markers(self, label: str, values, color: str, fill: str, size: float = 9.0) -> int:
        self.data.append(np.asarray(values, float))
        self.series.append({"label": label, "stroke": color, "width": 0,
                            "points": {"show": True, "size": size, "fill": fill, "width": 2}})
        return len(self.data) - 1

    def limit(self, values, bound: float, upper: bool, color: Optional[str]) -> None:
        """A limit line (dashed in ``color``, or invisible when None) and a red fill between it and
        the part of ``values`` beyond it."""
        values = np.asarray(values, float)
        line = np.full(values.shape, float(bound))
        i_line = self.curve("limit", line, color or TRANSPARENT, 1.5, dash=(6, 4), visible=color is not None)
        beyond = np.maximum(values, bound) if upper else np.minimum(values, bound)
        i_beyond = self.curve("beyond", beyond, TRANSPARENT, 0.0)
        self.bands.append({"series": (i_beyond, i_line) if upper else (i_line, i_beyond), "fill": OVER_LIMIT_FILL})

    def build(self, legend: str, y_range=None, x_range=None) -> PlotSpec:
        return PlotSpec(tuple(self.data), tuple(self.series), tuple(self.bands),
                        y_range or _range(self.visible), legend, x_range)


def _snap(theta: np.ndarray, where: Sequence[float]) -> np.ndarray:
    """Zeros at the grid points nearest to ``where``, NaN elsewhere (markers on the theta axis)."""
    out = np.full(theta.size, np.nan)
    for w in where:
        if theta[0] <= w <= theta[-1]:
            out[int(np.argmin(np.abs(theta - w)))] = 0.0
    return out


def _component(theta: np.ndarray, values: np.ndarray, theta0: float) -> np.ndarray:
    """``values`` kept only on the run of finite values that contains theta0 (the orbit through the
    initial state; a chart would join separate runs by straight lines).

    >>> _component(np.arange(6.0), np.array([1, np.nan, 2, 3, np.nan, 4.0]), 2.6).tolist()[2:4]   # exact: copied
    [2.0, 3.0]
    """
    finite = np.isfinite(values)
    j = int(np.clip(np.searchsorted(theta, theta0), 0, theta.size - 1))
    if not finite[j]:
        near = np.flatnonzero(finite)
        if near.size == 0:
            return np.full(values.shape, np.nan)
        j = int(near[np.argmin(np.abs(near - j))])
    lo = j
    while lo > 0 and finite[lo - 1]:
        lo -= 1
    hi = j
    while hi < values.size - 1 and finite[hi + 1]:
        hi += 1
    out = np.full(values.shape, np.nan)
    out[lo:hi + 1] = values[lo:hi + 1]
    return out


def phase_plot(view: ThrowView) -> PlotSpec:
    """theta_dot(theta): orbits through states at rest (both branches, grey), the throw from
    (theta_b, theta_dot_b) to the release (bold), centres (open circles), saddles (filled) and
    points where alpha changes sign (the reduced dynamics is singular there)."""
    pp = view.portrait
    b = _Builder(pp.theta, "θ [m]")
    for sign in (1.0, -1.0):
        for curve in pp.curves[:-1]:
            b.curve("from rest", sign * _component(pp.theta, curve.theta_dot, curve.theta0), "#9aa0a6", 1.0)
    own = pp.curves[-1]
    b.curve("same energy as the throw", _component(pp.theta, own.theta_dot, own.theta0), "#7fa7d9", 1.2, dash=(4, 3))
    b.curve("this throw", view.throw_curve, hex_color(JOINT_COLORS[0]), 3.0)
    centres = [e.theta for e in pp.equilibria if e.kind == "center"]
    saddles = [e.theta for e in pp.equilibria if e.kind != "center"]
    b.markers("centre", _snap(pp.theta, centres), "#1e7b34", "#ffffff")
    b.markers("saddle", _snap(pp.theta, saddles), "#b3261e", "#b3261e")
    b.markers("α = 0", _snap(pp.theta, pp.singular), "#222222", "#222222", 7.0)
    top = max(float(np.nanmax(view.throw_curve)) if np.isfinite(view.throw_curve).any() else 0.0, 0.5) * 1.35
    kinds = []
    if centres:
        kinds.append(f"{len(centres)} centre{'s' if len(centres) > 1 else ''} (ω > 0)")
    if saddles:
        kinds.append(f"{len(saddles)} saddle{'s' if len(saddles) > 1 else ''} (ω < 0)")
    items = [_swatch(hex_color(JOINT_COLORS[0]), "this throw θb → θe"),
             _swatch("#7fa7d9", "its orbit beyond", dashed=True),
             _swatch("#9aa0a6", "orbits from rest"),
             '<span style="margin-right:9px;white-space:nowrap"><span style="color:#1e7b34">○</span> centre</span>',
             '<span style="margin-right:9px;white-space:nowrap"><span style="color:#b3261e">●</span> saddle</span>']
    if pp.singular:
        items.append('<span style="white-space:nowrap">● α = 0 (singular)</span>')
    title = "Phase portrait θ̇(θ) [m/s] of the reduced dynamics" + (f": {', '.join(kinds)}" if kinds else
                                                                    ": no equilibrium in this range")
    reachable = pp.theta[np.isfinite(pp.alpha)]          # the constraint can be reached there
    x_range = (float(reachable[0]), float(reachable[-1])) if reachable.size > 1 else None
    return b.build(legend_html(title, items), (-top, top), x_range)


def angles_plot(view: ThrowView, limits: Optional[Dict[str, np.ndarray]] = None) -> PlotSpec:
    """q1, q2, q3 [rad] over time; red where a joint leaves its range."""
    limits = limits or view.throw.arm.limits
    tr = view.samples
    b = _Builder(tr.t, "t [s]")
    for i in range(3):
        b.curve(f"q{i + 1}", tr.q[i], hex_color(JOINT_COLORS[i]))
    for i in range(3):
        for bound, upper in ((limits["lower"][i], False), (limits["upper"][i], True)):
            if np.isfinite(bound):
                b.limit(tr.q[i], bound, upper, None)
    items = [_swatch(hex_color(JOINT_COLORS[i]), f"q{i + 1}") for i in range(3)]
    items.append(_swatch(OVER_LIMIT_FILL, "outside the joint range", fill=True))
    return b.build(legend_html("Joint angles q [rad] over time t [s]", items))


def speeds_plot(view: ThrowView, limits: Optional[Dict[str, np.ndarray]] = None) -> PlotSpec:
    """|q_dot_i| / limit_i over time, the limit 1 dashed, red where any joint is too fast."""
    limits = limits or view.throw.arm.limits
    tr = view.samples
    speed = limits["speed"]
    ratios = np.abs(tr.dq) / speed[:, None]
    b = _Builder(tr.t, "t [s]")
    for i in range(3):
        b.curve(f"|q̇{i + 1}| / {speed[i]:.3g}", ratios[i], hex_color(JOINT_COLORS[i]))
    b.limit(ratios.max(axis=0), 1.0, True, LIMIT_STROKE)
    lo, hi = _range(b.visible)
    items = [_swatch(hex_color(JOINT_COLORS[i]), f"q̇{i + 1} (limit {speed[i]:.3g} rad/s)") for i in range(3)]
    items += [_swatch(LIMIT_STROKE, "limit", dashed=True), _swatch(OVER_LIMIT_FILL, "over the limit", fill=True)]
    return b.build(legend_html("Joint speeds |q̇| / their limit over time t [s]", items), (min(lo, 0.0), hi))


def torques_plot(view: ThrowView, limits: Optional[Dict[str, np.ndarray]] = None) -> PlotSpec:
    """tau1, tau2 [N m] over time with their limits dashed (same colour), red beyond them."""
    limits = limits or view.throw.arm.limits
    tr = view.samples
    b = _Builder(tr.t, "t [s]")
    for i in range(2):
        b.curve(f"τ{i + 1}", tr.tau[i], hex_color(JOINT_COLORS[i]))
    for i in range(2):
        L = float(limits["torque"][i])
        if np.isfinite(L):
            b.limit(tr.tau[i], L, True, hex_color(JOINT_COLORS[i]))
            b.limit(tr.tau[i], -L, False, hex_color(JOINT_COLORS[i]))
    items = [_swatch(hex_color(JOINT_COLORS[i]), f"τ{i + 1} (limit ±{limits['torque'][i]:g} N m, dashed)")
             for i in range(2)]
    items.append(_swatch(OVER_LIMIT_FILL, "over the limit", fill=True))
    return b.build(legend_html("Actuator torques τ [N m] over time t [s]", items))


# ====================================================================== HTML
BADGE_COLORS = {"feasible": ("#1e7b34", "#e6f4ea", "&#10004;"), "infeasible": ("#b3261e", "#fce8e6", "&#10008;"),
                "error": ("#ffffff", "#b3261e", "&#9888;"), "pending": ("#5f6368", "#f1f3f4", "&#8943;")}


def badge_html(state: str, title: str, details: Sequence[str] = (), note: str = "") -> str:
    """The feasibility badge: ``feasible``, ``infeasible`` (limits exceeded), ``error`` (the throw
    cannot be carried out), ``pending``; ``details`` are listed under it.

    >>> 'data-state="error"' in badge_html("error", "cannot be carried out", ["unreachable"])
    True
    """
    fg, bg, icon = BADGE_COLORS[state]
    items = "".join(f"<li>{html.escape(d)}</li>" for d in details)
    listing = (f'<ul class="r2-throw-violations" style="margin:3px 0 0 0;padding-left:18px;font-size:0.92em">'
               f"{items}</ul>") if details else ""
    extra = f'<div style="font-size:0.9em;margin-top:3px;opacity:0.9">{html.escape(note)}</div>' if note else ""
    return (f'<div class="r2-throw-badge" data-state="{state}" style="font-size:0.84em;color:{fg};background:{bg};'
            f'border-radius:6px;padding:5px 9px;margin:4px 14px 4px 9px"><b>{icon} {html.escape(title)}</b>{listing}{extra}</div>')


def feasibility_badge(feas: Feasibility) -> str:
    if feas.feasible:
        speeds = ", ".join(f"{r:.0%}" for r in feas.max_speed_ratio)
        torques = ", ".join(f"{t:.0f}" for t in feas.max_torque)
        return badge_html("feasible", "Feasible: every limit of Table A.2 holds",
                          note=f"peak speeds {speeds} of their limits; peak torques {torques} N m")
    n = len(feas.violations)
    return badge_html("infeasible", f"Infeasible: {n} limit{'s' if n > 1 else ''} exceeded", feas.violations)


def _fmt(v: float, digits: int = 4) -> str:
    return f"{v:.{digits}f}"


def summary_html(view: ThrowView, thesis: Optional[Dict[str, float]] = None) -> str:
    """Release state, the four distances, peak speeds and torques, and what the thesis reports."""
    rel, feas = view.release, view.feasibility
    arm = view.throw.arm
    speed_deg = math.degrees(math.atan2(rel.velocity[1], rel.velocity[0]))
    rows = [("true velocity J(q) q̇", f"{rel.speed:.3f} m/s at {speed_deg:.1f}°",
             rel.distance_from_base, rel.distance_from_release, FLIGHTS["true"][1]),
            ("thesis: θ̇ along ψ", f"{rel.theta_dot:.3f} m/s at {view.spec.psi_deg:.1f}°",
             rel.distance_from_base_thesis, rel.distance_from_release_thesis, FLIGHTS["thesis"][1])]
    body = "".join(
        f'<tr><td><span style="color:{hex_color(c)}">●</span> {html.escape(name)}<br>'
        f'<span style="color:#666">{html.escape(v)}</span></td>'
        f'<td style="text-align:right"><b>{_fmt(d1, 3)} m</b></td><td style="text-align:right">{_fmt(d2, 3)} m</td></tr>'
        for name, v, d1, d2, c in rows)
    table = ('<table class="r2-throw-distances" style="width:100%;border-collapse:collapse;font-size:0.95em">'
             '<tr style="color:#555"><td>ball launched with</td><td style="text-align:right">from the base</td>'
             f'<td style="text-align:right">from the release</td></tr>{body}</table>')
    speeds = ", ".join(f"q{i + 1} {r:.1%}" for i, r in enumerate(feas.max_speed_ratio))
    torques = ", ".join(f"τ{i + 1} {t:.1f} / {arm.limits['torque'][i]:g}" for i, t in enumerate(feas.max_torque))
    lines = [f"θ̇ at release <b>{rel.theta_dot:.4f} m/s</b> after <b>{view.duration * 1000:.1f} ms</b>; "
             f"released at x = {rel.position[0]:.3f} m, y = {rel.position[1]:.3f} m above the ground",
             f"peak joint speeds: {html.escape(speeds)} of their limits",
             f"peak torques [N m]: {html.escape(torques)}"]
    if thesis:
        parts = []
        if "theta_dot_e" in thesis:
            parts.append(f"θ̇ {thesis['theta_dot_e']:g} m/s")
        if "duration" in thesis:
            parts.append(f"T {thesis['duration'] * 1000:.1f} ms")
        if "distance_from_base" in thesis:
            parts.append(f"{thesis['distance_from_base']:g} m from the base, "
                         f"{thesis.get('distance_from_release', float('nan')):g} m from the release (its convention)")
        lines.append("the thesis reports: " + html.escape(", ".join(parts))
                     + ' <span style="color:#666">(docs/throwing.md explains the differences)</span>')
    return (f'<div class="r2-throw-summary" style="font-size:0.82em;color:#222;line-height:1.4;{BLOCK}">{table}'
            + "".join(f'<div style="margin-top:3px">{line}</div>' for line in lines) + "</div>")


def verification_html(sims: Sequence, view: ThrowView) -> str:
    """The full 3-DOF simulations (``simulate_full``, one column each) beside the VHC prediction:
    drifts, the error of theta_dot, the duration and where the simulated ball lands."""
    rel = view.release
    names = {"feedforward": "VHC torques (open loop)", "computed_torque": "tracking controller"}
    rows = [("wrist drift max |q3 − q3,VHC| [rad]", [f"{s.max_wrist_drift:.1e}" for s in sims]),
            ("ball drift [m]", [f"{s.max_ball_drift:.1e}" for s in sims]),
            ("θ̇(θ) error / θ̇e", [f"{s.max_theta_dot_error:.1e}" for s in sims]),
            (f"time to θe, minus the VHC's {view.duration * 1e3:.2f} ms",
             [f"{(s.duration - view.duration) * 1e3:+.1e} ms" for s in sims]),
            (f"lands, J q̇ (VHC {rel.distance_from_base:.4f} m)",
             [f"{s.release.distance_from_base:.4f} m" for s in sims]),
            (f"lands, θ̇ along ψ (VHC {rel.distance_from_base_thesis:.4f} m)",
             [f"{s.release.distance_from_base_thesis:.4f} m" for s in sims])]
    head = "".join(f'<td style="text-align:right;color:#555">{html.escape(names.get(s.controller, s.controller))}</td>'
                   for s in sims)
    body = "".join(f"<tr><td>{html.escape(label)}</td>"
                   + "".join(f'<td style="text-align:right">{v}</td>' for v in values) + "</tr>"
                   for label, values in rows)
    return (f'<div class="r2-throw-verification" style="font-size:0.8em;color:#222;{BLOCK}">'
            "<b>Full dynamics</b>: the complete 3-DOF arm, wrist free, simulated from the VHC's initial state "
            "until the ball reaches θe, joints 1 and 2 driven by the VHC torques or by a tracking controller; "
            "drifts are the largest distances from the VHC prediction."
            f'<table style="width:100%;border-collapse:collapse;margin-top:3px"><tr><td></td>{head}</tr>{body}</table>'
            "</div>")
