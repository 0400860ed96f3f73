"""Check my answer: does a student's expression or number equal an entry the engine derives, and
if not, where does it go wrong (without giving the answer away)?

Entries of a robot's model: ``m11`` (M), ``c1`` (c), ``g1`` (g), ``k1`` (springs), ``C12`` (the
factorization C), ``c1_12`` or ``c112`` (Christoffel symbol = entry (1,2) of C_1), ``C1`` (the
Christoffel matrix), ``a1`` (a dynamic coefficient), ``Y12`` (entry of the regressor) and
``Ycol2`` (a column), and the whole objects ``M``, ``c``, ``g``, ``C`` (any valid factorization:
C q̇ = c; with ``skew=True`` also Ṁ − 2C skew-symmetric), ``a`` (a different minimal set of
coefficients is right when it spans the same model: an invertible constant linear map of the
engine's) and ``Y``. Entries of an exercise: its answer names (``python -m app solve ID --json``),
with ``[i]`` or ``[i,j]`` for one entry (1-based); the model shorthands above work on exercises
whose tasks give M, c, g, C.

Answers are read in the course's notation by the lab's whitelist parser (never ``eval``):
``m2*l1*d2*cos(q2)`` or ``2 m2 l1 d2 c2`` (implicit products), ``c2``, ``s12`` = sin(q1 + q2),
``q2'``/``dq2``/``q2''``, Greek names (``theta``, ``θ``), ``²``, vectors ``[a, b]`` and matrices
``[[a, b], [c, d]]`` or ``[a, b; c, d]``. Numbers are right up to the digits typed (at least 3
significant ones).

Equivalence is decided exactly through the canonical trigonometric form (app/core/trig.py), and,
for expressions outside it (fractions), at random points. A wrong answer gets findings: a unit
mismatch (dimensional analysis from the parameters' units), a missing or extra term (named by its
parameters only), a wrong sign, factor 2 or coefficient, sin for cos, a wrong dependence on a
coordinate, the value at a sample state; ``hint=2`` adds the derivation step to recheck.

For a panel, one line: ``check_answer("planar_2r", "m11", text).as_dict()`` (or
``check_model_entry(session.robot, session.dynamics, entry, text)`` to reuse the tab's model,
``check_exercise_answer(solution, name, text)`` for a solved exercise); the verdict's ``message``
and findings' ``message`` follow the text convention of app/core/mathtext.py (``$...$`` math).

The rooms: reading answers in answer_reading.py (``Reader``, ``AnswerError``), comparing and the
findings in answer_compare.py (``equivalent``, ``Diagnosis``, ``numbers_match``), dimensions in
answer_units.py; this module holds the entries and the checks.

>>> v = check_answer("planar_2r", "m22", "I2 + m2*d2^2")
>>> v.correct
True
>>> v = check_answer("planar_2r", "m22", "I2")
>>> v.correct, [f.kind for f in v.findings][:1]
(False, ['missing_term'])
"""
from __future__ import annotations

import math
import random
import re
from dataclasses import dataclass, field
from typing import Any, Dict, List, Optional, Tuple

import numpy as np
import sympy as sp

from .answer_compare import Diagnosis, Finding, equivalent, numbers_match, real_symbols, typed_digits
from .answer_reading import AnswerError, Reader, split_top
from .answer_units import Dimensions
from .errors import UserError
from .expressions import symbol
from .steps import Step, to_latex


# ====================================================================== verdict
@dataclass
class Verdict:
    target: str
    entry: str
    answer: str
    correct: bool
    kind: str                       # symbolic, numeric, factorization, coefficients
    message: str
    findings: List[Finding] = field(default_factory=list)
    hint: int = 1
    step: Optional[Step] = None     # hint level 2: the derivation step to recheck
    remarks: List[str] = field(default_factory=list)   # about a right answer (e.g. not skew)

    def as_dict(self) -> dict:
        """The ``--json`` object of ``check-answer`` (documented in docs/cli.md)."""
        return {"target": self.target, "entry": self.entry, "answer": self.answer, "correct": self.correct,
                "kind": self.kind, "message": self.message, "findings": [f.as_dict() for f in self.findings],
                "remarks": list(self.remarks), "hint": self.hint,
                "step": None if self.step is None else {"title": self.step.title, "latex": self.step.latex,
                                                        "text": self.step.text}}

    def text(self) -> str:
        """The verdict for a terminal (Unicode math)."""
        from .mathtext import latex_to_unicode, to_unicode
        out = [("right: " if self.correct else "wrong: ") + to_unicode(self.message)]
        out += ["  - " + to_unicode(f.message) for f in self.findings]
        out += ["  note: " + to_unicode(r) for r in self.remarks]
        if self.step is not None:
            out.append(f"  recheck this step: {to_unicode(self.step.title)}")
            if self.step.text:
                out.append("    " + to_unicode(self.step.text))
            if self.step.latex:
                out += ["    " + line for line in latex_to_unicode(self.step.latex, display=True).splitlines()]
        return "\n".join(out)


# ====================================================================== entries
_MODEL_ENTRY = [
    (re.compile(r"^m(\d)(\d)$"), ("M", 2)),
    (re.compile(r"^C(\d)(\d)$"), ("C", 2)),
    (re.compile(r"^c(\d)_?(\d)(\d)$"), ("christoffel", 3)),
    (re.compile(r"^C(\d)$"), ("christoffel", 1)),
    (re.compile(r"^c(\d)$"), ("c", 1)),
    (re.compile(r"^g(\d)$"), ("g", 1)),
    (re.compile(r"^k(\d)$"), ("spring", 1)),
    (re.compile(r"^a(\d+)$"), ("a", 1)),
    (re.compile(r"^Y(\d)(\d+)$"), ("Y", 2)),
    (re.compile(r"^Y_?col(\d+)$"), ("Ycol", 1)),
]
_INDEXED = re.compile(r"^([A-Za-z_][A-Za-z0-9_]*)\[\s*(:|\d+)\s*(?:,\s*(:|\d+)\s*)?\]$")


def _model_objects(dyn) -> Dict[str, Any]:
    par = dyn.parametrization
    return {"M": dyn.M, "c": dyn.c, "g": dyn.g, "C": dyn.C, "spring": dyn.spring, "a": sp.Matrix(par.a),
            "Y": par.Y}


def _entry_tex(entry: str) -> str:
    m = re.fullmatch(r"([A-Za-z]+)(\d+)", entry)
    if m and entry[0] in "mcgkaCY":
        return f"{m.group(1)}_{{{m.group(2)}}}"
    if re.fullmatch(r"c\d_\d\d", entry):
        return f"c_{{{entry[1]},{entry[3:]}}}"
    return r"\mathrm{" + entry.replace("_", r"\_") + "}" if len(entry) > 1 else entry


# ====================================================================== checking
def check_answer(target: str, entry: str, answer: str, hint: int = 1, skew: bool = False) -> Verdict:
    """Check ``answer`` for ``entry`` of a robot's model or of an exercise (see the module docstring)."""
    from .exercise import ExerciseError, exercise_path, load_exercise, solve
    try:
        path = exercise_path(target)
    except ExerciseError:
        path = None
    if path is not None and "#" in str(target) or (path is not None and _is_exercise_file(path)):
        solution = solve(load_exercise(target))
        return check_exercise_answer(solution, entry, answer, hint, skew, target=str(target))
    from .dynamics import derive
    from .robot import load_robot
    robot = load_robot(target)
    return check_model_entry(robot, derive(robot), entry, answer, hint, skew, target=str(target))


def _is_exercise_file(path) -> bool:
    from .files import load_yaml, read_user_file
    try:
        data = load_yaml(read_user_file(path), str(path))
        return isinstance(data, dict) and "tasks" in data
    except UserError:
        return False


def check_model_entry(robot, dyn, entry: str, answer: str, hint: int = 1, skew: bool = False,
                      target: str = "") -> Verdict:
    """Check one entry of a derived model (``dyn`` from app.core.dynamics.derive)."""
    objects = _model_objects(dyn)
    checker = _Checker(robot, dyn, target or robot.name, entry, answer, hint)
    for rx, (what, nidx) in _MODEL_ENTRY:
        m = rx.match(entry)
        if not m:
            continue
        idx = [int(g) - 1 for g in m.groups()]
        if what == "christoffel":
            if not 0 <= idx[0] < len(dyn.christoffel):
                raise AnswerError(f"{entry}: {robot.name} has {len(dyn.christoffel)} Christoffel matrices")
            if nidx == 1:
                return checker.whole(dyn.christoffel[idx[0]], step_title="Inertia matrix")
            return checker.scalar(_pick(dyn.christoffel[idx[0]], idx[1:], entry), step_title="Inertia matrix")
        if what == "Ycol":
            Y = objects["Y"]
            if not 0 <= idx[0] < Y.cols:
                raise AnswerError(f"{entry}: the regressor has {Y.cols} columns")
            return checker.whole(Y[:, idx[0]], step_title="Equations of motion")
        return checker.scalar(_pick(objects[what], idx, entry), step_title=_STEP_OF.get(what))
    if entry == "C":
        return checker.factorization(skew)
    if entry == "a":
        return checker.coefficients()
    if entry in objects:
        return checker.whole(objects[entry], step_title=_STEP_OF.get(entry))
    m = _INDEXED.match(entry)
    if m and m.group(1) in objects:
        return checker.scalar(_index(objects[m.group(1)], m, entry), step_title=_STEP_OF.get(m.group(1)))
    raise AnswerError(f"unknown entry '{entry}' (use m11, c1, g1, k1, C12, c1_12, C1, a1, Y12, Ycol1, "
                      "or M, c, g, C, a, Y)")


_STEP_OF = {"M": "Kinematics of", "c": "Inertia matrix", "C": "Inertia matrix", "g": "Potential energy",
            "spring": "Elastic energy", "a": "Equations of motion", "Y": "Equations of motion"}


def check_exercise_answer(solution, entry: str, answer: str, hint: int = 1, skew: bool = False,
                          target: str = "") -> Verdict:
    """Check an answer of a solved exercise (``solution`` from app.core.exercise.solve)."""
    answers = solution.answers
    target = target or solution.exercise.id
    name, index = entry, None
    m = _INDEXED.match(entry)
    if m:
        name = m.group(1)
    if name not in answers:
        shorthand = next((what for rx, (what, _) in _MODEL_ENTRY if rx.match(entry)), None)
        if shorthand and all(k in answers for k in ("M", "c", "g", "C")):
            from .dynamics import derive
            return check_model_entry(solution.robot, derive(solution.robot), entry, answer, hint, skew, target)
        raise AnswerError(f"{target} has no answer '{name}' (answers: {', '.join(sorted(answers))})")
    value = answers[name]
    checker = _Checker(solution.robot, None, target, entry, answer, hint, solution=solution, answer_name=name)
    if m:
        value = _index(_as_matrix(value), m, entry)
        if isinstance(value, sp.MatrixBase):
            return checker.whole(value)
        return checker.scalar(value)
    if isinstance(value, (bool, np.bool_)):
        return checker.yes_no(bool(value))
    if isinstance(value, (list, tuple, np.ndarray, sp.MatrixBase)):
        if name == "C" and "c" in answers:
            return checker.factorization(skew, c=answers["c"], M=answers.get("M"))
        return checker.whole(_as_matrix(value))
    return checker.scalar(value)


def _as_matrix(value):
    if isinstance(value, sp.MatrixBase):
        return value
    arr = np.asarray(value, dtype=object)
    if arr.ndim == 0:
        return sp.sympify(value)
    if arr.ndim == 1:
        return sp.Matrix([sp.sympify(v) for v in arr])
    return sp.Matrix([[sp.sympify(v) for v in row] for row in arr])


def _pick(matrix, idx, entry):
    matrix = sp.Matrix(matrix)
    try:
        if len(idx) == 1:
            if matrix.cols != 1 and matrix.rows != 1:
                raise IndexError
            if not 0 <= idx[0] < len(matrix):
                raise IndexError
            return matrix[idx[0]]
        i, j = idx
        if not (0 <= i < matrix.rows and 0 <= j < matrix.cols):
            raise IndexError
        return matrix[i, j]
    except IndexError:
        raise AnswerError(f"{entry}: no such entry (the matrix is {matrix.rows}x{matrix.cols}; indices start at 1)") from None


def _index(value, m, entry):
    a, b = m.group(2), m.group(3)
    if not isinstance(value, sp.MatrixBase):
        raise AnswerError(f"{entry}: '{m.group(1)}' is not a vector or matrix")
    if b is None:
        if a == ":":
            return value
        return _pick(value, [int(a) - 1], entry)
    if a == ":":
        j = int(b) - 1
        if not 0 <= j < value.cols:
            raise AnswerError(f"{entry}: no column {b}")
        return value[:, j]
    if b == ":":
        i = int(a) - 1
        if not 0 <= i < value.rows:
            raise AnswerError(f"{entry}: no row {a}")
        return value[i, :]
    return _pick(value, [int(a) - 1, int(b) - 1], entry)


class _Checker:
    def __init__(self, robot, dyn, target, entry, answer, hint, solution=None, answer_name=None):
        self.robot, self.dyn, self.target, self.entry, self.answer = robot, dyn, target, entry, str(answer)
        self.hint = int(hint)
        self.solution, self.answer_name = solution, answer_name
        self.tex = _entry_tex(entry)
        extra = set()
        if solution is not None:
            for v in solution.answers.values():
                if isinstance(v, (sp.Basic, sp.MatrixBase)):
                    extra |= {s.name for s in sp.sympify(v).free_symbols if isinstance(s, sp.Symbol)}
        self.reader = Reader(robot, sorted(extra))
        self.dims = Dimensions(robot, dyn) if dyn is not None or solution is not None else None
        self.diag = Diagnosis(robot, self.dims, robot.coordinates)

    def verdict(self, correct, kind, message, findings=(), remarks=()):
        step = self._step() if (not correct and self.hint >= 2) else None
        return Verdict(self.target, self.entry, self.answer, bool(correct), kind, message, list(findings),
                       self.hint, step, list(remarks))

    # ------------------------------------------------------------ scalars
    def scalar(self, expected, step_title=None):
        self.step_title = step_title
        expected = sp.sympify(expected)
        typed = self.reader.value(self.answer)
        if isinstance(typed, sp.MatrixBase):
            return self.verdict(False, "symbolic", f"${self.tex}$ is a single expression, not a list",
                                [Finding("shape", f"give one expression for ${self.tex}$")])
        if expected.is_number and typed.is_number:
            return self._number(float(expected), typed)
        if equivalent(typed, expected):
            return self.verdict(True, "symbolic", f"${self.tex}$ is right" + self._form_remark(typed, expected))
        findings = self.diag.findings(self.tex, expected, typed)
        findings.append(self._sample(expected, typed))
        return self.verdict(False, "symbolic", f"${self.tex}$ is not right", findings)

    def _form_remark(self, typed, expected) -> str:
        if sp.expand(typed) == sp.expand(expected):
            return ""
        return " (an equivalent form)"

    def _number(self, value, typed):
        typed_v = float(typed)
        ok, why = numbers_match(self.answer, typed_v, value)
        if ok:
            return self.verdict(True, "numeric", f"${self.tex}$ is right")
        if why == "digits":
            return self.verdict(False, "numeric", f"${self.tex}$: give at least 3 significant digits",
                                [Finding("digits", "right to the digits you typed, but too few of them to tell")])
        findings = []
        if value != 0 and abs(typed_v + value) <= 1e-6 * abs(value) + 0.5 * 10 ** (-max(typed_digits(self.answer)[0], 0)):
            findings.append(Finding("sign", "the sign is wrong"))
        elif value != 0 and typed_v != 0:
            r = typed_v / value
            for k, name in ((2, "2"), (0.5, "1/2"), (10, "10"), (0.1, "1/10"), (1000, "1000"), (0.001, "1/1000")):
                if abs(r - k) < 1e-3 * k:
                    findings.append(Finding("factor", f"off by a factor {name}" + (" (a unit or a decimal point?)"
                                                                                   if k in (10, 0.1, 1000, 0.001) else "")))
                    break
        rel = abs(typed_v - value) / max(abs(value), 1e-12)
        findings.append(Finding("value", "too large" if typed_v > value else "too small",
                                {"relative_error": float(f"{rel:.3g}")}))
        return self.verdict(False, "numeric", f"${self.tex}$ is not right", findings)

    def yes_no(self, value: bool):
        text = self.answer.strip().lower()
        if text in ("yes", "y", "true", "1"):
            typed = True
        elif text in ("no", "n", "false", "0"):
            typed = False
        else:
            raise AnswerError(f"answer yes or no for '{self.entry}'")
        return self.verdict(typed == value, "yes/no", f"${self.tex}$ is {'right' if typed == value else 'not right'}")

    def _sample(self, expected, typed) -> Finding:
        state = _sample_state(self.robot, expected.free_symbols | typed.free_symbols)
        try:
            ve = float(sp.N(expected.subs(state)))
            vt = float(sp.N(typed.subs(state)))
        except (TypeError, ValueError):
            return Finding("value", "the two differ at a sample state")
        motion = {n for c in self.robot.coordinates for n in (c, "d" + c, "dd" + c, "d" + c + "_r", "dd" + c + "_r")}
        shown = ", ".join(f"{to_latex(s, self.robot.coordinates)} = {v:g}" for s, v in state.items() if s.name in motion)
        shown = f"at the sample state ${shown}$" if shown else "with the robot's parameter values"
        return Finding("value", f"{shown} (parameters at the robot's values) yours is "
                                f"${_fmt(vt)}$, the right one ${_fmt(ve)}$",
                       {"state": {s.name: v for s, v in state.items()}, "yours": vt, "expected": ve})

    # ------------------------------------------------------------ vectors and matrices
    def whole(self, expected, step_title=None):
        self.step_title = step_title
        expected = sp.Matrix(expected)
        typed = self.reader.value(self.answer)
        if not isinstance(typed, sp.MatrixBase):
            if expected.shape == (1, 1):
                return self.scalar(expected[0], step_title)
            return self.verdict(False, "symbolic", f"${self.tex}$ has {expected.rows}x{expected.cols} entries",
                                [Finding("shape", f"give a {'vector' if expected.cols == 1 else 'matrix'} "
                                                  f"of {expected.rows}x{expected.cols}")])
        if typed.shape != expected.shape:
            if typed.shape == expected.shape[::-1] and 1 in typed.shape:
                typed = typed.T
            else:
                return self.verdict(False, "symbolic", f"${self.tex}$ is {expected.rows}x{expected.cols}, yours "
                                    f"{typed.rows}x{typed.cols}", [Finding("shape", "the size is wrong")])
        numeric = all(e.is_number for e in expected) and all(e.is_number for e in typed)
        parts = split_top(self.answer.strip()[1:-1], ",;") if self.answer.strip().startswith("[") else []
        findings, wrong = [], 0
        for k in range(len(expected)):
            i, j = divmod(k, expected.cols)
            label = f"{i + 1}" if expected.cols == 1 else f"{i + 1}{j + 1}"
            e, t = expected[k], typed[k]
            if numeric:
                text = parts[k].strip("[] ") if len(parts) == len(expected) else str(t)
                ok = numbers_match(text, float(t), float(e))[0]
            else:
                ok = equivalent(t, e)
            if ok:
                continue
            wrong += 1
            sub = f"{self.tex}_{{{label}}}" if len(self.tex) < 3 else f"({self.tex})_{{{label}}}"
            if numeric:
                findings.append(Finding("value", f"entry ${sub}$ is {'too large' if float(t) > float(e) else 'too small'}",
                                        {"entry": label}))
            else:
                findings += [Finding(f.kind, f"entry ${sub}$: {f.message}", {**f.data, "entry": label})
                             for f in self.diag.findings(sub, e, t)] or [Finding("function", f"entry ${sub}$ is not right",
                                                                                 {"entry": label})]
        if not wrong:
            return self.verdict(True, "numeric" if numeric else "symbolic", f"${self.tex}$ is right")
        return self.verdict(False, "numeric" if numeric else "symbolic",
                            f"${self.tex}$: {wrong} of {len(expected)} entries are not right", findings)

    # ------------------------------------------------------------ factorization C of c
    def factorization(self, skew: bool, c=None, M=None):
        self.step_title = "Inertia matrix"
        robot = self.robot
        c = sp.Matrix(c if c is not None else self.dyn.c)
        M = sp.Matrix(M if M is not None else self.dyn.M)
        typed = self.reader.value(self.answer)
        n = robot.n
        if not isinstance(typed, sp.MatrixBase) or typed.shape != (n, n):
            return self.verdict(False, "factorization", f"$C$ is a {n}x{n} matrix", [Finding("shape", "the size is wrong")])
        dq = sp.Matrix(robot.dq)
        Cdq = typed * dq
        findings = []
        for i in range(n):
            if not equivalent(Cdq[i], c[i]):
                sub = f"(C\\dot q)_{{{i + 1}}}"
                findings += [Finding(f.kind, f"row {i + 1}: {f.message}", {**f.data, "row": i + 1})
                             for f in self.diag.findings(sub, c[i], sp.expand(Cdq[i]))]
        if findings:
            return self.verdict(False, "factorization", r"$C \dot q \ne c$: this is not a factorization of $c$",
                                [Finding("factorization", r"$C \dot q$ must equal $c(q, \dot q)$ row by row")] + findings)
        Mdot = sp.Matrix(n, n, lambda i, j: sum(sp.diff(M[i, j], qk) * dqk for qk, dqk in zip(robot.q, robot.dq)))
        N = Mdot - 2 * typed
        is_skew = all(equivalent(N[i, j], -N[j, i]) for i in range(n) for j in range(i, n))
        if skew and not is_skew:
            return self.verdict(False, "factorization", r"$C \dot q = c$, but $\dot M - 2C$ is not skew-symmetric",
                                [Finding("skew", r"the question asks for the factorization with $\dot M - 2C$ skew-symmetric "
                                                 "(the one from the Christoffel symbols)")])
        remark = [] if is_skew else [r"a valid factorization, but $\dot M - 2C$ is not skew-symmetric "
                                     "(passivity-based laws need the Christoffel one)"]
        return self.verdict(True, "factorization", r"$C \dot q = c$: a valid factorization", remarks=remark)

    # ------------------------------------------------------------ dynamic coefficients a
    def coefficients(self):
        self.step_title = "Equations of motion"
        par = self.dyn.parametrization
        a = [sp.sympify(x) for x in par.a]
        typed = self.reader.value(self.answer)
        typed = list(typed) if isinstance(typed, sp.MatrixBase) else [typed]
        if len(typed) != len(a):
            kind = "count"
            msg = (f"a minimal set has {len(a)} coefficients, yours has {len(typed)}")
            return self.verdict(False, "coefficients", msg, [Finding(kind, msg)])
        T, bad = _linear_map(typed, a, [symbol(k) for k in par.known])
        if bad:
            findings = [Finding("span", f"$a'_{{{i + 1}}} = {to_latex(typed[i], self.robot.coordinates)}$ is not a "
                                        "combination of the model's coefficients (known parameters allowed as factors)",
                                {"index": i + 1}) for i in bad]
            return self.verdict(False, "coefficients", "your coefficients do not span the same model", findings)
        if sp.simplify(T.det()) == 0:
            return self.verdict(False, "coefficients", "your coefficients are dependent: they cannot reproduce the model",
                                [Finding("span", "some coefficient is a combination of the others (the map to the "
                                                 "model's coefficients is singular)")])
        same = T == sp.eye(len(a))
        return self.verdict(True, "coefficients", "a minimal set spanning the model" +
                            ("" if same else " (a linear reparametrization of the engine's)"))

    # ------------------------------------------------------------ level 2
    def _step(self) -> Optional[Step]:
        if self.solution is not None:
            k = getattr(self.solution, "answer_step", lambda n: None)(self.answer_name)
            steps = self.solution.steps
            if k is None:
                return None
            return steps[max(k - 1, 0)]
        title = getattr(self, "step_title", None)
        if not title or self.dyn is None:
            return None
        if title == "Kinematics of":
            body = self._suspect_body()
            if body is not None:
                title = f"Kinematics of {body.replace('_', ' ')}"
        return next((s for s in self.dyn.steps if s.title.startswith(title)), None)

    def _suspect_body(self) -> Optional[str]:
        """The first body whose parameters appear in a wrong term of an inertia entry."""
        try:
            expected = _pick(self.dyn.M, [int(self.entry[1]) - 1, int(self.entry[2]) - 1], self.entry)
            typed = self.reader.value(self.answer)
        except (AnswerError, ValueError, IndexError):
            return None
        diff = sp.expand(typed - expected)
        wrong = diff.free_symbols
        for body in self.robot.bodies:
            own = set(sp.sympify(body.mass).free_symbols) | set(sp.Matrix(body.inertia).free_symbols)
            if own & wrong:
                return body.name
        return None


def _fmt(x: float) -> str:
    return "0" if abs(x) < 1e-12 else f"{x:.5g}"


def _sample_state(robot, symbols) -> Dict[sp.Symbol, float]:
    """A fixed, generic state: coordinates and velocities drawn once (seed 5), parameters at the
    robot's values, other symbols at 0.7."""
    rng = random.Random(5)
    values = {p.symbol: p.value for p in robot.parameters.values()}
    state = {}
    for c in robot.coordinates:
        for name in (c, "d" + c, "dd" + c, "d" + c + "_r", "dd" + c + "_r"):
            state[symbol(name)] = round(rng.uniform(-1.2, 1.2), 2) or 0.37
    out = {}
    for s in sorted(symbols, key=lambda s: s.name):
        out[s] = state.get(s, values.get(s, 0.7))
    return out


def _linear_map(typed, a, known) -> Tuple[sp.Matrix, List[int]]:
    """T with typed = T a (entries may contain known parameters); indices of typed entries that are
    not such combinations."""
    t = sp.symbols(f"t0:{len(a)}")
    unknown_syms = set().union(*[x.free_symbols for x in a]) - set(known)
    rows, bad = [], []
    for i, y in enumerate(typed):
        expr = sp.expand(real_symbols(y) - sum(ti * ai for ti, ai in zip(t, a)))
        gens = sorted(unknown_syms | (expr.free_symbols - set(known) - set(t)), key=lambda s: s.name)
        if not gens:
            bad.append(i)
            rows.append([0] * len(a))
            continue
        poly = sp.Poly(expr, *gens)
        eqs = [sp.expand(c) for c in poly.coeffs()]
        sol = sp.solve(eqs, t, dict=True)
        if not sol:
            bad.append(i)
            rows.append([0] * len(a))
            continue
        rows.append([sol[0].get(ti, 0) for ti in t])
    return sp.Matrix(rows), bad


# ====================================================================== entries offered on the page
def model_entries(robot, dyn) -> List[Tuple[str, str]]:
    """The entries of a derived model a student can check, as ``(entry, description)`` pairs in the
    order of the Model tab: M (upper triangle), c, C, Christoffel symbols (j <= k), g, springs,
    the coefficients a and the regressor's columns.

    >>> from app.core.dynamics import derive
    >>> from app.core.robot import load_robot
    >>> robot = load_robot("planar_2r")
    >>> entries = [e for e, _ in model_entries(robot, derive(robot))]
    >>> entries[:5], "c1_22" in entries, "Ycol1" in entries
    (['m11', 'm12', 'm22', 'c1', 'c2'], True, True)
    """
    n = len(dyn.M.tolist())
    out: List[Tuple[str, str]] = []
    out += [(f"m{i + 1}{j + 1}", "inertia matrix M(q)") for i in range(n) for j in range(i, n)]
    out += [(f"c{i + 1}", "Coriolis and centrifugal terms c(q, q̇)") for i in range(n)]
    out += [(f"C{i + 1}{j + 1}", "factorization C(q, q̇)") for i in range(n) for j in range(n)]
    out += [(f"c{i + 1}_{j + 1}{k + 1}", f"Christoffel symbol, matrix C{i + 1}")
            for i in range(len(dyn.christoffel)) for j in range(n) for k in range(j, n)]
    out += [(f"g{i + 1}", "gravity g(q)") for i in range(n)]
    if any(e != 0 for e in dyn.spring):
        out += [(f"k{i + 1}", "springs k(q)") for i in range(n)]
    par = dyn.parametrization
    out += [(f"a{k + 1}", "dynamic coefficient") for k in range(len(par.a))]
    out += [(f"Ycol{k + 1}", "regressor column (a vector)") for k in range(par.Y.cols)]
    return out


def _checkable(value) -> bool:
    if isinstance(value, (bool, np.bool_, int, float, np.integer, np.floating, sp.Basic, sp.MatrixBase)):
        return True
    if isinstance(value, (list, tuple, np.ndarray)):
        try:
            arr = np.asarray(value, dtype=object)
        except ValueError:
            return False
        return arr.ndim in (1, 2) and arr.size > 0 and all(
            isinstance(v, (int, float, np.integer, np.floating, sp.Basic)) and not isinstance(v, bool)
            for v in arr.ravel())
    return False


def exercise_entries(solution, upto_step: Optional[int] = None) -> List[Tuple[str, str]]:
    """The answers of a solved exercise a student can check, as ``(entry, description)`` pairs:
    each answer shown by a step ``<= upto_step`` (all when None), whole and, for a vector or a
    small matrix, entry by entry (``name[i]``, ``name[i,j]``, 1-based)."""
    out: List[Tuple[str, str]] = []
    names = sorted(solution.answers, key=lambda a: (solution.answer_step(a) is None, solution.answer_step(a) or 0))
    for name in names:
        value, k = solution.answers[name], solution.answer_step(name)
        if upto_step is not None and (k is None or k > upto_step):
            continue
        if not _checkable(value):
            continue
        where = f"step {k + 1}" if k is not None else "answer"
        out.append((name, where))
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, (list, tuple, np.ndarray, sp.MatrixBase)):
            continue
        m = _as_matrix(value)
        if not isinstance(m, sp.MatrixBase) or m.rows * m.cols > 16 or m.rows * m.cols < 2:
            continue
        if m.cols == 1 or m.rows == 1:
            out += [(f"{name}[{i + 1}]", where) for i in range(len(m))]
        else:
            out += [(f"{name}[{i + 1},{j + 1}]", where) for i in range(m.rows) for j in range(m.cols)]
    return out
