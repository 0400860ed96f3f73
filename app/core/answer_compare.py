"""Comparing a student's answer with the engine's (for app/core/answer_check.py): exact
equivalence through the canonical trigonometric form, the findings about a wrong expression
(``Diagnosis``: units, missing or extra terms, sign, factor, sin for cos, dependence) and numbers
right up to the digits typed.

>>> numbers_match("0.333", 0.333, 1 / 3)
(True, '')
"""

from __future__ import annotations

import math
import random
import re
from dataclasses import dataclass, field
from typing import Any, Dict, List, Optional, Sequence, Tuple

import sympy as sp

from .answer_units import Dimensions, unit_text
from .expressions import symbol
from .numeric import numeric_function
from .steps import to_latex
from .trig import TrigPoly


@dataclass
class Finding:
    """One thing found about a wrong answer; ``message`` uses the $...$ text convention."""
    kind: str          # units, missing_term, extra_term, sign, factor, coefficient, sin_cos, dependence,
    #                    function, value, digits, shape, factorization, skew, span, count
    message: str
    data: Dict[str, Any] = field(default_factory=dict)

    def as_dict(self) -> dict:
        return {"kind": self.kind, "message": self.message, **self.data}


def real_symbols(expr):
    return sp.sympify(expr).xreplace({s: symbol(s.name) for s in sp.sympify(expr).free_symbols
                                      if isinstance(s, sp.Symbol) and not s.is_real})


def equivalent(a, b, points: int = 8) -> bool:
    """Exact equality through the canonical trigonometric form; expressions outside it (fractions,
    square roots) compared at random points (relative 1e-9)."""
    d = sp.expand(real_symbols(a) - real_symbols(b))
    if d == 0:
        return True
    try:
        if TrigPoly.from_expr(d).is_zero():
            return True
    except Exception:   # pragma: no cover - exotic expressions: fall back to numbers
        pass
    free = sorted(d.free_symbols | real_symbols(a).free_symbols | real_symbols(b).free_symbols, key=lambda s: s.name)
    if not d.free_symbols:
        return abs(complex(d.evalf())) < 1e-9 * max(1.0, abs(complex(real_symbols(a).evalf())))
    if not (d.has(sp.Pow) and any(p.exp.is_negative or not p.exp.is_integer for p in d.atoms(sp.Pow))) \
            and not d.has(sp.Abs, sp.sqrt, sp.atan2, sp.asin, sp.acos, sp.atan, sp.exp, sp.log):
        return False     # a trigonometric polynomial whose canonical form is not zero
    f = numeric_function(free, d, "math")
    scale = numeric_function(free, sp.Abs(real_symbols(a)) + sp.Abs(real_symbols(b)) + 1, "math")
    rng = random.Random(11)
    tried = 0
    for _ in range(points * 3):
        vals = [rng.uniform(0.3, 1.7) for _ in free]
        try:
            v, s = f(*vals), scale(*vals)
        except (ZeroDivisionError, ValueError, OverflowError):
            continue
        tried += 1
        if abs(v) > 1e-9 * s:
            return False
        if tried >= points:
            break
    return tried > 0


def _groups(expr, trig_symbols) -> Dict[sp.Expr, TrigPoly]:
    """expr = sum over monomials p (in everything but the angles) of p * f_p(q): {p: f_p}."""
    out: Dict[sp.Expr, TrigPoly] = {}
    tp = TrigPoly.from_expr(sp.expand(real_symbols(expr)))
    for key, coeff in tp.items():
        basis = TrigPoly({key: sp.Integer(1)})
        for term in sp.Add.make_args(sp.expand(coeff)):
            number, mono = term.as_coeff_Mul()
            mono_angles = [s for s in mono.free_symbols if s in trig_symbols]
            if mono_angles:    # a bare angle (q1 * cos q2): keep it with the function of q
                rest = mono
                angle_part = sp.Mul(*[f for f in sp.Mul.make_args(mono) if f.free_symbols & set(trig_symbols)])
                mono = sp.Mul(*[f for f in sp.Mul.make_args(rest) if not f.free_symbols & set(trig_symbols)])
                basis_term = TrigPoly.from_expr(angle_part * TrigPoly.basis_function(key))
            else:
                basis_term = basis
            out[mono] = out.get(mono, TrigPoly()) + basis_term.scale(number)
    return {m: f for m, f in out.items() if not f.is_zero()}


def _swap_sin_cos(tp: TrigPoly) -> TrigPoly:
    terms = {}
    for (freq, kind), c in tp.items():
        if freq:
            terms[(freq, "s" if kind == "c" else "c")] = c
        else:
            terms[(freq, kind)] = c
    return TrigPoly(terms)


def _ratio(a: TrigPoly, b: TrigPoly) -> Optional[sp.Expr]:
    """c with a = c * b for a constant c, else None."""
    if set(k for k, _ in a.items()) != set(k for k, _ in b.items()):
        return None
    ratios = {sp.nsimplify(sp.simplify(ca / b.terms[k])) for k, ca in a.items()}
    if len(ratios) == 1:
        r = ratios.pop()
        return r if r.is_number else None
    return None


def _angles_of(tp: TrigPoly) -> set:
    return {s for (freq, _), _ in tp.items() for s, _ in freq}


class Diagnosis:
    """Findings about a wrong symbolic answer (scalar), naming terms by their parameters only."""

    def __init__(self, robot, dims: Optional[Dimensions], coords: Sequence[str]):
        self.robot, self.dims, self.coords = robot, dims, list(coords)
        self.angles = [symbol(c) for c in coords]

    def L(self, expr) -> str:
        return to_latex(expr, self.coords)

    def findings(self, entry_tex: str, expected, answer) -> List[Finding]:
        out: List[Finding] = []
        out += self._units(entry_tex, expected, answer)
        out += self._dependence(entry_tex, expected, answer)
        try:
            out += self._terms(entry_tex, expected, answer)
        except Exception:   # pragma: no cover - forms outside the canonical one: the sample still speaks
            pass
        return out

    def _units(self, entry_tex, expected, answer) -> List[Finding]:
        if self.dims is None:
            return []
        terms_e = sp.Add.make_args(sp.expand(expected))
        dims_e = {self.dims.of(t) for t in terms_e}
        if len(dims_e) != 1 or None in dims_e:
            return []
        want = dims_e.pop()
        out = []
        for term in sp.Add.make_args(sp.expand(answer)):
            d = self.dims.of(term)
            if d is not None and any(abs(a - b) > 1e-9 for a, b in zip(d, want)):
                out.append(Finding("units", f"unit mismatch: your term ${self.L(term)}$ is in ${unit_text(d)}$, "
                                            f"but ${entry_tex}$ is in ${unit_text(want)}$",
                                   {"term": self.L(term), "unit": unit_text(d), "expected_unit": unit_text(want)}))
        return out[:3]

    def _dependence(self, entry_tex, expected, answer) -> List[Finding]:
        watched = set(self.angles) | {symbol("d" + c) for c in self.coords} | {symbol("dd" + c) for c in self.coords}
        fe, fa = expected.free_symbols & watched, answer.free_symbols & watched
        out = []
        for s in sorted(fa - fe, key=lambda s: s.name):
            out.append(Finding("dependence", f"your answer depends on ${self.L(s)}$, but ${entry_tex}$ does not",
                               {"symbol": s.name, "expected": False}))
        for s in sorted(fe - fa, key=lambda s: s.name):
            out.append(Finding("dependence", f"${entry_tex}$ depends on ${self.L(s)}$, your answer does not",
                               {"symbol": s.name, "expected": True}))
        return out

    def _terms(self, entry_tex, expected, answer) -> List[Finding]:
        ge, ga = _groups(expected, self.angles), _groups(answer, self.angles)
        out: List[Finding] = []
        missing = [m for m in ge if m not in ga]
        extra = [m for m in ga if m not in ge]
        for m in ge:
            if m not in ga:
                continue
            fe, fa = ge[m], ga[m]
            if fe == fa:
                continue
            where = self._term_name(m)
            r = _ratio(fa, fe)
            if r is not None:
                if r == -1:
                    out.append(Finding("sign", f"the sign of the term {where} is wrong", {"term": self.L(m)}))
                elif r in (2, sp.Rational(1, 2)):
                    out.append(Finding("factor", f"the term {where} is off by a factor {'2' if r == 2 else '1/2'}",
                                       {"term": self.L(m), "ratio": str(r)}))
                else:
                    out.append(Finding("coefficient", f"the numeric coefficient of the term {where} is wrong",
                                       {"term": self.L(m)}))
                continue
            swapped = _ratio(_swap_sin_cos(fa), fe)
            if swapped is not None:
                extra_text = "" if abs(swapped) == 1 else ", and its numeric coefficient is wrong too"
                out.append(Finding("sin_cos", f"in the term {where} a sine stands where a cosine belongs "
                                              f"(or the other way round){extra_text}", {"term": self.L(m)}))
                continue
            ae, aa = _angles_of(fe), _angles_of(fa)
            if ae != aa:
                miss = ", ".join(f"${self.L(s)}$" for s in sorted(ae - aa, key=lambda s: s.name))
                more = ", ".join(f"${self.L(s)}$" for s in sorted(aa - ae, key=lambda s: s.name))
                text = f"the function of the angles in the term {where} is wrong"
                text += (f": it should depend on {miss}" if miss else "") + (f"; it should not depend on {more}" if more else "")
                out.append(Finding("function", text, {"term": self.L(m)}))
            else:
                out.append(Finding("function", f"the function of the angles in the term {where} is wrong "
                                               "(check the trigonometric factor)", {"term": self.L(m)}))
        for m in missing:
            hint = _steiner_hint(m, self.robot)
            out.append(Finding("missing_term", f"a term {self._term_name(m)} is missing{hint}", {"term": self.L(m)}))
        for m in extra:
            out.append(Finding("extra_term", f"the term {self._term_name(m)} should not be there", {"term": self.L(m)}))
        return out

    def _term_name(self, mono) -> str:
        if mono == 1:
            return "without parameters (a pure number or function of the angles)"
        return f"in ${self.L(mono)}$"


def _steiner_hint(mono, robot) -> str:
    """' (a Steiner term: mass times a squared distance?)' when the monomial looks like one."""
    powers = sp.Mul.make_args(mono)
    masses = [f for f in powers if f.is_Symbol and robot.parameters.get(f.name) and robot.parameters[f.name].kind == "mass"]
    squares = [f for f in powers if f.is_Pow and f.exp == 2 and robot.parameters.get(f.base.name if f.base.is_Symbol else "")
               and robot.parameters[f.base.name].kind in ("length", "com")]
    if len(masses) == 1 and squares and len(powers) == 2:
        return " (a parallel-axis, Steiner, term: mass times a squared distance)"
    return ""


# ====================================================================== numbers
def typed_digits(text: str) -> Tuple[int, int]:
    """(decimals, significant digits) typed in a plain number."""
    m = re.fullmatch(r"\s*[-+]?(\d*)(?:\.(\d*))?(?:[eE][-+]?\d+)?\s*", text)
    if not m:
        return (-1, 0)
    whole, frac = m.group(1) or "", m.group(2) or ""
    sig = len((whole + frac).lstrip("0")) if (whole + frac).strip("0") else 1
    return (len(frac), sig)


def numbers_match(text: str, typed: float, value: float) -> Tuple[bool, str]:
    """Whether a typed number equals ``value`` up to the digits typed (half a unit of the last
    decimal), with at least 3 significant digits unless it is exact; (ok, reason)."""
    decimals, sig = typed_digits(text)
    if abs(typed - value) <= 1e-9 * max(1.0, abs(value)):
        return True, ""
    if decimals < 0:
        return False, "value"
    if abs(typed - value) <= 0.5 * 10 ** (-decimals) * (1 + 1e-9) + 1e-12:
        return (True, "") if sig >= 3 else (False, "digits")
    return False, "value"
