"""Presenter mode: one switch (Display folder) for projecting the page in a lecture hall.

On: the side panel takes half the window (``PANEL_VW``), every label, field and button of the
panel grows by ``SCALE`` (Mantine's ``--mantine-scale``), formulas by ``MATH_EM`` more, lines
drawn in 3D from then on are ``LINE_SCALE`` times thicker, the Model tab lays its formulas out
for the narrower width in em (``MATH_WIDTH_EM``, more line breaks, no sideways scrolling), and
the camera frames the robot in the part of the view the panel leaves free. Off: all back. It is per browser tab (session): the
style is a ``<style>`` element in this tab's panel, active only while its marker
``<span class="r2-presenter">`` is on the page (CSS ``:has``).
"""
from __future__ import annotations

PANEL_VW = 50          # width of the side panel, percent of the window
SCALE = 1.25           # labels, fields, buttons
MATH_EM = 1.45         # formulas, on top of SCALE's larger text
LINE_SCALE = 2.0       # thickness of 3D lines (trajectories, paths)
MATH_WIDTH_EM = 14.0   # formulas are laid out for this width (in em of the larger math font):
#                        (PANEL_VW % of 853 CSS px - 40 px of padding) / 26.8 px, a 1280 px screen at 150 %

CSS = (
    ":root:has(.r2-presenter){--mantine-scale:%(scale)s}"
    ".mantine-Paper-root:has(.r2-presenter){width:%(vw)svw!important;max-width:none!important;"
    "left:auto!important;right:0!important}"
    "body:has(.r2-presenter) .r2-math math{font-size:%(math)sem}"
    "body:has(.r2-presenter) .r2-label{font-size:1.15em}"
) % {"scale": SCALE, "vw": PANEL_VW, "math": MATH_EM}


def style_html(on: bool) -> str:
    """The HTML that switches the page's look (empty when off)."""
    return f'<span class="r2-presenter" hidden></span><style>{CSS}</style>' if on else ""


class Presenter:
    """``Presenter(session, order, on_switch)`` adds the (top-level) style holder; ``add_switch()``
    the checkbox (call it inside the Display folder); ``set(on)`` switches (tests, pictures) and
    then calls ``on_switch(on)`` (the session tells the panels: ``session.on_presenter_change``)."""

    def __init__(self, session, order: float, on_switch):
        self.session = session
        self.on = False
        self._style = session.gui.add_html("", order=order)
        self.switch = None
        self._on_switch = on_switch

    def math_width_em(self, normal: float) -> float:
        """The width to lay formulas out for: ``normal`` when off."""
        return MATH_WIDTH_EM if self.on else normal

    def add_switch(self):
        self.switch = self.session.gui.add_checkbox(
            "Presenter mode", False, hint="for a projector: wide panel, large math and labels, thick lines, "
                                          "the robot framed")
        self.switch.on_update(lambda event: event.client is not None and self.set(bool(event.target.value)))
        return self.switch

    def set(self, on: bool) -> None:
        on = bool(on)
        self.on = on
        scene = self.session.scene
        scene.set_line_scale(LINE_SCALE if on else 1.0)
        scene.panel_fraction = PANEL_VW / 100.0 if on else None
        self._style.content = style_html(on)
        if self.switch is not None and self.switch.value != on:
            self.switch.value = on
        self._on_switch(on)
        scene.frame_camera()
