"""LaTeX out: a robot's model or an exercise's step-by-step solution as a .tex fragment.

The fragment needs only ``\\usepackage{amsmath}`` (it has no preamble: ``\\input`` it into a
document). Formulas are the ones the page shows: the same compact forms (``c_{12}`` for
``cos(q1 + q2)`` when no parameter would print alike, app/core/steps.py ``to_latex``) and the same
layout rules (app/core/formula_layout.py) at the width of a printed page, one ``equation*`` per
formula block. Sentences follow the lab's text convention (app/core/mathtext.py): their ``$...$``
segments stay math, the rest is escaped for LaTeX.

>>> text_tex(r"Collect $T = \\frac{1}{2} m$ & 50% — done")
'Collect $T = \\\\frac{1}{2} m$ \\\\& 50\\\\% --- done'
"""
from __future__ import annotations

import re
from typing import List, Mapping, Optional, Sequence

import sympy as sp

from .formula_layout import matrix_latex_blocks, split_top_level, wrap_latex
from .mathtext import split_math
from .steps import shorthand_is_clear, symbol_latex

#: width of a formula line on a printed page (an article's text width at 10 pt), in em
PAGE_WIDTH_EM = 32.0

_ESCAPES = {"\\": r"\textbackslash{}", "&": r"\&", "%": r"\%", "#": r"\#", "_": r"\_", "{": r"\{",
            "}": r"\}", "~": r"\textasciitilde{}", "^": r"\textasciicircum{}", "$": r"\$"}
#: Unicode in sentences that pdfLaTeX's default input encoding cannot set, as LaTeX
_UNICODE = {"—": "---", "–": "--", "…": r"\ldots{}", "−": "$-$", "≤": r"$\le$", "≥": r"$\ge$",
            "≠": r"$\ne$", "≈": r"$\approx$", "→": r"$\to$", "⇔": r"$\Leftrightarrow$", "∈": r"$\in$",
            "×": r"$\times$", "·": r"$\cdot$", "²": r"$^2$", "ᵀ": r"$^T$", "π": r"$\pi$", "θ": r"$\theta$",
            "φ": r"$\varphi$", "ε": r"$\varepsilon$", "τ": r"$\tau$", "ω": r"$\omega$", "Λ": r"$\Lambda$",
            "‖": r"$\|$", "½": r"$\frac{1}{2}$"}
_PLAIN = re.compile("[" + re.escape("".join(_ESCAPES) + "".join(_UNICODE)) + "]")


def text_tex(text: str) -> str:
    """A sentence of the lab's text convention as LaTeX text: ``$...$`` kept, the rest escaped."""
    def plain(piece: str) -> str:
        return _PLAIN.sub(lambda m: _ESCAPES.get(m.group(0)) or _UNICODE[m.group(0)], piece)
    return "".join(f"${piece}$" if is_math else plain(piece) for is_math, piece in split_math(text))


def _equations(blocks: Sequence[str]) -> List[str]:
    return [f"\\begin{{equation*}}\n{block}\n\\end{{equation*}}" for block in blocks]


def _header(what: str) -> List[str]:
    return [f"% {what}: a LaTeX fragment written by Robotics II Lab.",
            "% It needs \\usepackage{amsmath}; \\input it into a document (UTF-8 text).", ""]


def model_tex(robot, dynamics, steps: bool = False, width_em: float = PAGE_WIDTH_EM) -> str:
    """The symbolic model of ``robot`` (``dynamics`` from ``app.core.dynamics.derive``) as LaTeX:
    M(q), c and C(q, q'), g(q), springs and friction, the Christoffel matrices, the linear
    parametrization Y a and the adaptive regressor; ``steps`` adds the derivation steps.

    >>> from app.core.robot import load_robot
    >>> from app.core.dynamics import derive
    >>> robot = load_robot("planar_2r")
    >>> tex = model_tex(robot, derive(robot))
    >>> r"m_{12} = " in tex and r"c_{2}" in tex and tex.count(r"\\begin{equation*}") > 5
    True
    """
    coords = list(robot.coordinates)
    short = shorthand_is_clear(robot.parameters)

    def blocks(name, matrix, entry, symmetric=False):
        return matrix_latex_blocks(name, matrix, coords, entry, width_em=width_em, symmetric=symmetric,
                                   short_trig=short)

    par = dynamics.parametrization
    sections = [("Inertia matrix $M(q)$", blocks("M(q)", dynamics.M, "m", symmetric=True)),
                (r"Coriolis and centrifugal terms $c(q, \dot q)$", blocks(r"c(q,\dot q)", dynamics.c, "c")),
                (r"Factorization $C(q, \dot q)$ from the Christoffel symbols",
                 blocks(r"C(q,\dot q)", dynamics.C, "c")),
                ("Gravity $g(q)$", blocks("g(q)", dynamics.g, "g"))]
    if any(e != 0 for e in dynamics.spring):
        sections.append(("Springs $k(q)$", blocks("k(q)", dynamics.spring, "k")))
    if any(e != 0 for e in dynamics.friction):
        sections.append(("Friction", blocks(r"\tau_f", dynamics.friction, r"\tau_f")))
    christoffel = []
    for i, Ci in enumerate(dynamics.christoffel):
        christoffel += blocks(f"C_{{{i + 1}}}(q)", Ci, f"c_{{{i + 1},#}}", symmetric=True)
    sections.append((r"Christoffel matrices ($c_i = \dot q^T C_i(q) \dot q$)", christoffel))
    known = ", ".join(par.known) or "none"
    sections.append((f"Linear parametrization $Y a = \\tau$ ({par.count} coefficients; known: {known})",
                     blocks(r"Y(q,\dot q,\ddot q)", par.Y, "y") + blocks("a", sp.Matrix(par.a), "a")))
    sections.append((r"Adaptive regressor $Y_r(q, \dot q, \dot q_r, \ddot q_r)$", blocks("Y_r", par.Y_ref, "y")))
    lines = _header(f"Dynamic model of {robot.title}")
    lines += [f"\\subsection*{{{text_tex(robot.title)}}}", "",
              "Coordinates $q = (" + ", ".join(symbol_latex(c, coords) for c in coords) + ")$. "
              + text_tex(robot.description.strip()), ""]
    if short and all(len(c) == 2 for c in coords):
        lines += [r"Shorthand: $c_{1} = \cos q_{1}$, $s_{12} = \sin(q_{1} + q_{2})$, and so on.", ""]
    for title, formulas in sections:
        lines += [f"\\paragraph{{{text_tex(title)}}}", *_equations(formulas), ""]
    if steps:
        lines += ["\\subsubsection*{Derivation}", "", *_steps_tex(dynamics.steps, width_em=width_em)]
    return "\n".join(lines).rstrip() + "\n"


def _steps_tex(steps, notes_of=lambda k: [], width_em: float = PAGE_WIDTH_EM) -> List[str]:
    """Steps as an enumerated list: title, explanation, one ``equation*`` per top-level formula
    (wrapped at the page's width as the page wraps it at the panel's)."""
    if not steps:
        return []
    lines = ["\\begin{enumerate}"]
    for k, step in enumerate(steps):
        lines.append(f"\\item \\textbf{{{text_tex(step.title)}}}")
        if step.text:
            lines.append(text_tex(step.text))
        lines += _equations([wrap_latex(part, width_em) for part in split_top_level(step.latex)] if step.latex else [])
        lines += [f"\\emph{{Note on the printed solution:}} {text_tex(note)}" for note in notes_of(k)]
        lines.append("")
    lines.append("\\end{enumerate}")
    return lines


def solution_tex(solution, variant: Optional[Mapping[str, str]] = None) -> str:
    """An exercise's solution (``app.core.exercise.solve``) as LaTeX: the question, the numbers of
    a variant (name -> value as text) when given, every step with its notes on the printed
    solution, then the notes about the whole exercise. The same content as ``Solution.markdown``.

    >>> from app.core.exercise import load_exercise, solve
    >>> tex = solution_tex(solve(load_exercise("2004-03-25#1")))
    >>> tex.count(r"\\begin{enumerate}") == tex.count(r"\\end{enumerate}") == 1
    True
    """
    ex = solution.exercise
    lines = _header(f"Exercise {ex.id}")
    lines += [f"\\subsection*{{{text_tex(f'{ex.id}: {ex.title}')}}}", "",
              f"Robot: {text_tex(solution.robot.title)}.", "",
              "\\paragraph{Question}", text_tex(ex.question.strip()), ""]
    if variant:
        lines += ["\\paragraph{Numbers of this variant}", "\\begin{itemize}"]
        lines += [f"\\item {text_tex(name)} $=$ {text_tex(value)}" for name, value in variant.items()]
        lines += ["\\end{itemize}", ""]
    lines += ["\\paragraph{Solution}", *_steps_tex(solution.steps, solution.step_notes), ""]
    general = solution.general_notes()
    if general:
        lines += ["\\paragraph{Notes on the printed solution}", "\\begin{itemize}"]
        lines += [f"\\item {text_tex(note)}" for note in general]
        lines += ["\\end{itemize}"]
    return "\n".join(lines).rstrip() + "\n"


_ENVIRONMENT = re.compile(r"\\(begin|end)\{([A-Za-z*]+)\}")


def unbalanced(tex: str) -> List[str]:
    """What is not balanced in a LaTeX text: environments (begin/end pairs) and braces.

    >>> unbalanced(r"\\begin{equation*} {a \\end{equation*}"), unbalanced(r"\\{ \\begin{x}\\end{x}")
    (['a brace opened and not closed'], [])
    """
    problems, stack = [], []
    for m in _ENVIRONMENT.finditer(tex):
        if m.group(1) == "begin":
            stack.append(m.group(2))
        elif not stack or stack.pop() != m.group(2):
            problems.append(f"\\end{{{m.group(2)}}} does not close the environment open there")
    problems += [f"\\begin{{{name}}} never closed" for name in stack]
    depth = 0
    for ch in re.sub(r"\\[\\{}]", "", tex):
        depth += {"{": 1, "}": -1}.get(ch, 0)
        if depth < 0:
            problems.append("a brace closed that was not opened")
            depth = 0
    if depth:
        problems.append("a brace opened and not closed")
    return problems


def formulas(tex: str) -> List[str]:
    """Every formula of a fragment written here: the bodies of its ``equation*`` environments and
    its inline ``$...$`` segments (what the test converts to MathML)."""
    out = re.findall(r"\\begin\{equation\*\}\n(.*?)\n\\end\{equation\*\}", tex, flags=re.S)
    rest = re.sub(r"\\begin\{equation\*\}.*?\\end\{equation\*\}", " ", tex, flags=re.S)
    rest = "\n".join(line for line in rest.splitlines() if not line.startswith("%"))
    out += [piece for is_math, piece in split_math(rest) if is_math]
    return out
