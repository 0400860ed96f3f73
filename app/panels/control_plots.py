"""The Control tab's plots of a run (app/panels/control.py): which series go together
(``plot_groups``: errors, torques, estimates, residuals, contact forces, internals), their axis
scale, the samples drawn, and the PNG download. Not a tab: no ``TITLE`` nor ``build``."""
from __future__ import annotations

import io
from typing import List, Optional, Sequence, Tuple

import numpy as np

from app.core.sim import SimResult

COLORS = ["#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#17becf",
          "#7f7f7f", "#bcbd22"]
MAX_PLOT_POINTS = 1500


def plot_groups(res: SimResult, true_coefficients: Optional[Sequence[float]] = None
                ) -> List[Tuple[str, List[Tuple[str, np.ndarray, bool, int]]]]:
    """The plots of a run: (title, [(label, values, dashed, color index), ...]) for errors,
    torques, estimates (with the true values dashed, same colour), residuals (with J^T F dashed),
    contact forces, other internals.

    >>> from app.core.sim import simulate
    >>> res = simulate("planar_2r", "adaptive", duration=0.01, observer=10)
    >>> [title for title, _ in plot_groups(res)]
    ['Tracking error e = q_d - q', 'Torques τ', 'Estimates â', 'Collision residual r (dashed: Jᵀ F)']
    """
    groups = []
    task = bool(res.reference_names) and res.reference_names[0] in ("x", "y", "z", "s", "s1", "s2")

    def numbered(items, dashed=False):
        return [(label, values, dashed, k) for k, (label, values) in enumerate(items)]
    groups.append((f"Tracking error e = {'p_d - p' if task else 'q_d - q'}",
                   numbered([(f"e_{r}", res.e[:, i]) for i, r in enumerate(res.reference_names)])))
    groups.append(("Torques τ", numbered([(f"τ_{c}", res.tau[:, i]) for i, c in enumerate(res.coordinates)])))
    internals = dict(res.internals)
    estimates = [k for k in internals if k.startswith("a_hat")]
    if estimates:
        series = numbered([(k.replace("a_hat", "â"), internals.pop(k)) for k in estimates])
        if true_coefficients is not None:
            series += numbered([(f"a{i + 1}", np.full(len(res.t), float(v))) for i, v in enumerate(true_coefficients)],
                               dashed=True)
        groups.append(("Estimates â" + (" (dashed: true values)" if true_coefficients is not None else ""), series))
    residuals = [k for k in internals if k.startswith("r_")]
    if residuals:
        series = numbered([(k, internals.pop(k)) for k in residuals])
        if res.tau_ext is not None:
            series += numbered([(f"(Jᵀ F)_{c}", res.tau_ext[:, i]) for i, c in enumerate(res.coordinates)], dashed=True)
        groups.append(("Collision residual r (dashed: Jᵀ F)", series))
    forces = [(f"F_{name}_{a}", arr[:, j]) for name, arr in res.forces.items()
              for j, a in enumerate(res.force_axes[:arr.shape[1]])]
    forces += [(k, internals.pop(k)) for k in [k for k in internals if k.startswith("F_") or k in ("lambda", "f_c")]]
    if forces:
        groups.append(("Contact forces [N] (on the robot)",
                       [(label, v, label == "f_c", k) for k, (label, v) in enumerate(forces)]))
    if internals:
        groups.append(("Controller internals", numbered(list(internals.items()))))
    return groups


def decade(series) -> int:
    """The power of ten that brings a plot's values into [1, 10000) for its axis labels (0 when
    they already are), since uPlot's default tick labels keep 3 decimals.

    >>> decade([("e", np.array([2e-5, -3e-5]), False, 0)])
    -5
    >>> decade([("tau", np.array([120.0, -35.0]), False, 0)])
    0
    """
    peak = max((float(np.max(np.abs(v))) for _, v, _, _ in series), default=0.0)
    if peak == 0.0 or 0.01 <= peak < 1e4:
        return 0
    return int(np.floor(np.log10(peak)))


def plot_indices(n: int) -> np.ndarray:
    """Indices of at most MAX_PLOT_POINTS samples, always including the last one."""
    if n <= MAX_PLOT_POINTS:
        return np.arange(n)
    idx = np.linspace(0, n - 1, MAX_PLOT_POINTS).round().astype(int)
    return np.unique(idx)


def plots_png(res: SimResult, groups, width: int = 900, height_each: int = 220) -> bytes:
    """A PNG of the plots (stacked, one per group), drawn with Pillow.

    >>> from app.core.sim import simulate
    >>> res = simulate("planar_2r", "computed_torque", reference="quintic by=0.3 T=0.05", duration=0.05)
    >>> plots_png(res, plot_groups(res))[:8] == b"\\x89PNG\\r\\n\\x1a\\n"
    True
    """
    from PIL import Image, ImageDraw, ImageFont
    font = ImageFont.load_default(size=13)
    small = ImageFont.load_default(size=11)
    img = Image.new("RGB", (width, height_each * len(groups) + 30), "white")
    d = ImageDraw.Draw(img)
    d.text((10, 6), f"{res.robot} · {res.title} · {res.reference}"
           + ("" if res.completed else f" · {res.message}"), fill="black", font=font)
    left, right = 70, width - 20
    t = res.t
    t0, t1 = float(t[0]), float(t[-1]) if t[-1] > t[0] else float(t[0]) + 1.0
    for g, (title, series) in enumerate(groups):
        top = 30 + g * height_each + 22
        bottom = 30 + (g + 1) * height_each - 28
        values = np.concatenate([v for _, v, _, _ in series]) if series else np.zeros(1)
        lo, hi = float(np.min(values)), float(np.max(values))
        if hi - lo < 1e-12:
            lo, hi = lo - 1.0, hi + 1.0
        pad = 0.05 * (hi - lo)
        lo, hi = lo - pad, hi + pad
        d.text((left, top - 20), title, fill="black", font=font)
        d.rectangle((left, top, right, bottom), outline="#999999")
        if lo < 0 < hi:
            y0 = bottom - (0 - lo) / (hi - lo) * (bottom - top)
            d.line((left, y0, right, y0), fill="#dddddd")
        for y, label in ((top, hi), (bottom, lo)):
            d.text((5, y - 7), f"{label:.3g}", fill="#444444", font=small)
        d.text((left, bottom + 4), f"{t0:g} s", fill="#444444", font=small)
        d.text((right - 40, bottom + 4), f"{t1:g} s", fill="#444444", font=small)
        idx = plot_indices(len(t))
        xs = left + (t[idx] - t0) / (t1 - t0) * (right - left)
        legend_x = left + 60
        for label, v, dashed, ci in series:
            color = COLORS[ci % len(COLORS)]
            ys = bottom - (v[idx] - lo) / (hi - lo) * (bottom - top)
            pts = list(zip(xs.tolist(), ys.tolist()))
            if dashed:
                for j in range(0, len(pts) - 1, 2):
                    d.line(pts[j:j + 2], fill=color, width=1)
            else:
                d.line(pts, fill=color, width=2)
            d.text((legend_x, bottom + 4), label, fill=color, font=small)
            legend_x += 9 * len(label) + 14
    buf = io.BytesIO()
    img.save(buf, format="PNG")
    return buf.getvalue()
