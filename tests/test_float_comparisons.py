"""No exact comparison of computed floats in the tests or in the doctests of app/.

Another CPU, BLAS or compiler may round a computed float differently in its last bits, so a test
that passes here can fail there. The rule (README, Correctness), checked on the syntax tree:

- tests/**/*.py and every doctest example in app/: no ``==`` / ``!=`` against a float literal (also
  inside a tuple or list: ``x.tolist() == [0.5, 1.0]``), against ``round(...)``, or against an
  expression that is a float by its form (``float(...)``, a division, ``math.sqrt(...)``,
  ``np.pi`` ...); no ``np.array_equal`` / ``assert_array_equal`` / ``assert_equal`` on such values.
  Compare with ``pytest.approx``, ``np.allclose`` or ``numpy.testing.assert_allclose``.
- doctests: an example whose expected output shows a float (outside a quoted string, which the
  code under test formatted itself) formats it in the example (``round``, ``.round``, ``np.round``,
  an f-string or ``format`` with a precision), so the printed text cannot flip; a value that is
  exact by construction (parsed from text, set to a constant, sums of 0 and 1) may be printed as
  it is when the example says so in a comment containing the word ``exact``.

A quantity that is exact by construction in the code (a landing height set to 0, a first sample
time set to 0) may be checked exactly against an integer (``== 0``): that is the code's promise.
The check sees the form only: ``a == b`` between two plain names is not flagged (it cannot know
their types), so keep such comparisons to values exact by construction.
"""
from __future__ import annotations

import ast
import doctest
import re
from pathlib import Path
from typing import Iterator, List, Optional, Tuple

import pytest

ROOT = Path(__file__).resolve().parents[1]

#: functions whose result is a float (math.*, numpy's elementwise and reductions)
FLOAT_FUNCTIONS = {"sqrt", "sin", "cos", "tan", "arcsin", "arccos", "arctan", "arctan2", "asin", "acos", "atan",
                   "atan2", "exp", "expm1", "log", "log1p", "log10", "log2", "hypot", "degrees", "radians",
                   "norm", "det", "mean", "average", "std", "var", "cbrt", "sinh", "cosh", "tanh", "trace",
                   "dot", "linspace", "interp", "trapezoid", "trapz", "fsum", "pinv", "inv", "solve"}
FLOAT_CONSTANTS = {"pi", "e", "tau", "inf", "nan"}
ROUNDING = {"round", "around"}
ARRAY_EQUAL = {"array_equal", "assert_array_equal", "assert_equal", "array_equiv"}
WRAPPERS = {"tolist", "item", "list", "tuple", "array", "asarray", "float64"}


def _name(func: ast.AST) -> str:
    """Last part of a called name: ``np.linalg.norm`` -> ``norm``, ``round`` -> ``round``."""
    if isinstance(func, ast.Attribute):
        return func.attr
    return func.id if isinstance(func, ast.Name) else ""


def _is_approx(node: ast.AST) -> bool:
    return isinstance(node, ast.Call) and _name(node.func) in ("approx", "ApproxBase")


def float_literal(node: ast.AST) -> bool:
    """A float literal, possibly signed, or a tuple/list/set/array display holding one."""
    if isinstance(node, ast.Constant):
        return isinstance(node.value, (float, complex))
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
        return float_literal(node.operand)
    if isinstance(node, (ast.Tuple, ast.List, ast.Set)):
        return any(float_literal(e) for e in node.elts)
    if isinstance(node, ast.Call) and _name(node.func) in WRAPPERS and node.args:
        return float_literal(node.args[0])
    return False


def rounded(node: ast.AST) -> bool:
    """``round(x, n)``, ``np.round(x)``, ``x.round(n)`` anywhere in the expression."""
    return any(isinstance(n, ast.Call) and _name(n.func) in ROUNDING for n in ast.walk(node))


def float_by_form(node: ast.AST) -> bool:
    """An expression whose value is a float whatever its inputs: float(...), a true division (not a
    path joined with a text, ``folder / "name"``), a
    float function or constant of math/numpy, or arithmetic with any of these or a float literal."""
    if float_literal(node):
        return True
    if isinstance(node, ast.BinOp):
        path_join = any(isinstance(side, ast.Constant) and isinstance(side.value, str) for side in (node.left, node.right))
        return (isinstance(node.op, ast.Div) and not path_join) or float_by_form(node.left) or float_by_form(node.right)
    if isinstance(node, ast.UnaryOp):
        return float_by_form(node.operand)
    if isinstance(node, ast.Call):
        name = _name(node.func)
        if name == "float" or name in FLOAT_FUNCTIONS:
            return True
        return name in WRAPPERS and bool(node.args) and float_by_form(node.args[0]) or (
            isinstance(node.func, ast.Attribute) and name in WRAPPERS and float_by_form(node.func.value))
    if isinstance(node, ast.Attribute):
        return node.attr in FLOAT_CONSTANTS and isinstance(node.value, ast.Name) and node.value.id in ("math", "np", "numpy")
    return False


def _why(node: ast.AST) -> Optional[str]:
    if float_literal(node):
        return "against a float literal"
    if rounded(node):
        return "through round()"
    if float_by_form(node):
        return "against a computed float"
    return None


def exact_comparisons(tree: ast.AST) -> Iterator[Tuple[int, str]]:
    """(line offset, message) of every exact float comparison in a syntax tree."""
    for node in ast.walk(tree):
        if isinstance(node, ast.Compare):
            operands = [node.left, *node.comparators]
            for op, a, b in zip(node.ops, operands, operands[1:]):
                if not isinstance(op, (ast.Eq, ast.NotEq)) or _is_approx(a) or _is_approx(b):
                    continue
                why = _why(a) or _why(b)
                if why:
                    yield node.lineno, f"`{ast.unparse(node)}` compares exactly {why}"
                    break
        elif isinstance(node, ast.Call) and _name(node.func) in ARRAY_EQUAL:
            why = next((w for w in map(_why, node.args) if w), None)
            if why:
                yield node.lineno, f"`{ast.unparse(node)}` compares arrays exactly {why}"


# ---------------------------------------------------------------------------- doctests
STRING = re.compile(r"'(?:[^'\\\n]|\\.)*'|\"(?:[^\"\\\n]|\\.)*\"")
FLOAT_TEXT = re.compile(r"(?<![\w.])[-+]?(?:\d+\.\d*|\.\d+)(?:[eE][-+]?\d+)?(?![\w.])|(?<![\w.])\d+[eE][-+]?\d+(?![\w.])")
EXACT_NOTE = re.compile(r"#.*\bexact", re.IGNORECASE)


def formats(node: ast.AST) -> bool:
    """Does the expression round or format (to a precision) what it prints?"""
    for n in ast.walk(node):
        if isinstance(n, ast.Call) and _name(n.func) in ROUNDING | {"format", "printoptions", "set_printoptions"}:
            return True
        if isinstance(n, ast.FormattedValue) and n.format_spec is not None:
            return True
        if isinstance(n, ast.BinOp) and isinstance(n.op, ast.Mod) and isinstance(n.left, ast.Constant) \
                and isinstance(n.left.value, str):
            return True
    return False


def shows_float(want: str) -> bool:
    """Does the expected output show a float outside quoted strings?"""
    try:
        tree = ast.parse(want.strip(), mode="eval")
    except SyntaxError:
        return bool(FLOAT_TEXT.search(STRING.sub("''", want)))
    return any(isinstance(n, ast.Constant) and isinstance(n.value, float) for n in ast.walk(tree))


def _elements(source: str, want: str) -> List[Tuple[ast.AST, str]]:
    """Pairs (expression, its expected text): per element when both are tuples of one length."""
    try:
        expr = ast.parse(source.strip(), mode="eval").body
        out = ast.parse(want.strip(), mode="eval").body
    except SyntaxError:
        return []
    if isinstance(expr, ast.Tuple) and isinstance(out, ast.Tuple) and len(expr.elts) == len(out.elts):
        return [(e, ast.unparse(o)) for e, o in zip(expr.elts, out.elts)]
    return [(expr, want)]


def unformatted_floats(example: doctest.Example) -> Optional[str]:
    """Why a doctest example prints a float that could flip, or None."""
    if example.exc_msg is not None or not shows_float(example.want) or EXACT_NOTE.search(example.source):
        return None
    pairs = _elements(example.source, example.want)
    if not pairs:                                     # a statement (print(...)) or text output
        try:
            tree = ast.parse(example.source)
        except SyntaxError:
            return "prints a float (cannot read the example)"
        return None if formats(tree) else f"prints {example.want.strip()[:60]!r} unformatted (format it)"
    for expr, want in pairs:
        if shows_float(want) and not formats(expr):
            return (f"prints {want.strip()[:60]!r} from `{ast.unparse(expr)[:60]}` unformatted (format it, "
                    f"e.g. f\"{{x:.4f}}\" or round(x, 4), or say in a comment why it is exact)")
        if shows_zero(want) and not pins_zero_sign(expr):
            return (f"prints a rounded zero in {want.strip()[:60]!r} from `{ast.unparse(expr)[:60]}`: a tiny "
                    f"negative value rounds to -0.0 (add 0.0 after rounding, or compare abs(x) < tol)")
    return None


def shows_zero(want: str) -> bool:
    """Does the expected output (parsed as Python) show the float 0.0 outside strings?"""
    try:
        tree = ast.parse(want.strip(), mode="eval")
    except SyntaxError:
        return False
    return any(isinstance(n, ast.Constant) and isinstance(n.value, float) and n.value == 0 for n in ast.walk(tree))


def pins_zero_sign(node: ast.AST) -> bool:
    """``... + 0.0`` (turns -0.0 into 0.0) or ``abs(...)`` around what is printed."""
    return any(isinstance(n, ast.BinOp) and isinstance(n.op, ast.Add) and float_literal(n.right)
               or isinstance(n, ast.Call) and _name(n.func) in ("abs", "fabs", "absolute") for n in ast.walk(node))


def doctest_examples(path: Path) -> Iterator[Tuple[int, doctest.Example]]:
    """(line, example) of every doctest example in the docstrings of one module."""
    tree = ast.parse(path.read_text(), filename=str(path))
    parser = doctest.DocTestParser()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)) and node.body:
            first = node.body[0]
            if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant) and isinstance(first.value.value, str):
                for ex in parser.get_examples(first.value.value):
                    yield first.lineno + ex.lineno, ex


def _rel(path: Path) -> str:
    return str(path.relative_to(ROOT))


def problems_in_tests() -> List[str]:
    out = []
    for path in sorted((ROOT / "tests").rglob("*.py")):
        tree = ast.parse(path.read_text(), filename=str(path))
        out += [f"{_rel(path)}:{line}: {msg}" for line, msg in exact_comparisons(tree)]
    return out


def problems_in_doctests() -> List[str]:
    out = []
    for path in sorted((ROOT / "app").rglob("*.py")):
        for line, ex in doctest_examples(path):
            try:
                tree = ast.parse(ex.source)
            except SyntaxError:
                tree = None
            if tree is not None:
                out += [f"{_rel(path)}:{line + off - 1}: {msg}" for off, msg in exact_comparisons(tree)]
            why = unformatted_floats(ex)
            if why:
                out.append(f"{_rel(path)}:{line}: doctest {why}")
    return out


def test_no_exact_float_comparison_in_the_tests():
    found = problems_in_tests()
    assert not found, "exact float comparisons (use pytest.approx / np.allclose):\n" + "\n".join(found)


def test_no_exact_float_comparison_or_unformatted_float_in_the_doctests():
    found = problems_in_doctests()
    assert not found, "doctests that can flip on another CPU:\n" + "\n".join(found)


# ---------------------------------------------------------------------------- the check itself
EQ = "=" * 2      # the samples below spell == as EQ, so that a plain grep of tests/ does not take them for tests


@pytest.mark.parametrize("source", [
    "assert x EQ 0.0", "assert ball[1] != -1.5", "assert round(t, 3) EQ 0.289", "assert t EQ round(u, 2)",
    "assert x.tolist() EQ [1.0, 0.5]", "assert (a, b) EQ (0.198, 2)", "assert np.all(res.tau EQ 0.0)",
    "assert a EQ b EQ 0.0", "assert x / 3 EQ y", "assert float(s) EQ t", "assert math.sqrt(2) EQ r",
    "assert np.linalg.norm(v) EQ n", "assert x EQ np.pi / 2", "np.testing.assert_array_equal(a, [0.5, 1.0])",
    "assert np.array_equal(np.round(a, 3), b)", "wait_until(lambda: s.k EQ 40.0)", "assert x.round(4).tolist() EQ w",
])
def test_the_check_finds_exact_float_comparisons(source):
    source = source.replace("EQ", EQ)
    assert list(exact_comparisons(ast.parse(source))), source


@pytest.mark.parametrize("source", [
    "assert x == pytest.approx(0.5)", "assert len(x) == 3", "assert proc.returncode == 2", "assert s == '0.5 m'",
    "assert t[0] == 0", "assert a.kind == b.kind", "assert shape == (3, 4)", "assert x <= 0.5",
    "assert np.allclose(x, 0.5)", "assert out == {'a': 1}", "assert f'{x:.3f}' == '0.289'",
    "np.testing.assert_array_equal(order, [2, 0, 1])", "assert x is None",
])
def test_the_check_lets_exact_comparisons_of_other_kinds_pass(source):
    assert not list(exact_comparisons(ast.parse(source))), source


@pytest.mark.parametrize("source, want, flagged", [
    ("s", "0.5", True),
    ("round(s, 3)", "0.5", False),
    ("f'{s:.3f}'", "'0.500'", False),
    ("np.round(out.dq, 3).tolist(), out.scale", "([-1.0, 0.536], 1.0)", True),
    ("np.round(out.dq, 3).tolist(), out.scale   # exact: clamped at 1", "([-1.0, 0.536], 1.0)", False),
    ("a.rank, a.null_space.shape", "(1, (4, 3))", False),
    ("describe(ref)", "'quintic goal=1.570796327 T=2'", False),
    ("print(x)", "0.30000000000000004", True),
    ("print(f'{x:.2f}')", "0.30", False),
    ("arr", "array([0.5])", True),
    ("np.round(r.error, 4).tolist()", "[0.0, 0.5]", True),
    ("(np.round(r.error, 4) + 0.0).tolist()", "[0.0, 0.5]", False),
    ("round(x, 4)", "-0.0", True),
])
def test_the_doctest_check_finds_unformatted_floats(source, want, flagged):
    example = doctest.Example(source + "\n", want + "\n")
    assert bool(unformatted_floats(example)) == flagged, (source, want)
