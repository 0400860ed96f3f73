"""Text with inline math, as shown to users: the lab's convention and its renderers.

Convention (step texts, step titles, notes of exercises, diagnoses of answers): plain sentences,
with every formula, symbol with a subscript, derivative or equation written as LaTeX between
dollar signs, e.g. ``"Collect $T = \\frac{1}{2}\\dot q^T M(q) \\dot q$; M is symmetric."``
(``\\$`` is a literal dollar). The page typesets the ``$...$`` segments as inline MathML
(app/viewer/mathml.py ``text_html``), Markdown keeps them as they are (``$...$`` is Markdown's
inline math), and the terminal shows them in Unicode (``to_unicode``).

``problems(text)`` lists what breaks the convention (a plain-text formula, a Python structure, raw
LaTeX outside ``$``, noisy numbers); tests/test_readable_steps.py runs it on every shipped step.

>>> to_unicode(r"Collect $T = \\frac{1}{2} \\dot{q}_{2}^{2} m_{2}$.")
'Collect T = ½ q̇₂² m₂.'
>>> problems("then T = 1/2 m |v_c|^2")
['plain-text formula (=) outside $...$: "then T = 1/2 m |v_c|^2"']
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from typing import List, Tuple

# ---------------------------------------------------------------------- splitting
_DOLLAR = re.compile(r"(?<!\\)\$")


def split_math(text: str) -> List[Tuple[bool, str]]:
    """``[(is_math, piece), ...]`` of a text with ``$...$`` segments (an unclosed ``$`` is text).

    >>> split_math("a $x^2$ b")
    [(False, 'a '), (True, 'x^2'), (False, ' b')]
    """
    out: List[Tuple[bool, str]] = []
    pos, inside = 0, False
    marks = [m.start() for m in _DOLLAR.finditer(text)]
    if len(marks) % 2:
        marks = marks[:-1]
    for mark in marks:
        piece = text[pos:mark]
        if piece:
            out.append((inside, piece if inside else piece.replace(r"\$", "$")))
        inside, pos = not inside, mark + 1
    rest = text[pos:]
    if rest:
        out.append((False, rest.replace(r"\$", "$")))
    return out


def plain_parts(text: str) -> str:
    """The text outside the ``$...$`` segments (each segment replaced by a space)."""
    return "".join(" " if is_math else piece for is_math, piece in split_math(text))


# ---------------------------------------------------------------------- LaTeX -> Unicode
_SYMBOLS = {
    "alpha": "α", "beta": "β", "gamma": "γ", "delta": "δ", "epsilon": "ε", "varepsilon": "ε",
    "zeta": "ζ", "eta": "η", "theta": "θ", "vartheta": "ϑ", "iota": "ι", "kappa": "κ",
    "lambda": "λ", "mu": "μ", "nu": "ν", "xi": "ξ", "pi": "π", "rho": "ρ", "sigma": "σ", "tau": "τ",
    "upsilon": "υ", "phi": "φ", "varphi": "φ", "chi": "χ", "psi": "ψ", "omega": "ω",
    "Gamma": "Γ", "Delta": "Δ", "Theta": "Θ", "Lambda": "Λ", "Xi": "Ξ", "Pi": "Π", "Sigma": "Σ",
    "Phi": "Φ", "Psi": "Ψ", "Omega": "Ω",
    "cdot": "·", "times": "×", "le": "≤", "leq": "≤", "ge": "≥", "geq": "≥", "ne": "≠", "neq": "≠",
    "approx": "≈", "to": "→", "rightarrow": "→", "Rightarrow": "⇒", "leftarrow": "←",
    "Leftrightarrow": "⇔", "iff": "⇔", "infty": "∞", "partial": "∂", "in": "∈", "notin": "∉",
    "pm": "±", "mp": "∓", "sum": "Σ", "prod": "Π", "nabla": "∇", "dots": "…", "ldots": "…",
    "cdots": "⋯", "top": "ᵀ", "prime": "′", "ell": "ℓ", "|": "‖", "Vert": "‖", "lvert": "|",
    "rvert": "|", "vert": "|", "langle": "⟨", "rangle": "⟩", "{": "{", "}": "}", "%": "%", "_": "_",
    "#": "#", "&": "&", "$": "$", "circ": "∘", "sim": "∼", "equiv": "≡", "forall": "∀",
    "exists": "∃", "dagger": "†", "star": "⋆", "perp": "⊥", "parallel": "∥", "mapsto": "↦",
    "quad": "  ", "qquad": "    ", ",": " ", ";": " ", ":": " ", "!": "", " ": " ", "lfloor": "⌊",
    "rfloor": "⌋", "lceil": "⌈", "rceil": "⌉", "setminus": "∖", "cup": "∪", "cap": "∩",
    "subset": "⊂", "subseteq": "⊆", "emptyset": "∅", "neg": "¬", "wedge": "∧", "vee": "∨",
    "odot": "⊙", "otimes": "⊗", "oplus": "⊕", "propto": "∝", "ll": "≪", "gg": "≫", "angle": "∠",
    "degree": "°", "max": "max", "min": "min", "sup": "sup", "inf": "inf", "lim": "lim",
    "det": "det", "rank": "rank", "dim": "dim", "ker": "ker", "arg": "arg", "exp": "exp", "log": "log",
    "ln": "ln", "sin": "sin", "cos": "cos", "tan": "tan", "cot": "cot", "sec": "sec", "csc": "csc",
    "arcsin": "arcsin", "arccos": "arccos", "arctan": "arctan", "sinh": "sinh", "cosh": "cosh",
    "tanh": "tanh", "sgn": "sgn", "tr": "tr", "colon": ":", "mid": "|", "backslash": "\\",
}
_ACCENTS = {"dot": "\u0307", "ddot": "\u0308", "hat": "\u0302", "widehat": "\u0302", "tilde": "\u0303",
            "widetilde": "\u0303", "bar": "\u0304", "overline": "\u0305", "vec": "\u20d7"}
_FONTS = {"mathrm", "text", "textrm", "mathbf", "boldsymbol", "mathit", "mathsf", "operatorname",
          "mathcal", "textbf", "textit", "bm", "mathtt", "texttt", "mbox"}
_BLACKBOARD = {"R": "ℝ", "N": "ℕ", "Z": "ℤ", "Q": "ℚ", "C": "ℂ"}
_SUP = dict(zip("0123456789+-=()nijkTtx", "⁰¹²³⁴⁵⁶⁷⁸⁹⁺⁻⁼⁽⁾ⁿⁱʲᵏᵀᵗˣ"))
_SUP.update({"−": "⁻", "ᵀ": "ᵀ", "*": "*", "′": "′", "†": "†"})
_SUB = dict(zip("0123456789+-=()aehijklmnoprstuvx", "₀₁₂₃₄₅₆₇₈₉₊₋₌₍₎ₐₑₕᵢⱼₖₗₘₙₒₚᵣₛₜᵤᵥₓ"))
_SUB.update({",": ",", "−": "₋"})
_BIG = {"(": "(", ")": ")", "[": "[", "]": "]", ".": "", "|": "|", r"\|": "‖", r"\{": "{", r"\}": "}",
        r"\langle": "⟨", r"\rangle": "⟩", r"\lvert": "|", r"\rvert": "|", r"\Vert": "‖"}
_SIZERS = {"left", "right", "big", "Big", "bigg", "Bigg", "bigl", "bigr", "Bigl", "Bigr"}
_TOKEN = re.compile(r"\\[A-Za-z]+\*?|\\.|[{}^_&]|\s+|[^\\{}^_&\s]")


@dataclass
class Box:
    """A rendered piece: lines of equal width and the index of its baseline row."""
    lines: List[str]
    base: int = 0

    @property
    def width(self) -> int:
        return max((len(line) for line in self.lines), default=0)

    @property
    def flat(self) -> bool:
        return len(self.lines) == 1

    def text(self) -> str:
        return self.lines[self.base] if self.flat else " ".join(s.strip() for s in self.lines)


def _line(text: str) -> Box:
    return Box([text], 0)


def _hcat(boxes: List[Box]) -> Box:
    """Side by side, baselines aligned."""
    boxes = [b for b in boxes if b.lines and (b.width or not b.flat)]
    if not boxes:
        return _line("")
    above = max(b.base for b in boxes)
    below = max(len(b.lines) - b.base - 1 for b in boxes)
    rows = [""] * (above + below + 1)
    for b in boxes:
        w = b.width
        for r in range(len(rows)):
            k = r - (above - b.base)
            rows[r] += (b.lines[k].ljust(w) if 0 <= k < len(b.lines) else " " * w)
    return Box(rows, above)


class _Parser:
    def __init__(self, latex: str, display: bool):
        self.tokens = [t for t in _TOKEN.findall(latex)]
        self.i = 0
        self.display = display

    def peek(self):
        return self.tokens[self.i] if self.i < len(self.tokens) else None

    def take(self):
        tok = self.peek()
        self.i += 1
        return tok

    def group_tokens(self) -> Box:
        """One argument: a braced group or a single token."""
        while self.peek() is not None and self.peek().isspace():
            self.take()
        tok = self.peek()
        if tok == "{":
            self.take()
            box = self.sequence(("}",))
            self.take()
            return box
        if tok is None:
            return _line("")
        return self.atom()

    def raw_group(self) -> str:
        """A braced group's source text (for environment names and font arguments)."""
        while self.peek() is not None and self.peek().isspace():
            self.take()
        if self.peek() != "{":
            return self.take() or ""
        self.take()
        depth, out = 1, []
        while self.peek() is not None:
            tok = self.take()
            if tok == "{":
                depth += 1
            elif tok == "}":
                depth -= 1
                if depth == 0:
                    break
            out.append(tok)
        return "".join(out)

    def sequence(self, stops) -> Box:
        parts: List[Box] = []
        while self.peek() is not None and self.peek() not in stops:
            tok = self.peek()
            if tok in ("^", "_"):
                self.take()
                arg = self.group_tokens()
                while parts and parts[-1].lines == [" "]:
                    parts.pop()
                base = parts.pop() if parts else _line("")
                parts.append(_script(base, arg, tok))
                continue
            if tok.startswith(r"\end"):
                break
            parts.append(self.atom())
        return _hcat(parts)

    def atom(self) -> Box:
        tok = self.take()
        if tok is None:
            return _line("")
        if tok.isspace():
            return _line(" ")
        if tok == "{":
            box = self.sequence(("}",))
            self.take()
            return box
        if tok in ("&", "}"):
            return _line(" ")
        if tok == "'":
            return _line("′")
        if not tok.startswith("\\"):
            return _line(tok)
        name = tok[1:]
        if name in _SIZERS:
            delim = self.take() or ""
            if delim.startswith("\\") or delim in _BIG:
                return _line(_BIG.get(delim, _SYMBOLS.get(delim[1:], delim)))
            return _line(delim)
        if name == "frac" or name in ("dfrac", "tfrac"):
            num, den = self.group_tokens(), self.group_tokens()
            return _fraction(num, den)
        if name == "sqrt":
            arg = self.group_tokens()
            text = arg.text()
            return _line("√" + (text if _simple(text) else f"({text})"))
        if name in _ACCENTS:
            arg = self.group_tokens().text()
            return _line(_accent(arg, _ACCENTS[name]))
        if name in _FONTS:
            return _line(_plain_latex(self.raw_group()))
        if name == "mathbb":
            text = self.raw_group()
            return _line("".join(_BLACKBOARD.get(ch, ch) for ch in text))
        if name == "begin":
            return self.environment(self.raw_group())
        if name == "\\":
            return _line("; ")
        if name in _SYMBOLS:
            return _line(_SYMBOLS[name])
        return _line(name)

    def environment(self, env: str) -> Box:
        if env in ("array", "tabular"):
            self.raw_group()                       # column spec
        rows: List[List[Box]] = [[]]
        while self.peek() is not None:
            if self.peek().startswith(r"\end"):
                self.take()
                self.raw_group()
                break
            cell = self.sequence(("&", r"\\"))
            tok = self.peek()
            if tok is not None and tok.startswith(r"\end"):
                rows[-1].append(cell)
                continue
            self.take()
            rows[-1].append(cell)
            if tok == r"\\":
                rows.append([])
        rows = [r for r in rows if r and any(c.width for c in r)]
        delims = {"pmatrix": "()", "bmatrix": "[]", "vmatrix": "||", "Vmatrix": "‖‖", "cases": "{ "}
        return _grid(rows, delims.get(env, ""), self.display, aligned=env in ("array", "aligned", "align",
                                                                               "cases", "split"))


def _simple(text: str) -> bool:
    return bool(re.fullmatch(r"[\w.′̇̈]+", text))


def _accent(text: str, mark: str) -> str:
    if not text:
        return mark
    return text[0] + mark + text[1:]


def _script(base: Box, arg: Box, kind: str) -> Box:
    text = arg.text().strip()
    table = _SUP if kind == "^" else _SUB
    if text in ("T", "\u1d40") and kind == "^":
        return _hcat([base, _line("ᵀ")])
    short = len(text) <= 2 or text.isdigit()
    if text and short and all(ch in table for ch in text):
        return _hcat([base, _line("".join(table[ch] for ch in text))])
    if kind == "^" and text in ("′", "′′", "*", "†"):
        return _hcat([base, _line(text)])
    wrapped = text if _simple(text) else f"({text})"
    return _hcat([base, _line(("^" if kind == "^" else "_") + wrapped)])


def _fraction(num: Box, den: Box) -> Box:
    a, b = num.text().strip(), den.text().strip()
    vulgar = {("1", "2"): "½", ("1", "3"): "⅓", ("2", "3"): "⅔", ("1", "4"): "¼", ("3", "4"): "¾"}
    if (a, b) in vulgar:
        return _line(vulgar[(a, b)])
    a = a if _simple(a) else f"({a})"
    b = b if _simple(b) else f"({b})"
    return _line(f"{a}/{b}")


def _grid(rows: List[List[Box]], delims: str, display: bool, aligned: bool) -> Box:
    cells = [[_tidy_spaces(c.text()) for c in row] for row in rows]
    if not cells:
        return _line(delims[:1] + delims[1:2])
    if not display:
        sep = "; " if delims else ", "
        body = sep.join(", ".join(row) if not aligned else " ".join(row) for row in cells)
        left, right = (delims[0], delims[1].strip()) if delims else ("", "")
        return _line(f"{left}{body}{right}")
    ncol = max(len(r) for r in cells)
    widths = [max((len(r[j]) if j < len(r) else 0) for r in cells) for j in range(ncol)]
    lines = []
    for row in cells:
        padded = []
        for j in range(ncol):
            text = row[j] if j < len(row) else ""
            padded.append(text.rjust(widths[j]) if (aligned and j == 0 and ncol > 1) else text.ljust(widths[j]))
        lines.append((" " if aligned else "  ").join(padded).rstrip() if aligned else "  ".join(padded))
    width = max(len(s) for s in lines)
    lines = [s.ljust(width) for s in lines]
    n = len(lines)
    if not delims or delims == "{ ":
        left = ["{"] * n if delims and n == 1 else (["⎧"] + ["⎨" if k == n // 2 else "⎪" for k in range(1, n - 1)] + ["⎩"]
                                                    if delims and n > 1 else [""] * n)
        return Box([f"{l} {s}".rstrip() if l else s for l, s in zip(left, lines)], (n - 1) // 2)
    if n == 1:
        return Box([f"{delims[0]} {lines[0]} {delims[1]}"], 0)
    brackets = {"(": ("⎛", "⎜", "⎝"), ")": ("⎞", "⎟", "⎠"), "[": ("⎡", "⎢", "⎣"), "]": ("⎤", "⎥", "⎦"),
                "|": ("│", "│", "│"), "‖": ("‖", "‖", "‖")}
    lt, rt = brackets[delims[0]], brackets[delims[1]]
    out = []
    for k, s in enumerate(lines):
        pos = 0 if k == 0 else (2 if k == n - 1 else 1)
        out.append(f"{lt[pos]} {s} {rt[pos]}")
    return Box(out, (n - 1) // 2)


def _plain_latex(text: str) -> str:
    """Text inside \\text{...} and the like: drop braces and backslashes of escaped symbols."""
    return re.sub(r"\\([%$&#_{} ])", r"\1", text).replace("{", "").replace("}", "")


def latex_to_unicode(latex: str, display: bool = False) -> str:
    """A LaTeX formula as Unicode text; ``display`` lays matrices out over several lines.

    >>> latex_to_unicode(r"\\dot{q}_{1}^{2} \\cos{\\left(q_{1} \\right)} + \\frac{a}{b + c}")
    'q̇₁² cos(q₁) + a/(b + c)'
    >>> print(latex_to_unicode(r"M = \\left(\\begin{matrix}a & b\\\\c & d\\end{matrix}\\right)", display=True))
    M = ⎛ a  b ⎞
        ⎝ c  d ⎠
    """
    latex = re.sub(r"\\left\(\s*\\begin\{matrix\}", r"\\begin{pmatrix}", latex)
    latex = re.sub(r"\\end\{matrix\}\s*\\right\)", r"\\end{pmatrix}", latex)
    latex = re.sub(r"\\left\[\s*\\begin\{matrix\}", r"\\begin{bmatrix}", latex)
    latex = re.sub(r"\\end\{matrix\}\s*\\right\]", r"\\end{bmatrix}", latex)
    box = _Parser(latex, display).sequence(())
    if box.flat:
        return _tidy_spaces(box.lines[0])
    return "\n".join(s.rstrip() for s in box.lines)


def _tidy_spaces(text: str) -> str:
    """One space between words, none inside brackets' edges or before commas."""
    text = re.sub(r"(?<=\S) {3,}(?=\S)", "  ", text.strip())
    text = re.sub(r"(?<=[(\[{⟨]) +| +(?=[)\]}⟩,;])", "", text)
    text = re.sub(r"(^|[(\[]|, |= )- (?=\S)", r"\1-", text)
    return re.sub(r"(?<=[^ ]) (?= )(?! )", "", text) if "   " in text else text


def to_unicode(text: str) -> str:
    """A text with ``$...$`` segments for a terminal: each segment in Unicode math.

    >>> to_unicode(r"with $\\Lambda = K_D^{-1} K_P$ and $q_1 \\in [0, \\pi]$")
    'with Λ = K_D⁻¹ K_P and q₁ ∈ [0, π]'
    """
    return "".join(latex_to_unicode(piece) if is_math else piece for is_math, piece in split_math(text))


def to_markdown(text: str) -> str:
    """The text for Markdown with LaTeX math: ``$...$`` segments are Markdown's inline math already."""
    return text


# ---------------------------------------------------------------------- rules (the readability lint)
_RULES = [
    (re.compile(r"\{'|'\}|\['|'\]|': |\bNone\b(?! of\b)|\bTrue\b|\bFalse\b|<[a-z_]+ object|\bdict\(|\barray\("),
     "Python structure"),
    (re.compile(r"\\[A-Za-z]+|\\[\\{}]"), "raw LaTeX outside $...$"),
    (re.compile(r"(?<![<>=!])=(?!=)|<=|>=|->|=>|!="), "plain-text formula (=)"),
    (re.compile(r"\^"), "plain-text exponent or transpose (^)"),
    (re.compile(r"(?<=[A-Za-z0-9)\]])_(?=[A-Za-z0-9{(])"), "plain-text subscript (_)"),
    (re.compile(r"(?<=[A-Za-z0-9)\]])'(?![a-z])|(?<=[A-Za-z0-9)\]])'(?=s[A-Za-z0-9_'])"), "plain-text derivative (')"),
    (re.compile(r"\b(sqrt|sin|cos|tan|atan2|exp|det)\s*\("), "plain-text function call"),
    (re.compile(r"\|[^|\s][^|]{0,30}\|"), "plain-text absolute value or norm (|...|)"),
    (re.compile(r"(?<=[\w)])\s*\*\s*(?=[\w(])"), "plain-text product (*)"),
    (re.compile(r"(?<![\w.])\d+\s*/\s*\d+(?![\w.])|(?<=\w)/(?=\w)(?!s\b|s\^|rad\b|m\b)"), "plain-text fraction (/)"),
]
_NUMBER_RULES = [
    (re.compile(r"(?<![\w.])\d+(\.\d+)?[eE][-+]?\d+\b"), "number in exponent notation (round it)"),
    (re.compile(r"(?<![\w.])\d*\.\d{7,}"), "number with more than 6 decimals (round it)"),
    (re.compile(r"10\^\{-1[0-9]\}"), "round-off noise (10^-1x)"),
]
_PATHS = re.compile(r"`[^`]*`|\b[\w./-]+\.(?:py|md|yaml|txt)\b")   # file names and `code` are not formulas
_UNIT_SLASH = re.compile(r"\b(m|rad|cm|mm|N|N m|kg m|deg|km)/(s|s\^2|s²|rad|m)\b|\b(and|or)/(or|and)\b")


def problems(text: str, where: str = "text") -> List[str]:
    """What breaks the readability convention in a step's or note's text (empty when none).

    ``where`` is "text" (sentences with ``$...$`` math, also titles and notes) or "latex" (a
    formula: only the number rules apply).

    >>> problems("Rows x, y of {'body': 'link1'}")
    ['Python structure outside $...$: "Rows x, y of {\\'body\\': \\'link1\\'}"']
    >>> problems(r"Collect $T = \\frac{1}{2} \\dot q^T M \\dot q$; rounding 1e-09 is fine.")
    ['number in exponent notation (round it): "Collect $T = \\\\frac{1}{2} \\\\dot q^T M \\\\dot q$; rounding 1e-09 is fine."']
    >>> problems("the robot's joints, q2'' is the acceleration")
    ['plain-text derivative (\\') outside $...$: "the robot\\'s joints, q2\\'\\' is the acceleration"']
    """
    found: List[str] = []
    if where == "text":
        if _DOLLAR.findall(text).__len__() % 2:
            found.append(f'unbalanced $: "{text}"')
        for is_math, piece in split_math(text):
            bare = re.sub(r"\\[{}]|\\[lr]?[vV]ert|\\[|]", "", piece)
            if is_math and any(bare.count(a) != bare.count(b) for a, b in ("()", "[]", "{}")) \
                    and not re.search(r"\\left|\\right|\\in|[\[(]\s*-?\S+,\s*\S+\s*[\])]", piece):
                found.append(f'unbalanced brackets inside ${piece}$: "{text}"')
        outside = _PATHS.sub(" ", _UNIT_SLASH.sub(" ", plain_parts(text)))
        for rule, what in _RULES:
            if rule.search(outside):
                found.append(f'{what} outside $...$: "{text}"')
    for rule, what in _NUMBER_RULES[:2] if where == "text" else _NUMBER_RULES:
        if rule.search(text):
            found.append(f'{what}: "{text}"')
    return found


RULE = ("Text shown to users (step titles and texts, notes) is plain sentences; every formula, "
        "subscripted symbol, derivative (q'), exponent (^), product (*), fraction (1/2), norm (|v|), "
        "equation (=, <=) and function call (sin(q)) goes between $...$ as LaTeX "
        "(e.g. \"$T = \\frac{1}{2}\\dot q^T M(q) \\dot q$\"); no Python structures (dicts, lists, None); "
        "numbers rounded (no 1e-09, no 0.666666666666667). Formulas of the `latex` field are rounded too. "
        "See app/core/mathtext.py and docs/exercise-format.md (\"Text and math\").")


def symbols_text(names, coordinates=()) -> str:
    """Names of symbols for a sentence, each typeset: ``"$d_{c1}$, $l_{2}$"`` ("none" when empty).

    >>> symbols_text(["d_c1", "l2"])
    '$d_{c1}$, $l_{2}$'
    """
    from .steps import symbol_latex
    names = list(names)
    return ", ".join(f"${symbol_latex(str(n), coordinates)}$" for n in names) if names else "none"
