"""The Throw studio's *Edit* tab: the sliders of psi, theta_b, theta_e, the spring k, one Bezier
control point at a time, the control points as text (applied when the typing pauses), raising the
degree, the chart's control points dragged in the 3D view, and the throw as a file. The numbers
live in the studio's ``draft`` (app.core.throw.study.ThrowDraft); every change asks the studio to
solve the throw again (``draft_changed``).
"""
from __future__ import annotations

import math
import threading
from typing import Dict, List

from app.core.errors import UserError
from app.core.throw.study import format_points, parse_points, parse_stiffness
from app.viewer import CommittedField

from .throw_plots import BLOCK

TYPING_PAUSE = 0.8        # seconds of quiet before typed control points are applied (or refused)


class EditTab:
    """Widgets of the *Edit* tab; ``studio`` is the ThrowStudio (``draft``, ``lock``, ``draft_changed()``)."""

    def __init__(self, studio):
        self.studio = studio
        self.session = studio.session
        self.selected = ("a", 0)                   # the control point of the slider and the chart
        self._typing_timers: Dict[str, threading.Timer] = {}
        gui, v = studio.gui, studio.draft
        arm = studio.arm()
        reach = arm.l1 + arm.l2 + arm.l3
        self.psi = gui.add_slider("ψ [deg]", min=-30.0, max=90.0, step=0.01, initial_value=float(v.psi_deg),
                                  hint="rotation of the θ axis through the shoulder (the thesis's release angle)")
        self.theta_b = gui.add_slider("θb [m]", min=-round(reach, 3), max=round(reach, 3), step=0.0005,
                                      initial_value=float(v.theta_b), hint="θ at the start (s = 0)")
        self.theta_e = gui.add_slider("θe [m]", min=-round(reach, 3), max=round(reach, 3), step=0.0005,
                                      initial_value=float(v.theta_e), hint="θ at the release (s = 1)")
        self.k = CommittedField(
            gui.add_text("Spring k [N m/rad]", f"{float(v.k):.6g}",
                         hint="stiffness of the wrist spring: a number or an expression (1e3, 2*pi); "
                              "taken when you stop typing"),
            parse_stiffness, self._stiffness_committed,
            lambda message: self.session.notify("Spring not changed",
                                                f"{message}; keeping k = {studio.draft.k:.6g}", error=True),
            format=lambda value: f"{float(value):.6g}")
        self.theta_dot_b = gui.add_number("θ̇b [m/s]", float(v.theta_dot_b), min=0.0, max=20.0, step=0.01,
                                          hint="initial speed along θ (0: from rest)")
        for key, handle in (("psi_deg", self.psi), ("theta_b", self.theta_b), ("theta_e", self.theta_e),
                            ("theta_dot_b", self.theta_dot_b)):
            handle.on_update(lambda e, key=key: self._number_edited(key, e))
        gui.add_html(f'<div class="r2-label" style="font-size:0.8em;color:#555;margin-top:6px;{BLOCK}">Bézier control '
                     'points: pick one and slide it, type them all, or drag them in the chart of the 3D view.</div>')
        self.point = gui.add_dropdown("Control point", self._point_options(), initial_value=self._point_options()[0])
        self.point_value = gui.add_slider("Value [rad]", min=-2.1, max=3.7, step=0.001, initial_value=float(v.a[0]))
        self.a_text = gui.add_text("φ1 points a [rad]", format_points(v.a),
                                   hint="control points of q1 = φ1(s), comma-separated (pi allowed)")
        self.b_text = gui.add_text("φ2 points b [rad]", format_points(v.b),
                                   hint="control points of q2 = φ2(s), comma-separated (pi allowed)")
        self.raise_degree = gui.add_button("Raise the degree", hint="the same curves with one more control point each")
        self.show_chart = gui.add_checkbox("Chart in the 3D view", True,
                                           hint="the Bézier curves below the ground, with draggable control points")
        self.point.on_update(lambda e: self._point_picked(e))
        self.point_value.on_update(self._point_slid)
        self.a_text.on_update(lambda e: self._points_typed("a", e))
        self.b_text.on_update(lambda e: self._points_typed("b", e))
        self.raise_degree.on_click(lambda _e: studio._guarded(self._raise_degree))
        self.show_chart.on_update(lambda e: self._chart_toggled(e))
        self.download = gui.add_button("Download the throw (YAML)",
                                       hint="a throw file for `python -m app throw FILE --json`")
        self.upload = gui.add_upload_button("Open a throw file", mime_type=".yaml,.yml,.json",
                                            hint="YAML or JSON with theta_b, theta_e, psi_deg, k, a, b")
        self.download.on_click(studio._download)
        self.upload.on_upload(studio._uploaded)
        self._sync_point_slider()

    # ================================================================== widgets from the draft
    def _point_options(self) -> List[str]:
        a, b = self.studio.draft.a, self.studio.draft.b
        return ([f"a{i}  (φ1 at s = {i / (len(a) - 1):.3g})" for i in range(len(a))]
                + [f"b{i}  (φ2 at s = {i / (len(b) - 1):.3g})" for i in range(len(b))])

    def _selected_label(self) -> str:
        kind, i = self.selected
        return next(o for o in self._point_options() if o.split()[0] == f"{kind}{i}")

    def _sync_point_slider(self) -> None:
        kind, i = self.selected
        lim = self.studio.limits
        j = 0 if kind == "a" else 1
        lo, hi = float(lim["lower"][j]), float(lim["upper"][j])
        value = float(self.studio.draft.points(kind)[i])
        self.point_value.min = math.floor(min(lo, value) * 1000) / 1000
        self.point_value.max = math.ceil(max(hi, value) * 1000) / 1000
        self.point_value.value = value

    def sync(self) -> None:
        """Every editor widget from the studio's draft (after a load, a drag, a typed list)."""
        v = self.studio.draft
        self.psi.value = float(v.psi_deg)
        self.theta_b.value = float(v.theta_b)
        self.theta_e.value = float(v.theta_e)
        self.k.set(float(v.k))
        self.theta_dot_b.value = float(v.theta_dot_b)
        self._sync_texts()
        options = self._point_options()
        kind, i = self.selected
        if i >= len(v.points(kind)):
            self.selected = (kind, len(v.points(kind)) - 1)
        if list(self.point.options) != options:
            self.point.options = options
        self.point.value = self._selected_label()
        self._sync_point_slider()

    def _sync_texts(self) -> None:
        for kind, field in (("a", self.a_text), ("b", self.b_text)):
            points = self.studio.draft.points(kind)
            try:
                same = parse_points(field.value, kind) == [float(f"{x:.5g}") for x in points]
            except UserError:
                same = False
            if not same:
                field.value = format_points(points)

    # ================================================================== edits
    def _stiffness_committed(self, value: float) -> None:
        with self.studio.lock:
            self.studio.draft.k = value
        self.studio.draft_changed()

    def _number_edited(self, key: str, event) -> None:
        if event.client is None:
            return
        with self.studio.lock:
            setattr(self.studio.draft, key, float(event.target.value))
        self.studio.draft_changed()

    def _point_picked(self, event) -> None:
        if event.client is None:
            return
        label = event.target.value.split()[0]
        self.selected = (label[0], int(label[1:]))
        self._sync_point_slider()
        self.studio.redraw_chart()

    def _point_slid(self, event) -> None:
        if event.client is None:
            return
        kind, i = self.selected
        with self.studio.lock:
            points = self.studio.draft.points(kind)
            points[i] = float(event.target.value)
        self._sync_texts()
        self.studio.chart.move_point(kind, i, len(points), float(event.target.value))
        self.studio.draft_changed()

    def _points_typed(self, kind: str, event) -> None:
        """A control-point list is being typed (the browser sends every keystroke): it is applied once
        the typing pauses, so that half-typed lists are neither solved nor refused."""
        if event.client is None:
            return
        timer = self._typing_timers.pop(kind, None)
        if timer is not None:
            timer.cancel()
        timer = threading.Timer(TYPING_PAUSE, self.studio._guarded, (self._apply_typed, kind, event.target))
        timer.daemon = True
        self._typing_timers[kind] = timer
        timer.start()

    def _apply_typed(self, kind: str, field) -> None:
        """Apply a typed list; a bad one is refused with a message and the last good list comes back."""
        studio = self.studio
        if not studio._alive():
            return
        try:
            values = parse_points(field.value, f"φ{1 if kind == 'a' else 2} points {kind}")
        except UserError as exc:
            kept = format_points(studio.draft.points(kind))
            field.value = kept
            self.session.notify("Control points not changed", f"{exc}; keeping {kept}", error=True)
            return
        with studio.lock:
            if values == studio.draft.points(kind):
                return
            setattr(studio.draft, kind, values)
        options = self._point_options()
        sel_kind, i = self.selected
        if i >= len(studio.draft.points(sel_kind)):
            self.selected = (sel_kind, len(studio.draft.points(sel_kind)) - 1)
        if list(self.point.options) != options:
            self.point.options = options
            self.point.value = self._selected_label()
        self._sync_point_slider()
        studio.draft_changed()

    def _raise_degree(self) -> None:
        with self.studio.lock:
            self.studio.draft = self.studio.draft.raised()
        self.sync()
        self.studio.draft_changed()

    def chart_dragged(self, kind: str, index: int, value: float, phase: str) -> None:
        """A control point of the 3D view's chart was dragged to ``value`` (kept within its joint's range)."""
        lim = self.studio.limits
        j = 0 if kind == "a" else 1
        value = float(min(max(value, lim["lower"][j]), lim["upper"][j]))
        with self.studio.lock:
            points = self.studio.draft.points(kind)
            points[index] = value
        if phase == "start" or self.selected != (kind, index):
            self.selected = (kind, index)
            self.point.value = self._selected_label()
            self._sync_point_slider()
        else:
            self.point_value.value = value
        self.studio.chart.move_point(kind, index, len(points), value)
        self._sync_texts()
        self.studio.draft_changed()

    def chart_selected(self, kind: str, index: int) -> None:
        self.selected = (kind, index)
        self.point.value = self._selected_label()
        self._sync_point_slider()
        self.studio.redraw_chart()

    def _chart_toggled(self, event) -> None:
        self.studio.chart.set_visible(bool(event.target.value))
        if self.studio.view is not None:
            self.studio.frame()

    def close(self) -> None:
        for timer in self._typing_timers.values():
            timer.cancel()
