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
