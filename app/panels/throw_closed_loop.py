"""The throw studio's *Closed loop* tab: the throw on display, run in full dynamics under the three
controllers on a plant drawn from user-set uncertainty ranges (a seeded Monte-Carlo study,
app/core/throw/montecarlo.py), shown as a histogram of the landing distance and a scatter of release
speed against landing distance beside the planned throw, with a summary table per controller.

The study runs off the event thread with a progress bar; the panel only builds widgets and HTML
(inline SVG), the numbers come from the core.
"""
from __future__ import annotations

import html
from dataclasses import replace
from typing import Dict, List, Optional

import numpy as np

from app.core.errors import UserError
from app.core.throw.closed_loop import CONTROLLERS
from app.core.throw.plants import list_plant_names, load_plant
from app.core.throw.catch import CAMERA_NOISE, CAMERA_RATE, ThrowAndCatch, throw_and_catch
from app.core.throw.montecarlo import Study, histogram
from app.core.throw.study import closed_loop_study
from app.viewer import in_worker

from .throw_plots import BLOCK, StudioTab, status_html

#: controller colours (open, vhc, transverse)
COLORS = {"open": "#c0392b", "vhc": "#e69f00", "transverse": "#2e5eaa"}
LABELS = {"open": "open loop (plan's torques)", "vhc": "VHC enforced (FL + PD)", "transverse": "transverse LQR"}


def _svg_frame(width: int, height: int, body: str, title: str) -> str:
    return (f'<svg class="r2-cl-plot" xmlns="http://www.w3.org/2000/svg" width="100%" viewBox="0 0 {width} {height}" '
            f'role="img" aria-label="{html.escape(title)}" style="background:#fff;{BLOCK}">{body}</svg>')


def _ticks(lo: float, hi: float, count: int = 5) -> List[float]:
    return list(np.linspace(lo, hi, count))


def histogram_svg(study: Study, controllers, bins: int = 30, width: int = 360, height: int = 190) -> str:
    """Landing distances per controller as overlaid step histograms, the planned distance dashed."""
    runs = {c: study.results[c].distance for c in controllers}
    finite = np.concatenate([d[np.isfinite(d)] for d in runs.values()] + [np.array([study.planned_distance])])
    lo, hi = float(finite.min()), float(finite.max())
    pad = 0.02 * max(hi - lo, 1e-3)
    lo, hi = lo - pad, hi + pad
    left, right, top, bottom = 40, 8, 18, 30
    pw, ph = width - left - right, height - top - bottom
    counts = {c: histogram(d, bins, (lo, hi))[0] for c, d in runs.items()}
    top_count = max(1, max(int(c.max()) for c in counts.values()))
    x = lambda v: left + (v - lo) / (hi - lo) * pw
    y = lambda n: top + ph - n / top_count * ph
    parts = [f'<rect x="{left}" y="{top}" width="{pw}" height="{ph}" fill="none" stroke="#bbb"/>']
    edges = np.linspace(lo, hi, bins + 1)
    for c, n in counts.items():
        pts = [f"{x(edges[0]):.1f},{y(0):.1f}"]
        for j in range(bins):
            pts += [f"{x(edges[j]):.1f},{y(n[j]):.1f}", f"{x(edges[j + 1]):.1f},{y(n[j]):.1f}"]
        pts.append(f"{x(edges[-1]):.1f},{y(0):.1f}")
        parts.append(f'<polyline class="r2-cl-hist" data-controller="{c}" points="{" ".join(pts)}" '
                     f'fill="{COLORS[c]}" fill-opacity="0.25" stroke="{COLORS[c]}" stroke-width="1.5"/>')
    xp = x(study.planned_distance)
    parts.append(f'<line x1="{xp:.1f}" y1="{top}" x2="{xp:.1f}" y2="{top + ph}" stroke="#000" stroke-dasharray="4 3"/>')
    parts.append(f'<text x="{xp + 3:.1f}" y="{top + 10}" font-size="10">plan {study.planned_distance:.3f} m</text>')
    for v in _ticks(lo, hi):
        parts.append(f'<text x="{x(v):.1f}" y="{height - 16}" font-size="9" text-anchor="middle">{v:.3f}</text>')
    parts.append(f'<text x="{left + pw / 2:.1f}" y="{height - 3}" font-size="10" text-anchor="middle">'
                 f'landing distance from the base [m]</text>')
    parts.append(f'<text x="4" y="{top + 8}" font-size="9">{top_count}</text>'
                 f'<text x="4" y="{top + ph}" font-size="9">0</text>'
                 f'<text x="{left}" y="12" font-size="10">plants per bin ({study.plants} plants)</text>')
    return _svg_frame(width, height, "".join(parts), "histogram of the landing distance")


def scatter_svg(study: Study, controllers, width: int = 360, height: int = 210, most: int = 600) -> str:
    """Release speed against landing distance, one dot per plant and controller; the plan as a cross."""
    xs, ys = [study.planned_distance], [study.planned_speed]
    for c in controllers:
        r = study.results[c]
        ok = r.released
        xs += list(r.distance[ok][:most])
        ys += list(r.release_speed[ok][:most])
    xlo, xhi, ylo, yhi = min(xs), max(xs), min(ys), max(ys)
    px, py = 0.04 * max(xhi - xlo, 1e-3), 0.04 * max(yhi - ylo, 1e-3)
    xlo, xhi, ylo, yhi = xlo - px, xhi + px, ylo - py, yhi + py
    left, right, top, bottom = 44, 8, 10, 30
    pw, ph = width - left - right, height - top - bottom
    x = lambda v: left + (v - xlo) / (xhi - xlo) * pw
    y = lambda v: top + ph - (v - ylo) / (yhi - ylo) * ph
    parts = [f'<rect x="{left}" y="{top}" width="{pw}" height="{ph}" fill="none" stroke="#bbb"/>']
    for c in controllers:
        r = study.results[c]
        ok = r.released
        dots = "".join(f'<circle cx="{x(d):.1f}" cy="{y(s):.1f}" r="1.6"/>'
                       for d, s in zip(r.distance[ok][:most], r.release_speed[ok][:most]))
        parts.append(f'<g class="r2-cl-scatter" data-controller="{c}" fill="{COLORS[c]}" fill-opacity="0.55">{dots}</g>')
    cx, cy = x(study.planned_distance), y(study.planned_speed)
    parts.append(f'<path class="r2-cl-plan" d="M{cx - 5:.1f},{cy - 5:.1f}L{cx + 5:.1f},{cy + 5:.1f}M{cx - 5:.1f},'
                 f'{cy + 5:.1f}L{cx + 5:.1f},{cy - 5:.1f}" stroke="#000" stroke-width="2"/>')
    for v in _ticks(xlo, xhi):
        parts.append(f'<text x="{x(v):.1f}" y="{height - 16}" font-size="9" text-anchor="middle">{v:.3f}</text>')
    for v in _ticks(ylo, yhi, 4):
        parts.append(f'<text x="{left - 3}" y="{y(v) + 3:.1f}" font-size="9" text-anchor="end">{v:.2f}</text>')
    parts.append(f'<text x="{left + pw / 2:.1f}" y="{height - 3}" font-size="10" text-anchor="middle">landing distance '
                 f'[m] (× the plan) · up: release speed [m/s]</text>')
    return _svg_frame(width, height, "".join(parts), "release speed against landing distance")


def summary_table(study: Study, controllers) -> str:
    rows = []
    for c in controllers:
        s = study.summary(c)
        d, e = s["distance"], s["landing_error"]
        if d["mean"] is None:
            rows.append(f'<tr><td style="color:{COLORS[c]}">{LABELS[c]}</td><td colspan="4">no ball released</td></tr>')
            continue
        q = d["quantiles"]
        rows.append(f'<tr class="r2-cl-row" data-controller="{c}"><td style="color:{COLORS[c]}">{LABELS[c]}</td>'
                    f'<td>{d["mean"]:.4f} ± {d["std"]:.4f}</td><td>{q["0.05"]:.3f} / {q["0.5"]:.3f} / {q["0.95"]:.3f}</td>'
                    f'<td>{e["mean"]:.4f}</td><td>{100 * s["violation_rate"]:.1f} %</td></tr>')
    return (f'<table class="r2-cl-table" style="font-size:0.75em;border-collapse:collapse;{BLOCK}">'
            '<tr><th>controller</th><th>distance [m]</th><th>5 % / median / 95 %</th><th>mean |error| [m]</th>'
            '<th>limits violated</th></tr>' + "".join(rows) + "</table>"
            f'<div class="r2-label" style="font-size:0.75em;color:#444;{BLOCK}">Plan: {study.planned_distance:.4f} m, '
            f'release speed {study.planned_speed:.4f} m/s; {study.plants} plants, seed {study.seed}.</div>')


class ClosedLoopTab(StudioTab):
    """Widgets of the *Closed loop* tab; ``studio`` is the ThrowStudio (its ``view`` is the throw on display)."""

    def __init__(self, studio):
        super().__init__(studio, "Run the throw on display in the full 3-DOF dynamics on plants that differ from the "
                                 "model (wrist passive): the plan's torques open loop, the VHC enforced by feedback, "
                                 "or the transverse LQR stabilizer of the orbit. Plants are drawn from the ranges "
                                 "below (a seeded Monte-Carlo study).")
        gui = studio.gui
        plants = list_plant_names()
        self.plant = gui.add_dropdown("Plant", plants, initial_value="heavier" if "heavier" in plants else plants[0],
                                      hint="the arm actually driven (app/throws/plants): its parameters, friction, "
                                           "noise and control period")
        self.mass = gui.add_slider("± masses, CoMs [%]", min=0.0, max=30.0, step=0.5, initial_value=5.0,
                                   hint="each draw multiplies m_i and c_i by a factor in [1 - r, 1 + r]")
        self.inertia = gui.add_slider("± inertias [%]", min=0.0, max=30.0, step=0.5, initial_value=10.0,
                                      hint="each draw multiplies J_i by a factor in [1 - r, 1 + r]")
        self.spring = gui.add_slider("± spring k [%]", min=0.0, max=30.0, step=0.5, initial_value=5.0)
        self.coulomb = gui.add_slider("Wrist Coulomb up to [N m]", min=0.0, max=1.0, step=0.01, initial_value=0.2,
                                      hint="each draw takes the wrist's Coulomb friction uniformly from [0, this]")
        self.count = gui.add_number("Plants", 500, min=1, max=5000, step=1, hint="plants drawn (at least 500 for "
                                                                                  "the spread; fewer to try)")
        self.seed = gui.add_number("Seed (plants)", 0, min=0, max=10 ** 6, step=1, hint="seed of the plants and the noise")
        self.run_button = gui.add_button("Run closed loop", hint="simulate every plant under the three controllers")
        self.progress = gui.add_progress_bar(0.0, visible=False, animated=True)
        self.status = gui.add_html("")
        self.table = gui.add_html("")
        self.hist = gui.add_html("")
        self.scatter = gui.add_html("")
        gui.add_html(f'<div class="r2-label" style="font-size:0.8em;color:#444;{BLOCK}"><b>Throw and catch.</b> The '
                     'catching arm (coursework 4M20) stands 0.5 m beyond the planned landing point and catches the '
                     'ball, planned from a camera\'s noisy pictures of the flight (least-squares estimate), not from '
                     'the release state, and moves in its own full dynamics under computed torque. The throw uses the plant '
                     'above (its nominal values).</div>')
        self.catch_controller = gui.add_dropdown("Thrower", list(CONTROLLERS), initial_value="transverse",
                                                 hint="the throwing arm's controller")
        self.camera_rate = gui.add_slider("Camera [pictures/s]", min=10.0, max=500.0, step=10.0,
                                          initial_value=CAMERA_RATE)
        self.camera_noise = gui.add_slider("Camera noise [mm]", min=0.0, max=30.0, step=0.5,
                                           initial_value=1e3 * CAMERA_NOISE, hint="standard deviation per axis")
        self.catch_button = gui.add_button("Throw and catch", hint="simulate the throw, the camera and the catch")
        self.catch_result = gui.add_html("")
        self.study: Optional[Study] = None
        self.catch: Optional[ThrowAndCatch] = None
        self._running = False
        self.run_button.on_click(lambda _e: self.studio._guarded(self.run))
        self.catch_button.on_click(lambda _e: self.studio._guarded(self.throw_and_catch))

    def plant_with_ranges(self):
        plant = load_plant(self.plant.value)
        m, j, k = self.mass.value / 100.0, self.inertia.value / 100.0, self.spring.value / 100.0
        unc: Dict[str, object] = {f"{p}{i}": m for p in ("m", "c") for i in (1, 2, 3)}
        unc.update({f"J{i}": j for i in (1, 2, 3)})
        unc["k"] = k
        unc["coulomb"] = [0.0, float(self.coulomb.value)]
        if "viscous" in plant.uncertainty:
            unc["viscous"] = plant.uncertainty["viscous"]
        return replace(plant, uncertainty=unc)

    def run(self, wait: bool = False):
        """Run the study for the throw on display (in the background; ``wait`` blocks until done)."""
        studio = self.studio
        view = self.throw_on_display("run")
        if self._running:
            raise UserError("the closed-loop study is already running")
        plant = self.plant_with_ranges()      # validated like a plant file
        count, seed = int(self.count.value), int(self.seed.value)
        if count < 1:
            raise UserError("the study needs at least one plant")
        self._running = True
        self.run_button.disabled = True
        self.progress.value = 0.0
        self.progress.visible = True
        self.status.content = status_html(f"simulating {count} plants x 3 controllers ...")

        def work(progress):
            def report(fraction, message):
                progress(fraction, message)
                if studio._alive():
                    self.progress.value = 100 * fraction
                    self.status.content = status_html(message)
            try:
                arm = view.throw.arm        # the study runs in a worker process (app/viewer/worker.py)
                return in_worker(closed_loop_study, arm.robot, arm.values, view.spec, plant, count, seed,
                                 progress=report)
            finally:
                self._running = False
                if studio._alive():
                    self.run_button.disabled = False
                    self.progress.visible = False

        def done(study):
            self.show(study)
            self.status.content = status_html(f"{study.plants} plants, plant '{self.plant.value}': done", done=True)

        return studio.background(work, "Closed-loop throws", self.status, done, wait)

    def throw_and_catch(self, wait: bool = False):
        """Throw the ball on the chosen plant, watch it with the camera and catch it (in the background)."""
        studio = self.studio
        view = self.throw_on_display("catch")
        plant = load_plant(self.plant.value)
        controller, seed = self.catch_controller.value, int(self.seed.value)
        rate, noise = float(self.camera_rate.value), 1e-3 * float(self.camera_noise.value)
        self.catch_button.disabled = True
        self.catch_result.content = status_html("throwing, watching, catching ...")

        def work(progress):
            progress(0.1, f"throwing ({controller})")
            try:
                return throw_and_catch(view.throw, plant, controller, rate=rate, noise=noise, seed=seed)
            finally:
                if studio._alive():
                    self.catch_button.disabled = False

        return studio.background(work, "Throw and catch", None, self.show_catch, wait)

    def show_catch(self, r: ThrowAndCatch) -> None:
        """The outcome as text and the catch in the 3D view: the catching arm at its catch pose, the
        camera's pictures and the planned catch point beside the true ball."""
        self.catch = r
        color = "#1e7b34" if r.success else "#b3261e"
        detail = (f" at {r.catch_time:.3f} s after the release; {r.camera_times.size} pictures, "
                  f"estimated release speed {np.hypot(*r.estimate.v0):.3f} m/s (true {np.hypot(*r.release_velocity):.3f})"
                  if r.catch_time is not None else "")
        if r.run is not None:
            detail += (f"; catching arm in full dynamics (computed torque), tracking error "
                       f"{1e3 * r.run.hand_tracking_error:.2f} mm at the hand, max |tau| "
                       + " ".join(f"{x:.0f}" for x in r.run.max_torque) + " N m")
        self.catch_result.content = (f'<div class="r2-catch-result" data-success="{str(r.success).lower()}" '
                                     f'style="font-size:0.85em;color:{color};{BLOCK}"><b>{html.escape(r.message)}</b>'
                                     f'{html.escape(detail)}</div>')
        nodes = self.studio.nodes
        base = np.array([r.base_x, 0.0])
        pictures = r.camera_positions.T
        nodes.segments("catch_pictures", np.stack([pictures - [0.01, 0], pictures + [0.01, 0]], axis=1),
                       (90, 90, 90), width=2.0)
        if r.q_catch is None:
            nodes.remove("catch_arm")
            nodes.remove("catch_point")
            nodes.remove("catch_ball")
            return
        from app.core.catching import CatchingArm
        arm_points = CatchingArm().joints(r.q_catch if r.q_end is None else r.q_end) + base
        nodes.polyline("catch_arm", arm_points, (40, 40, 40), width=5.0)
        nodes.sphere("catch_point", r.hand, 0.05, (30, 123, 52) if r.success else (179, 38, 30))
        nodes.sphere("catch_ball", r.ball, 0.025, (200, 30, 30))

    def show(self, study: Study) -> None:
        self.study = study
        self.table.content = summary_table(study, CONTROLLERS)
        self.hist.content = histogram_svg(study, CONTROLLERS)
        self.scatter.content = scatter_svg(study, CONTROLLERS)
