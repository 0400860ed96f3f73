"""Layout of formulas for a given width: top-level ``,\\quad`` lists split into lines, long sums
broken at their + and - signs, matrices too wide for the width written entry by entry, a step's
formula wrapped at its top-level '=', '+' and '-' (``wrap_latex``). The page
(app/viewer/mathml.py, at the side panel's width) and the LaTeX output (app/core/tex.py, at a
printed page's width) lay formulas out the same way.

>>> matrix_latex_blocks("g", sp.Matrix([sp.Symbol("a"), 0]), [], "g", width_em=3)
['g_{1} = a']
"""
from __future__ import annotations

import re
from typing import List, Sequence

import sympy as sp

from .steps import to_latex

#: width of the formulas' box in the page's side panel, in em of the math font (about 16 px each)
PANEL_WIDTH_EM = 23.0


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


def _width(latex: str) -> float:
    return estimate_width_em(re.sub(r"\\(begin|end)\{[a-z]*\}", "", latex))


def _top_level_breaks(latex: str) -> List[tuple]:
    """(index, symbol) of the top-level '=', '+' and binary '-' of a formula (not inside braces,
    \\left...\\right or environments)."""
    out, depth, i, last = [], 0, 0, ""
    while i < len(latex):
        for word, change in ((r"\left", 1), (r"\right", -1), (r"\begin", 1), (r"\end", -1)):
            if latex.startswith(word, i) and not latex[i + len(word): i + len(word) + 1].isalpha():
                depth += change
                i += len(word)
                last = "x"
                break
        else:
            ch = latex[i]
            if ch == "\\":
                m = re.match(r"\\[A-Za-z]+|\\.", latex[i:])
                i += len(m.group(0))
                last = "x"
                continue
            if ch in "{([":
                depth += 1
            elif ch in "})]":
                depth -= 1
            elif depth == 0 and ch == ",":
                out.append((i, ch))
            elif depth == 0 and ch in "=+-" and (ch == "=" or last not in ("", "=", "+", "-", "(", ",", "&")):
                out.append((i, ch))
            if not ch.isspace():
                last = ch
            i += 1
    return out


def wrap_latex(latex: str, width_em: float = PANEL_WIDTH_EM) -> str:
    """A formula too wide for the side panel broken into lines at its top-level '=' (each starts a
    line) and '+'/'-' (filled greedily), as a two-column array; narrow formulas are unchanged.

    >>> wrap_latex("y = a + b")
    'y = a + b'
    >>> wrap_latex(r"T = 1.2165,\\ T_s = 0.3041,\\ V = 1.096,\\ A = 3.6037", 12)
    '\\\\begin{array}{l}T = 1.2165,\\\\\\\\T_s = 0.3041,\\\\\\\\V = 1.096,\\\\\\\\A = 3.6037\\\\end{array}'
    >>> wrap_latex("y = " + " + ".join(f"x_{{{k}}}" for k in range(30)), 20)[:36]
    '\\\\begin{array}{rl}y & = x_{0} + x_{1}'
    >>> wrap_latex("y = " + " + ".join(f"x_{{{k}}}" for k in range(30)), 20).count(r"\\quad + ") > 2
    True
    """
    if _width(latex) <= width_em:
        return latex
    breaks = _top_level_breaks(latex)
    commas = [i for i, ch in breaks if ch == ","]
    if commas:                 # a list (a = 1, b = 2, ...): items on lines, each wrapped if needed
        items = [latex[a:b].strip().lstrip(",").strip() for a, b in zip([0] + commas, commas + [len(latex)])]
        items = [re.sub(r"^(\\[ ,;:!]|\\q?quad)\s*", "", it) for it in items if it]
        lines, current = [], ""
        for it in items:
            if current and _width(current + r",\ " + it) > width_em:
                lines.append(current)
                current = it
            else:
                current = f"{current},\\ {it}" if current else it
        lines.append(current)
        if len(lines) == 1:
            return latex
        return r"\begin{array}{l}" + r"\\".join(wrap_latex(l + ("," if k < len(lines) - 1 else ""), width_em)
                                                 for k, l in enumerate(lines)) + r"\end{array}"
    breaks = [(i, ch) for i, ch in breaks if ch != ","]
    if not breaks:
        return latex
    pieces, start, sym = [], 0, ""
    for i, ch in breaks:
        pieces.append((sym, latex[start:i].strip()))
        start, sym = i + 1, ch
    pieces.append((sym, latex[start:].strip()))
    has_lhs = any(ch == "=" for _, ch in breaks)
    lhs = pieces.pop(0)[1] if has_lhs and pieces[1:] and pieces[1][0] == "=" else ""
    rows, current = [], ""
    for sym, text in pieces:
        piece = f"{sym} {text}".strip() if (sym != "=" or current or rows) else f"= {text}"
        if sym == "=" or (current and _width(current + " " + piece) > width_em - 3):
            if current:
                rows.append(current)
            current = piece
        else:
            current = f"{current} {piece}".strip()
    rows.append(current)
    if lhs:
        lines = [f"{lhs} & {rows[0]}"] + [(f"& {r}" if r.startswith("=") else rf"& \quad {r}") for r in rows[1:]]
        return r"\begin{array}{rl}" + r"\\".join(lines) + r"\end{array}"
    return r"\begin{array}{l}" + r"\\".join(rows) + r"\end{array}"
