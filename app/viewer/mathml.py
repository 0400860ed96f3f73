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
from typing import Iterable, List, Sequence

import numpy as np
import sympy as sp
from latex2mathml.converter import convert

from app.core.steps import to_latex

FONT_PATH = Path(__file__).resolve().parents[2] / "static" / "fonts" / "STIXTwoMath-Regular.ttf"

#: width of the formulas' box in the side panel, in em of the math font (about 16 px each)
PANEL_WIDTH_EM = 23.0


@functools.lru_cache(maxsize=1)
def font_style() -> str:
    """A ``<style>`` element declaring the math font (as a data URL) and the formula CSS.

    Added once per page (a session does it when a browser tab connects); every formula from
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


def split_top_level(latex: str, separator: str = r",\quad") -> List[str]:
    """Split a formula at top-level separators (not inside braces or environments).

    >>> split_top_level(r"a = \\left(\\begin{matrix}1,\\quad 2\\end{matrix}\\right),\\quad b = 3")
    ['a = \\\\left(\\\\begin{matrix}1,\\\\quad 2\\\\end{matrix}\\\\right)', 'b = 3']
    """
    parts, depth, start, i = [], 0, 0, 0
    while i < len(latex):
        if latex.startswith(r"\begin", i) or latex[i] == "{":
            depth += 1
        elif latex.startswith(r"\end", i) or latex[i] == "}":
            depth -= 1
        if depth == 0 and latex.startswith(separator, i):
            parts.append(latex[start:i].strip())
            i += len(separator)
            start = i
            continue
        i += 1
    parts.append(latex[start:].strip())
    return [p for p in parts if p]


_COMMAND_WIDTH = {r"\left": 0, r"\right": 0, r"\quad": 1, r"\qquad": 2, r"\frac": 0, r"\dot": 0,
                  r"\ddot": 0, r"\partial": 0.6, r"\cdot": 0.5}


def estimate_width_em(latex: str) -> float:
    """Rough rendered width of a one-line formula in em (fractions count their wider part)."""
    def width(s: str) -> float:
        total, i = 0.0, 0
        while i < len(s):
            ch = s[i]
            if s.startswith(r"\frac", i):
                i += 5
                num, i = _group(s, i)
                den, i = _group(s, i)
                total += max(width(num), width(den)) * 0.8 + 0.3
                continue
            if ch == "\\":
                m = re.match(r"\\[A-Za-z]+", s[i:])
                if m:
                    cmd = m.group(0)
                    total += _COMMAND_WIDTH.get(cmd, 0.55 * (len(cmd) - 1) if cmd in
                                                (r"\cos", r"\sin", r"\tan", r"\log", r"\exp") else 0.6)
                    i += len(cmd)
                    continue
                i += 2
                total += 0.3
                continue
            if ch in "{}":
                i += 1
                continue
            if ch in "_^":
                grp, i = _group(s, i + 1)
                total += 0.7 * width(grp)
                continue
            if ch in "+-=<>":
                total += 1.1
            elif ch in "()[],":
                total += 0.4
            elif ch == " ":
                pass
            else:
                total += 0.55
            i += 1
        return total
    return 1.3 * width(latex)    # calibrated on rendered model entries (STIX Two Math, Chromium)


def _group(s: str, i: int):
    """The braced group (or single character) starting at s[i], and the index after it."""
    while i < len(s) and s[i] == " ":
        i += 1
    if i >= len(s):
        return "", i
    if s[i] != "{":
        if s[i] == "\\":
            m = re.match(r"\\[A-Za-z]+", s[i:])
            if m:
                return m.group(0), i + len(m.group(0))
        return s[i], i + 1
    depth = 0
    for j in range(i, len(s)):
        if s[j] == "{":
            depth += 1
        elif s[j] == "}":
            depth -= 1
            if depth == 0:
                return s[i + 1:j], j + 1
    return s[i + 1:], len(s)


def sum_lines(lhs: str, expr, coordinates: Sequence[str], width_em: float = PANEL_WIDTH_EM,
              short_trig: bool = True) -> str:
    """LaTeX of ``lhs = expr`` broken over several lines at top-level + and - signs when too wide.

    >>> q1, a, b = sp.symbols("q1 a b")
    >>> sum_lines("x", a + b, ["q1"])
    'x = a + b'
    """
    full = f"{lhs} = {to_latex(expr, coordinates, short_trig=short_trig)}"
    expr = sp.sympify(expr)
    if estimate_width_em(full) <= width_em or not isinstance(expr, sp.Add):
        return full
    terms: List[sp.Expr] = []
    for term in sp.Add.make_args(expr):     # keep the compact terms; expand only one too wide
        wide = estimate_width_em(to_latex(term, coordinates, short_trig=short_trig)) > width_em - 2
        terms.extend(sp.Add.make_args(sp.expand(term)) if wide else [term])
    lines = _break_sum(terms, coordinates, width_em, short_trig)
    rows = [f"{lhs} & = {lines[0]}"] + [rf"& \quad {line}" for line in lines[1:]]
    return r"\begin{array}{rl}" + r"\\".join(rows) + r"\end{array}"


def _break_sum(terms, coordinates, width_em, short_trig) -> List[str]:
    terms = [to_latex(t, coordinates, short_trig=short_trig) for t in terms]
    lines: List[str] = []
    current = ""
    for k, term in enumerate(terms):
        piece = term if k == 0 else (term if term.startswith("-") else "+ " + term)
        if current and estimate_width_em(current + piece) > width_em - 2:
            lines.append(current)
            current = piece
        else:
            current = f"{current} {piece}".strip()
    lines.append(current)
    return lines


def matrix_latex_blocks(name: str, matrix: sp.Matrix, coordinates: Sequence[str], entry_name: str,
                        width_em: float = PANEL_WIDTH_EM, symmetric: bool = False,
                        short_trig: bool = True) -> List[str]:
    """LaTeX blocks showing ``name = matrix``: one block if it fits the width, otherwise one block
    per (non-zero) entry ``entry_name_{ij} = ...`` (upper triangle when symmetric), long entries
    broken over lines. A ``#`` in ``entry_name`` marks where the index goes (``c_{1,#}``).

    >>> m = sp.Matrix([[sp.Symbol("a"), 0], [0, sp.Symbol("b")]])
    >>> matrix_latex_blocks("M", m, [], "m")
    ['M = \\\\left(\\\\begin{matrix}a & 0\\\\\\\\0 & b\\\\end{matrix}\\\\right)']
    """
    full = f"{name} = {to_latex(matrix, coordinates, short_trig=short_trig)}"
    if _matrix_width(matrix, coordinates, short_trig) <= width_em:
        return [full]
    rows, cols = matrix.shape
    blocks = []
    for i in range(rows):
        for j in range(cols):
            if symmetric and j < i:
                continue
            if matrix[i, j] == 0:
                continue
            index = f"{i + 1}{j + 1}" if cols > 1 and rows > 1 else f"{(i if cols == 1 else j) + 1}"
            label = entry_name.replace("#", index) if "#" in entry_name else f"{entry_name}_{{{index}}}"
            blocks.append(sum_lines(label, matrix[i, j], coordinates, width_em, short_trig))
    if not blocks:
        return [f"{name} = 0"]
    return blocks


def _matrix_width(matrix: sp.Matrix, coordinates: Sequence[str], short_trig: bool = True) -> float:
    rows, cols = matrix.shape
    widths = [[estimate_width_em(to_latex(matrix[i, j], coordinates, short_trig=short_trig)) for j in range(cols)]
              for i in range(rows)]
    col_w = [max(widths[i][j] for i in range(rows)) for j in range(cols)]
    return sum(col_w) + 1.2 * cols + 4


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
