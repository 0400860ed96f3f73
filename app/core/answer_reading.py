"""Reading a student's answer in the course's notation into sympy (for app/core/answer_check.py):
implicit products, primes, Greek and Unicode, the c12/s12 shorthands, vectors and matrices, all
through the lab's whitelist parser (never ``eval``).

>>> from app.core.robot import load_robot
>>> list(Reader(load_robot("planar_2r")).value("[2 m2 l1 d2 c2, q2'']"))
[2*d2*l1*m2*cos(q2), ddq2]
"""

from __future__ import annotations

import re
from typing import Dict, List, Sequence, Tuple

import sympy as sp

from .errors import UserError
from .expressions import ExpressionError, parse_expression, symbol
from .steps import shorthand_is_clear


class AnswerError(UserError):
    """The answer cannot be read, or the entry does not exist (exit code 2 on the command line)."""



_UNICODE = {"²": "**2", "³": "**3", "·": "*", "×": "*", "−": "-", "–": "-", "’": "'", "′": "'", "″": "''",
            "π": "pi", "θ": "theta", "α": "alpha", "β": "beta", "γ": "gamma", "δ": "delta", "λ": "lambda",
            "μ": "mu", "ρ": "rho", "σ": "sigma", "τ": "tau", "φ": "phi", "ψ": "psi", "ω": "omega",
            "Ω": "Omega", "Λ": "Lambda", "Γ": "Gamma", "Δ": "Delta", "η": "eta", "ξ": "xi", "ζ": "zeta",
            "κ": "kappa", "ν": "nu", "χ": "chi", "ε": "epsilon"}
_FUNCTIONS = {"sin", "cos", "tan", "atan2", "atan", "asin", "acos", "sqrt", "exp", "log", "abs", "Abs", "sign"}
_TOKEN = re.compile(r"\s*(?:(\d+\.\d*|\.\d+|\d+)|([A-Za-z_][A-Za-z0-9_]*)('*)|(\*\*|[-+*/^(),]))")


def _rewrite(text: str, known: Sequence[str]) -> str:
    """Course notation -> the whitelist parser's syntax: primes to dq/ddq, implicit products made
    explicit, ``sin q2`` to ``sin(q2)``, glued names (``m2l1``) split into known ones."""
    for a, b in _UNICODE.items():
        text = text.replace(a, b)
    text = text.replace("^", "**")
    tokens: List[Tuple[str, str]] = []
    pos = 0
    while pos < len(text):
        m = _TOKEN.match(text, pos)
        if not m or m.end() == pos:
            if text[pos:].strip() == "":
                break
            raise AnswerError(f"cannot read {text!r} at '{text[pos:pos + 10].strip()}'")
        pos = m.end()
        number, name, primes, op = m.groups()
        if number is not None:
            tokens.append(("num", number))
        elif name is not None:
            if primes:
                name = ("dd" if len(primes) >= 2 else "d") + name
            for part in _split_glued(name, known):
                tokens.append(("name", part))
        else:
            tokens.append(("op", op))
    out: List[str] = []
    i = 0
    while i < len(tokens):
        kind, value = tokens[i]
        prev = tokens[i - 1] if i else None
        if prev is not None and kind in ("num", "name") or (kind == "op" and value == "("):
            if prev is not None and (prev[0] in ("num", "name") and not (prev[0] == "name" and prev[1] in _FUNCTIONS
                                                                          and value == "(")
                                     or prev == ("op", ")")):
                out.append("*")
        if kind == "name" and value in _FUNCTIONS and i + 1 < len(tokens) and tokens[i + 1][0] in ("name", "num"):
            out.append(f"{value}({tokens[i + 1][1]})")     # sin q2 -> sin(q2)
            i += 2
            continue
        out.append(value)
        i += 1
    return " ".join(out)


def _split_glued(name: str, known: Sequence[str]) -> List[str]:
    """``m2l1`` -> ``[m2, l1]`` when the whole is unknown but splits into known names."""
    if name in known or name in _FUNCTIONS or name in ("pi", "E"):
        return [name]
    best: Dict[int, List[str]] = {0: []}
    for end in range(1, len(name) + 1):
        for start in range(end):
            if start in best and name[start:end] in known:
                cand = best[start] + [name[start:end]]
                if end not in best or len(cand) < len(best[end]):
                    best[end] = cand
    return best.get(len(name), [name])


def split_top(text: str, seps: str) -> List[str]:
    parts, depth, cur = [], 0, ""
    for ch in text:
        if ch in "([":
            depth += 1
        elif ch in ")]":
            depth -= 1
        if depth == 0 and ch in seps:
            parts.append(cur)
            cur = ""
        else:
            cur += ch
    parts.append(cur)
    return [p.strip() for p in parts]


class Reader:
    """Reads answers for one robot (and extra names of an exercise) into sympy."""

    def __init__(self, robot, extra_names: Sequence[str] = ()):
        self.robot = robot
        coords = list(robot.coordinates)
        names = set(robot.parameters) | set(coords) | {"d" + c for c in coords} | {"dd" + c for c in coords}
        names |= {"d" + c + "_r" for c in coords} | {"dd" + c + "_r" for c in coords} | {"t"}
        names |= set(extra_names)
        self.extra = _shorthands(coords, names)
        self.known = sorted(names | set(self.extra))
        self.names = names

    def scalar(self, text: str) -> sp.Expr:
        source = _rewrite(text, self.known)
        try:
            expr = parse_expression(source, allowed_names=self.names, extra=self.extra)
        except ExpressionError as exc:
            raise AnswerError(f"cannot read the answer {text!r}: {str(exc).split(' in ')[0]}") from None
        return expr

    def value(self, text: str):
        """A scalar, a vector ``[a, b]`` or a matrix ``[[a, b], [c, d]]`` / ``[a, b; c, d]``."""
        text = str(text).strip()
        if not text:
            raise AnswerError("empty answer")
        if text.startswith("[") and text.endswith("]"):
            inner = text[1:-1].strip()
            if ";" in inner and "[" not in inner:
                rows = [[self.scalar(x) for x in split_top(r, ",")] for r in split_top(inner, ";")]
                if len({len(r) for r in rows}) != 1:
                    raise AnswerError(f"the rows of {text!r} have different lengths")
                return sp.Matrix(rows)
            items = split_top(inner, ",")
            if all(i.startswith("[") for i in items):
                rows = [self.value(i) for i in items]
                if any(not isinstance(r, sp.MatrixBase) or r.cols != 1 for r in rows) or len({r.rows for r in rows}) != 1:
                    raise AnswerError(f"the rows of {text!r} have different lengths")
                return sp.Matrix([list(r) for r in rows])
            return sp.Matrix([self.scalar(i) for i in items])
        return self.scalar(text)


def _shorthands(coords: Sequence[str], names) -> Dict[str, sp.Expr]:
    """c1 = cos q1, s12 = sin(q1 + q2), c23 ... for coordinates named letter+digit, when no
    parameter is called like that."""
    matches = [re.fullmatch(r"([A-Za-z]+)(\d)", c) for c in coords]
    if not coords or not all(matches) or len({m.group(1) for m in matches}) != 1:
        return {}
    if not shorthand_is_clear(names):
        return {}
    digits = [m.group(2) for m in matches]
    out: Dict[str, sp.Expr] = {}
    from itertools import combinations
    for k in range(1, len(coords) + 1):
        for combo in combinations(range(len(coords)), k):
            arg = sp.Add(*[symbol(coords[i]) for i in combo])
            key = "".join(digits[i] for i in combo)
            out["c" + key] = sp.cos(arg)
            out["s" + key] = sp.sin(arg)
    return out
