"""LaTeX of numeric vectors and matrices, as printed in the exam solutions (4 decimals).

>>> vec([1, -0.5, 2/3])
'\\\\begin{pmatrix} 1 \\\\\\\\ -0.5 \\\\\\\\ 0.6667 \\\\end{pmatrix}'
>>> num(1e-17)
'0'
"""
from __future__ import annotations

import math

import numpy as np


def num(x: float, digits: int = 4) -> str:
    """A number with at most ``digits`` decimals, trailing zeros removed; inf as \\infty."""
    x = float(x)
    if math.isinf(x):
        return r"\infty" if x > 0 else r"-\infty"
    if math.isnan(x):
        return r"\mathrm{NaN}"
    text = f"{x:.{digits}f}".rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text


def mat(M, digits: int = 4) -> str:
    M = np.atleast_2d(np.asarray(M, dtype=float))
    rows = [" & ".join(num(v, digits) for v in row) for row in M]
    return r"\begin{pmatrix} " + r" \\ ".join(rows) + r" \end{pmatrix}"


def vec(v, digits: int = 4) -> str:
    v = np.asarray(v, dtype=float).reshape(-1)
    return r"\begin{pmatrix} " + r" \\ ".join(num(x, digits) for x in v) + r" \end{pmatrix}"


def sig(x: float, digits: int = 4) -> str:
    """A number with ``digits`` significant digits; powers of ten as ``10^{k}``, never ``1e-09``.

    >>> sig(1e-9), sig(0.0000123456), sig(2.6180339887)
    ('10^{-9}', '1.235 \\\\cdot 10^{-5}', '2.618')
    """
    x = float(x)
    if not math.isfinite(x) or x == 0:
        return num(x)
    text = f"{x:.{digits}g}"
    if "e" not in text:
        return text
    mant, exp = text.split("e")
    return f"10^{{{int(exp)}}}" if mant == "1" else rf"{mant} \cdot 10^{{{int(exp)}}}"
