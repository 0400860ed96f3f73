"""Typeset math for the page: LaTeX -> MathML (latex2mathml), laid out for a narrow side panel.

Chromium renders MathML natively; with a math font (STIX Two Math, served once per page as an
``@font-face`` data URL by :func:`font_style`) brackets stretch and fractions look right. Wide
formulas are laid out on purpose: top-level ``,\\quad`` lists become one line each, long sums are
broken into several lines, and matrices that do not fit are shown entry by entry.

>>> html = math_html(r"\\frac{a}{b}")
>>> "<mfrac>" in html and html.startswith('<div class="r2-math"')
True
>>> estimate_width_em(r"\\dot{q}_{1} \\cos{\\left(q_{1} \\right)}") < 7
True
"""
from __future__ import annotations

import base64
import functools
import re
from pathlib import Path
from typing import Iterable

import numpy as np
from latex2mathml.converter import convert

from app.core.formula_layout import (  # noqa: F401  (the page's layout of formulas, shared with the LaTeX output)
    PANEL_WIDTH_EM, estimate_width_em, matrix_latex_blocks, split_top_level, sum_lines)

FONT_PATH = Path(__file__).resolve().parents[2] / "static" / "fonts" / "STIXTwoMath-Regular.ttf"


@functools.lru_cache(maxsize=1)
def font_style() -> str:
    """A ``<style>`` element declaring the math font (as a data URL) and the formula CSS.

    Added once per page (a session does it with the tab's first robot, after the robot's drawing:
    2 MB that need not delay the first frame); every formula from
    :func:`math_html` then uses it."""
    data = base64.b64encode(FONT_PATH.read_bytes()).decode("ascii")
    return ("<style>"
            "@font-face{font-family:'STIX Two Math';"
            f"src:url(data:font/ttf;base64,{data}) format('truetype');font-display:block}}"
            ".r2-math{overflow-x:auto;overflow-y:hidden;max-width:100%;padding:2px 0}"
            ".r2-math math{font-family:'STIX Two Math',math;font-size:1.05em}"
            "math{font-family:'STIX Two Math',math}"
            ".r2-math math[display=block]{margin:0.2em 0}"
            ".r2-math mtd[columnalign=left]{text-align:left}"
            ".r2-math mtd[columnalign=right]{text-align:right}"
            ".r2-label{font-size:0.85em;color:#555;margin-top:0.4em}"
            ".r2-num math{color:#1d4f91}"
            "</style>")


def _fix_latex(latex: str) -> str:
    """Rewrite constructs latex2mathml renders badly (``aligned`` becomes a two-column array)."""
    latex = re.sub(r"\\begin\{aligned\}", r"\\begin{array}{rl}", latex)
    return re.sub(r"\\end\{aligned\}", r"\\end{array}", latex)


#: a dotted single letter (q-dot, theta-ddot) becomes one letter with a combining dot: its height
#: stays that of the letter, so an exponent (q-dot squared) sits where it sits on q
_COMBINING = {"&#x002D9;": "&#x00307;", "&#x000A8;": "&#x00308;"}
_DOTTED_LETTER = re.compile(r"<mover><mrow><mi>([^<&]|&#x[0-9A-Fa-f]+;)</mi></mrow><mo>(&#x002D9;|&#x000A8;)</mo></mover>")
def _math_italic(char: str) -> str:
    """The mathematical italic code point of a letter (as an entity), so that a letter with a
    combining dot stays italic (a two-character ``<mi>`` is set upright)."""
    c = html_unescape(char)
    if len(c) != 1:
        return char
    o = ord(c)
    if "a" <= c <= "z":
        cp = 0x210E if c == "h" else 0x1D44E + o - ord("a")
    elif "A" <= c <= "Z":
        cp = 0x1D434 + o - ord("A")
    elif 0x3B1 <= o <= 0x3C9:
        cp = 0x1D6FC + o - 0x3B1
    else:
        return char
    return f"&#x{cp:05X};"


def html_unescape(text: str) -> str:
    import html
    return html.unescape(text)


_ACCENT_MOVER = re.compile(r"<mover>((?:(?!</?mover).)*?)<mo>(&#x002D9;|&#x000A8;|&#x0005E;|&#x0007E;|&#x000AF;|&#x02192;)</mo></mover>")


@functools.lru_cache(maxsize=4096)
def latex_to_mathml(latex: str, display: bool = True) -> str:
    """MathML markup of a LaTeX formula (cached). Dots, hats and bars are marked as accents
    (``<mover accent="true">``), so that q̇₂² keeps its dot close to the q and its exponent
    beside it instead of above a tall over-script.

    >>> "<mi>&#x1D45E;&#x00307;</mi>" in latex_to_mathml(r"\\dot{q}_{2}^{2}")
    True
    """
    markup = convert(_fix_latex(latex), display="block" if display else "inline")
    markup = _DOTTED_LETTER.sub(lambda m: f"<mi>{_math_italic(m.group(1))}{_COMBINING[m.group(2)]}</mi>", markup)
    return _ACCENT_MOVER.sub(r'<mover accent="true">\1<mo stretchy="false">\2</mo></mover>', markup)


def math_html(latex: str, display: bool = True, css_class: str = "") -> str:
    """HTML for ``gui.add_html``: the formula in a box that scrolls sideways if still too wide."""
    cls = "r2-math" + (f" {css_class}" if css_class else "")
    return f'<div class="{cls}">{latex_to_mathml(latex, display)}</div>'


def number_latex(x: float, digits: int = 4) -> str:
    """A number for display: ``digits`` significant digits, no exponent noise.

    >>> number_latex(0.000012345), number_latex(-3.0), number_latex(1234567.0)
    ('1.234 \\\\cdot 10^{-5}', '-3', '1.235 \\\\cdot 10^{6}')
    """
    if not np.isfinite(x):
        return r"\text{nan}"
    if abs(x) < 1e-12:
        return "0"
    text = f"{x:.{digits}g}"
    if "e" in text:
        mant, exp = text.split("e")
        return rf"{mant} \cdot 10^{{{int(exp)}}}"
    return text


def numeric_latex(value, digits: int = 4) -> str:
    """LaTeX of a numeric scalar, vector (as a column) or matrix.

    >>> numeric_latex([[1.0, 0.5], [0.5, 2.0]])
    '\\\\left(\\\\begin{matrix}1 & 0.5\\\\\\\\0.5 & 2\\\\end{matrix}\\\\right)'
    """
    arr = np.atleast_1d(np.asarray(value, dtype=float))
    if arr.ndim == 1:
        arr = arr.reshape(-1, 1)
    body = r"\\".join(" & ".join(number_latex(float(v), digits) for v in row) for row in arr)
    return r"\left(\begin{matrix}" + body + r"\end{matrix}\right)"


def text_html(text: str) -> str:
    """A sentence of the lab's text convention (app/core/mathtext.py) as HTML: plain parts
    escaped, ``$...$`` segments typeset as inline MathML.

    >>> text_html("Collect $T = \\frac{1}{2}$ & more")[:40]
    'Collect <math xmlns="http://www.w3.org/1'
    """
    import html
    from app.core.mathtext import split_math
    return "".join(latex_to_mathml(piece, False) if is_math else html.escape(piece)
                   for is_math, piece in split_math(text))


def label_html(text: str) -> str:
    """A small caption above a formula (HTML-escaped)."""
    import html
    return f'<div class="r2-label">{html.escape(text)}</div>'


def blocks_html(blocks: Iterable[str]) -> str:
    return "".join(math_html(b) for b in blocks)
