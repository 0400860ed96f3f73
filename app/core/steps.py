"""Derivation steps and the LaTeX conventions of the lab.

A step is what the viewer and the exercise walkthroughs show: a title, a formula in LaTeX, a
one-line explanation, and what to highlight in 3D.

>>> from app.core.expressions import symbol
>>> to_latex(symbol("ddq1") + symbol("dq2_r"))
'\\\\ddot{q}_{1} + \\\\dot{q}_{2r}'
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Dict, List, Optional

import sympy as sp


@dataclass
class Step:
    title: str
    latex: str
    text: str = ""
    highlight: Dict[str, List[str]] = field(default_factory=dict)   # {"bodies": [...], "joints": [...]}

    def as_dict(self) -> dict:
        return {"title": self.title, "latex": self.latex, "text": self.text, "highlight": self.highlight}


_NAME = re.compile(r"^(d{0,2})([A-Za-z]+?)_?(\d*)(_r)?$")
_GREEK = {"alpha", "beta", "gamma", "delta", "epsilon", "theta", "phi", "psi", "lambda", "mu", "nu",
          "rho", "sigma", "tau", "omega", "eta", "xi", "zeta", "kappa", "chi", "Delta", "Theta", "Phi",
          "Psi", "Lambda", "Omega", "Gamma", "Sigma", "pi"}


def symbol_latex(name: str, coordinates=()) -> str:
    """LaTeX of one symbol name: coordinates' time derivatives get dots, digits become subscripts.

    >>> symbol_latex("dtheta2", ["theta2"])
    '\\\\dot{\\\\theta}_{2}'
    >>> symbol_latex("I_c2x")
    'I_{c2x}'
    """
    for prefix, wrap in (("dd", r"\ddot{%s}"), ("d", r"\dot{%s}")):
        for suffix in ("_r", ""):
            if name.startswith(prefix) and name.endswith(suffix):
                core = name[len(prefix): len(name) - len(suffix)] if suffix else name[len(prefix):]
                if core in coordinates:
                    base, sub = _split(core)
                    sub = sub + ("r" if suffix else "")
                    body = wrap % base
                    return f"{body}_{{{sub}}}" if sub else body
    base, sub = _split(name)
    return f"{base}_{{{sub}}}" if sub else base


def _split(name: str):
    if "_" in name:
        head, tail = name.split("_", 1)
        return _greek(head), tail.replace("_", ",")
    m = re.match(r"^([A-Za-z]+?)(\d+\w*)$", name)
    if m:
        return _greek(m.group(1)), m.group(2)
    return _greek(name), ""


def _greek(word: str) -> str:
    return "\\" + word if word in _GREEK else word


_COORDS: List[str] = []


def set_coordinates(names) -> None:
    """Tell the printer which names are coordinates (their derivatives get dots)."""
    _COORDS[:] = list(names)


_INDEXED = re.compile(r"^([A-Za-z]+)(\d)$")
_SHORTHAND_LIKE = re.compile(r"^[cs]_?\d+$")


def shorthand_is_clear(parameter_names) -> bool:
    """Whether the exam shorthand c_1 = cos q1, s_12 = sin(q1 + q2) can be used: not when a
    parameter would print the same (a CoM distance called c1, say).

    >>> shorthand_is_clear(["m1", "d1"]), shorthand_is_clear(["m1", "c1"])
    (True, False)
    """
    return not any(_SHORTHAND_LIKE.match(name) for name in parameter_names)


def _short_trig(expr, coords):
    """Replace sin/cos of sums of coordinates q_i (single-digit indices, one common letter) by the
    exam shorthand s_{12}, c_{123}; returns (expr, {placeholder: latex})."""
    matches = [_INDEXED.match(c) for c in coords]
    if not coords or not all(matches) or len({m.group(1) for m in matches}) != 1:
        return expr, {}
    if not shorthand_is_clear(s.name for s in expr.free_symbols):
        return expr, {}   # a parameter such as c1 would print like the shorthand
    index = {sp.Symbol(c, real=True): m.group(2) for c, m in zip(coords, matches)}
    repl, names = {}, {}
    for f in expr.atoms(sp.sin, sp.cos):
        arg = sp.expand(f.args[0])
        digits = []
        for term in sp.Add.make_args(arg):
            if term in index:
                digits.append(index[term])
            else:
                digits = None
                break
        if not digits:
            continue
        label = ("s" if isinstance(f, sp.sin) else "c") + "_{" + "".join(sorted(digits)) + "}"
        ph = sp.Symbol("zz_trig_" + label)   # sorts after the parameters: m_2 d_2 c_{12}
        repl[f] = ph
        names[ph] = label
    return expr.xreplace(repl), names


def rounded(expr, digits: int = 5):
    """Floating-point numbers of an expression rounded for display: ``digits`` significant digits,
    round-off noise (below 1e-12) dropped, whole numbers as integers (exact numbers untouched).

    >>> rounded(sp.Float(0.666666666666667) * sp.Symbol("x") + sp.Float(6e-17) + sp.Float(1.0) * sp.Symbol("y"))  # exact: parsed constants
    0.66667*x + y
    """
    floats = expr.atoms(sp.Float) if isinstance(expr, sp.Basic) or isinstance(expr, sp.MatrixBase) else set()
    if not floats:
        return expr
    repl = {}
    for f in floats:
        value = float(f)
        if abs(value) < 1e-12:
            repl[f] = sp.Integer(0)
        elif abs(value - round(value)) < 1e-12 * max(1.0, abs(value)):
            repl[f] = sp.Integer(int(round(value)))
        else:
            repl[f] = sp.Float(float(f"{value:.{digits}g}"), digits)
    return expr.xreplace(repl)


#: sums longer than this are printed in sympy's stored order: sorting their terms took half of the
#: printing of a 6R arm with full inertia tensors (entries of 400 terms and more); no shipped
#: robot's formula comes near it, so what a student reads is unchanged
LONG_SUM = 40


def to_latex(expr, coordinates=None, short_trig: bool = True, **kwargs) -> str:
    """LaTeX of a sympy object using the lab's symbol conventions; sines and cosines of sums of
    coordinates are written s_{12}, c_{1} as in the exams (``short_trig=False`` keeps sin/cos).

    >>> from app.core.expressions import symbol
    >>> q1, q2 = symbol("q1"), symbol("q2")
    >>> to_latex(sp.cos(q1 + q2) * sp.sin(q1), ["q1", "q2"])
    'c_{12} s_{1}'
    """
    coords = list(coordinates) if coordinates is not None else list(_COORDS)
    expr = rounded(sp.sympify(expr))
    if isinstance(expr, sp.MatrixBase) and coords and not kwargs and expr.rows * expr.cols > 1:
        # entry by entry, each distinct entry printed once: the text sympy gives for the matrix
        rows = [" & ".join(_entry_latex(expr[r, c], tuple(coords), short_trig) for c in range(expr.cols))
                for r in range(expr.rows)]
        body = r"\\".join(rows)
        if expr.cols > 10:
            return r"\left(\begin{array}{" + "c" * expr.cols + "}" + body + r"\end{array}\right)"
        return r"\left(\begin{matrix}" + body + r"\end{matrix}\right)"
    trig_names = {}
    if short_trig:
        if isinstance(expr, sp.MatrixBase):
            pairs = [_short_trig(e, coords) for e in expr]
            for _, nm in pairs:
                trig_names.update(nm)
            expr = sp.Matrix(expr.rows, expr.cols, [e for e, _ in pairs])
        else:
            expr, trig_names = _short_trig(expr, coords)
    if not coords:   # guess the coordinates from the derivative symbols present
        coords = sorted({re.sub(r"_r$", "", s.name[2 if s.name.startswith("dd") else 1:])
                         for s in expr.free_symbols if s.name.startswith("d")})
    names = {s: symbol_latex(s.name, coords) for s in expr.free_symbols if isinstance(s, sp.Symbol)}
    names.update(trig_names)
    kwargs.setdefault("mat_delim", "(")
    if not isinstance(expr, sp.MatrixBase) and len(sp.Add.make_args(expr)) > LONG_SUM:
        kwargs.setdefault("order", "none")
    return sp.latex(expr, symbol_names=names, **kwargs)


_ENTRY_LATEX: Dict[tuple, str] = {}


def forget() -> None:
    """Empty the memory of printed entries (for cold benchmarks)."""
    _ENTRY_LATEX.clear()


def _entry_latex(entry, coords: tuple, short_trig: bool) -> str:
    key = (entry, coords, short_trig)
    text = _ENTRY_LATEX.get(key)
    if text is None:
        if len(_ENTRY_LATEX) > 50000:
            _ENTRY_LATEX.clear()
        text = _ENTRY_LATEX[key] = to_latex(entry, coords, short_trig)
    return text
