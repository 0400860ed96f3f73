"""Safe, bounded parsing of user and file expressions into sympy, through a whitelist of ``ast``.

Nothing here calls ``eval``, ``sympify`` or ``parse_expr`` on text: the text is parsed by
``ast.parse`` and every node is checked against a whitelist before a sympy object is built.
The parse is bounded, so that no short text can freeze the process: the text's length, its number
of nodes, its nesting depth, the size of numbers and of numeric powers, and the number of terms the
expression would expand to are limited (``Bounds``). Numbers must come out real and finite.

>>> parse_expression("m1*d1**2 + I1", {"m1", "d1", "I1"})
I1 + d1**2*m1
>>> parse_expression("((((9**64)**64)**64)**64)", field="mass")
Traceback (most recent call last):
...
app.core.expressions.ExpressionError: mass: number too large (beyond 1e308) in '((((9**64)**64)**64)**64)'
"""
from __future__ import annotations

import ast
import math
import threading
from dataclasses import dataclass
from typing import Iterable, Mapping, Optional

import sympy as sp

from .errors import UserError, excerpt


class ExpressionError(UserError):
    """An expression could not be parsed; the message says where and why."""


_FUNCTIONS = {
    "sin": sp.sin, "cos": sp.cos, "tan": sp.tan, "atan2": sp.atan2, "atan": sp.atan,
    "asin": sp.asin, "acos": sp.acos, "sqrt": sp.sqrt, "exp": sp.exp, "log": sp.log,
    "Abs": sp.Abs, "abs": sp.Abs, "sign": sp.sign,
    "min": sp.Min, "max": sp.Max, "Min": sp.Min, "Max": sp.Max,
}
#: number of arguments of each function (None: one or more)
_ARITY = {"atan2": 2, "min": None, "max": None, "Min": None, "Max": None}
_CONSTANTS = {"pi": sp.pi, "E": sp.E}
_MAX_FLOAT_EXPONENT = 1024          # numbers beyond 2**1024 (about 1.8e308) are refused


@dataclass(frozen=True)
class Bounds:
    """Limits of one parse: characters, ``ast`` nodes, nesting depth (a chain of the same operator,
    ``a + b + c``, counts as one level), the largest integer exponent of a symbolic base, and the
    number of terms the expression may expand to (``(a + b)**3`` expands to 4 terms)."""
    length: int = 2000
    nodes: int = 2000
    depth: int = 60
    exponent: int = 64
    expanded_terms: int = 20000


USER_BOUNDS = Bounds()


def symbol(name: str) -> sp.Symbol:
    """The one sympy symbol used for a name everywhere in the lab (all symbols are real).

    >>> symbol("q1").is_real
    True
    """
    return sp.Symbol(name, real=True)


def _fail(field: str, message: str) -> ExpressionError:
    return ExpressionError(f"{field}: {message}" if field else message)


def _non_ascii(source: str) -> Optional[str]:
    for position, char in enumerate(source):
        if ord(char) > 127:
            return f"non-ASCII character {char!r} (U+{ord(char):04X}) at position {position + 1}; " \
                   f"use plain letters, digits and operators"
    return None


def is_finite_real(value: sp.Expr) -> bool:
    """True when a sympy number is real and finite with a magnitude below about 1.8e308.

    >>> is_finite_real(sp.sqrt(2)), is_finite_real(sp.sqrt(-1)), is_finite_real(sp.acos(2))
    (True, False, False)
    """
    if value.is_Integer:
        return abs(int(value)).bit_length() <= _MAX_FLOAT_EXPONENT
    if value.is_Rational:
        return abs(value.p // value.q).bit_length() <= _MAX_FLOAT_EXPONENT
    if value.is_Float:
        return math.isfinite(float(value))
    if value.is_extended_real is False or value.is_finite is False or value is sp.nan:
        return False
    try:
        number = complex(value.evalf(20))
    except (TypeError, ValueError, OverflowError, ZeroDivisionError):
        return False
    return math.isfinite(number.real) and abs(number.imag) <= 1e-12 * max(1.0, abs(number.real))


def _multinomial_terms(terms: int, exponent: int, cap: int) -> int:
    """Number of terms of (t_1 + ... + t_terms)**exponent expanded, or cap + 1 when larger."""
    if terms <= 1 or exponent <= 1:
        return terms if exponent else 1
    count = 1
    for k in range(1, terms):          # C(exponent + terms - 1, terms - 1), stopped above the cap
        count = count * (exponent + k) // k
        if count > cap:
            return cap + 1
    return count


class _Reader:
    """One bounded parse: an iterative check of the tree's shape, then a build that flattens chains
    of the same operator (so a 1,000-term sum costs one level, not 1,000)."""

    def __init__(self, text: str, allowed, extra, field: str, bounds: Bounds):
        self.text, self.field, self.bounds = text, field, bounds
        self.allowed = None if allowed is None else set(allowed)
        self.extra = dict(extra or {})

    def fail(self, message: str) -> ExpressionError:
        return _fail(self.field, f"{message} in {excerpt(self.text)}")

    # ---------------------------------------------------------------- shape
    def check_shape(self, tree: ast.AST) -> None:
        stack = [(tree, 0, None)]
        nodes = 0
        while stack:
            node, depth, parent_op = stack.pop()
            nodes += 1
            if nodes > self.bounds.nodes:
                raise self.fail(f"expression too long (more than {self.bounds.nodes} elements)")
            op = _chain_kind(node)
            level = depth if op is not None and op == parent_op else depth + 1
            if level > self.bounds.depth:
                raise self.fail(f"expression nested too deeply (more than {self.bounds.depth} levels)")
            for child in ast.iter_child_nodes(node):
                if not isinstance(child, (ast.operator, ast.unaryop, ast.expr_context)):
                    stack.append((child, level, op))

    # ---------------------------------------------------------------- build
    def build(self, node: ast.AST):
        """(sympy expression, number of terms it expands to)."""
        if isinstance(node, ast.Expression):
            return self.build(node.body)
        if isinstance(node, ast.Constant):
            return self.constant(node.value)
        if isinstance(node, ast.Name):
            return self.name(node.id), 1
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.UAdd, ast.USub)):
            operand, size = self.build(node.operand)
            return (operand if isinstance(node.op, ast.UAdd) else -operand), size
        if isinstance(node, ast.BinOp) and isinstance(node.op, (ast.Add, ast.Sub)):
            return self.sum(node)
        if isinstance(node, ast.BinOp) and isinstance(node.op, (ast.Mult, ast.Div)):
            return self.product(node)
        if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Pow):
            return self.power(node)
        if isinstance(node, ast.BinOp):
            raise self.fail(f"operator {type(node.op).__name__} not allowed")
        if isinstance(node, ast.Call):
            return self.call(node)
        raise self.fail(f"'{_shown(node)}' is not allowed")

    def constant(self, value):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise self.fail(f"unexpected constant {excerpt(value, 20)}")
        if isinstance(value, float):
            if not math.isfinite(value):
                raise self.fail("non-finite number")
            return (sp.Integer(int(value)) if value == int(value) else sp.Float(value)), 1
        if value.bit_length() > _MAX_FLOAT_EXPONENT:
            raise self.fail("number too large (beyond 1e308)")
        return sp.Integer(value), 1

    def name(self, name: str) -> sp.Expr:
        if name in self.extra:
            return self.extra[name]
        if name in _CONSTANTS:
            return _CONSTANTS[name]
        if self.allowed is not None and name not in self.allowed:
            raise self.fail(f"unknown name '{name}'")
        return symbol(name)

    def checked(self, value: sp.Expr) -> sp.Expr:
        if value.is_number and not is_finite_real(value):
            if value.is_finite is not False and value.is_extended_real is not False \
                    and value not in (sp.nan, sp.zoo) and _too_large(value):
                raise self.fail("number too large (beyond 1e308)")
            raise self.fail(f"the value {_shown_value(value)} is not a real, finite number")
        return value

    @staticmethod
    def unchain(node, ops) -> list:
        """The operands of a left-nested chain ``a op b op c`` as [(None, a), (op, b), (op, c)]."""
        parts = []
        while isinstance(node, ast.BinOp) and isinstance(node.op, ops):
            parts.append((node.op, node.right))
            node = node.left
        return [(None, node)] + parts[::-1]

    def sum(self, node):
        terms, size = [], 0
        for op, operand in self.unchain(node, (ast.Add, ast.Sub)):
            value, n = self.build(operand)
            terms.append(-value if isinstance(op, ast.Sub) else value)
            size += n
        if size > self.bounds.expanded_terms:
            raise self.fail("expression too large when expanded")
        return self.checked(sp.Add(*terms)), size

    def product(self, node):
        factors, size = [], 1
        for op, operand in self.unchain(node, (ast.Mult, ast.Div)):
            value, n = self.build(operand)
            if isinstance(op, ast.Div):
                if value == 0:
                    raise self.fail("division by zero")
                value = self.checked(sp.Pow(value, -1))
            factors.append(value)
            size *= n
            if size > self.bounds.expanded_terms:
                raise self.fail("expression too large when expanded")
        return self.checked(sp.Mul(*factors)), size

    def power(self, node):
        base, size = self.build(node.left)
        exponent, exp_size = self.build(node.right)
        if exponent.is_number:
            if base.is_number:
                self.check_numeric_power(base, exponent)
            elif abs(float(exponent)) > self.bounds.exponent:
                raise self.fail(f"exponent larger than {self.bounds.exponent} of a symbolic expression")
            if exponent.is_Integer:
                size = _multinomial_terms(size, abs(int(exponent)), self.bounds.expanded_terms)
        else:
            size += exp_size
        if size > self.bounds.expanded_terms:
            raise self.fail("expression too large when expanded")
        if base == 0 and exponent.is_number and exponent.is_extended_negative:
            raise self.fail("division by zero (0 to a negative power)")
        return self.checked(sp.Pow(base, exponent)), size

    def check_numeric_power(self, base: sp.Expr, exponent: sp.Expr) -> None:
        """Refuse a numeric power whose result would be beyond 1e308 before computing it."""
        magnitude = abs(complex(base.evalf(15)))
        power = float(exponent)
        if magnitude == 0 or magnitude == 1:
            return
        if power * math.log2(magnitude) > _MAX_FLOAT_EXPONENT:
            raise self.fail("number too large (beyond 1e308)")
        if exponent.is_Rational and exponent.q > 64:
            raise self.fail("fractional exponent with a denominator above 64")

    def call(self, node):
        if not isinstance(node.func, ast.Name) or node.keywords:
            raise self.fail("only plain function calls are allowed")
        name = node.func.id
        if name not in _FUNCTIONS:
            raise self.fail(f"unknown function '{name}'")
        built = [self.build(arg) for arg in node.args]
        expected = _ARITY.get(name, 1)
        if expected is None and not built:
            raise self.fail(f"{name} takes at least one argument")
        if expected is not None and len(built) != expected:
            raise self.fail(f"{name} takes {expected} argument(s)")
        args = [value for value, _size in built]
        size = sum(n for _value, n in built)
        if name == "atan2" and all(a == 0 for a in args):
            raise self.fail("atan2(0, 0) is undefined")
        return self.checked(_FUNCTIONS[name](*args)), size


def _too_large(value: sp.Expr) -> bool:
    try:
        return not math.isfinite(abs(complex(value.evalf(15))))
    except (TypeError, ValueError, OverflowError):
        return False


def _shown_value(value: sp.Expr) -> str:
    text = str(value)
    return text if len(text) <= 40 else text[:37] + "..."


def _chain_kind(node: ast.AST) -> Optional[str]:
    """'sum' or 'product' for the operators that chain flat, None otherwise."""
    if isinstance(node, ast.BinOp):
        if isinstance(node.op, (ast.Add, ast.Sub)):
            return "sum"
        if isinstance(node.op, (ast.Mult, ast.Div)):
            return "product"
    return None


def _shown(node: ast.AST) -> str:
    try:
        text = ast.unparse(node)
    except (ValueError, RecursionError):  # pragma: no cover - unparse of an already parsed tree
        text = type(node).__name__
    return text if len(text) <= 40 else text[:37] + "..."


def parse_expression(text, allowed_names: Iterable[str] | None = None,
                     extra: Mapping[str, sp.Basic] | None = None, *, field: str = "",
                     bounds: Bounds = USER_BOUNDS) -> sp.Expr:
    """Parse ``text`` (a string or a number) into a sympy expression.

    Only numbers, the names in ``allowed_names`` (or any identifier when it is None), ``pi``,
    ``E``, the arithmetic operators ``+ - * / **`` and the functions sin, cos, tan, atan2, atan,
    asin, acos, sqrt, exp, log, abs, sign, min, max are accepted. ``^`` is read as a power.
    ``field`` names the input in messages. Numbers must be real and finite.

    >>> parse_expression("2*pi/3")
    2*pi/3
    >>> parse_expression("max(1, 3/2) - abs(-2)")
    -1/2
    >>> parse_expression("__import__('os')")
    Traceback (most recent call last):
    ...
    app.core.expressions.ExpressionError: unknown function '__import__' in "__import__('os')"
    >>> parse_expression("acos(2)", field="q1")
    Traceback (most recent call last):
    ...
    app.core.expressions.ExpressionError: q1: the value acos(2) is not a real, finite number in 'acos(2)'
    """
    if isinstance(text, bool):
        raise _fail(field, f"expected a number or an expression, got {text!r}")
    if isinstance(text, int):
        if text.bit_length() > _MAX_FLOAT_EXPONENT:
            raise _fail(field, "number too large (beyond 1e308)")
        return sp.Integer(text)
    if isinstance(text, float):
        if not math.isfinite(text):
            raise _fail(field, f"expected a finite number, got {text!r}")
        return sp.Float(text)
    if isinstance(text, sp.Basic):
        return text
    if not isinstance(text, str):
        raise _fail(field, f"expected a number or an expression, got {type(text).__name__} {excerpt(text, 40)}")
    source = text.strip()
    if not source:
        raise _fail(field, "empty expression")
    if len(source) > bounds.length:
        raise _fail(field, f"expression longer than {bounds.length} characters")
    problem = _non_ascii(source)
    if problem:
        raise _fail(field, f"{problem} in {excerpt(source)}")
    source = source.replace("^", "**")
    reader = _Reader(text, allowed_names, extra, field, bounds)
    try:
        tree = _ast_parse(source)
    except SyntaxError as exc:
        raise _fail(field, f"syntax error in {excerpt(text)}: {exc.msg}") from None
    except (RecursionError, MemoryError, ValueError):
        raise reader.fail("expression nested too deeply or too long") from None
    reader.check_shape(tree)
    try:
        value, _size = reader.build(tree)
    except RecursionError:   # pragma: no cover - the shape check keeps the build shallow
        raise reader.fail("expression nested too deeply") from None
    return value


def parse_number(text, what: str = "") -> float:
    """Parse a plain numeric value (expressions of constants allowed), or raise ExpressionError
    (its message starts with ``what``, the input's name, when one is given). The one rule for
    numbers read from user text: use it rather than ``float(parse_expression(...))``.

    >>> f"{parse_number('pi/2'):.12f}"
    '1.570796326795'
    >>> parse_number("abc", "mass")
    Traceback (most recent call last):
    ...
    app.core.expressions.ExpressionError: mass: unknown name 'abc' in 'abc'
    """
    expr = parse_expression(text, allowed_names=(), field=what)
    return float(expr)


# ---------------------------------------------------------------------------- exact text
# The derivation cache stores expressions as text that rebuilds the very same sympy tree (same
# arguments in the same order, so the same printing), read back through the same ``ast`` whitelist:
# heads Add, Mul, Pow, Rational, Float and the functions above, names, integers and floats.
_EXACT_CLASSES = {sp.Add: "Add", sp.Mul: "Mul", sp.Pow: "Pow", sp.sin: "sin", sp.cos: "cos", sp.tan: "tan",
                  sp.asin: "asin", sp.acos: "acos", sp.atan: "atan", sp.atan2: "atan2", sp.exp: "exp",
                  sp.log: "log", sp.Abs: "Abs", sp.sign: "sign", sp.Min: "Min", sp.Max: "Max"}
_EXACT_HEADS = {name: cls for cls, name in _EXACT_CLASSES.items()}
_EXACT_CONSTANTS = {sp.pi: "pi", sp.E: "E"}
_EXACT_DEPTH = 200


class NotStorable(ValueError):
    """An expression holds something the exact text cannot carry (it is then not cached)."""


def dump_exact(expr: sp.Basic) -> str:
    """Text that ``load_exact`` turns back into an identical sympy tree.

    >>> x = symbol("x")
    >>> text = dump_exact(sp.Mul(sp.Rational(1, 2), x + 1, evaluate=False))
    >>> text
    'Mul(Rational(1, 2), Add(1, x))'
    >>> load_exact(text) == sp.Mul(sp.Rational(1, 2), x + 1, evaluate=False)
    True
    """
    out: list = []
    _dump(sp.sympify(expr), out)
    return "".join(out)


def _dump(expr, out: list) -> None:
    if expr.is_Symbol:
        if not (expr.name.isascii() and expr.name.isidentifier()) or expr.name in _EXACT_HEADS \
                or expr.name in _CONSTANTS or expr.assumptions0 != symbol(expr.name).assumptions0:
            raise NotStorable(f"symbol {expr.name!r}")
        out.append(expr.name)
    elif expr.is_Integer:
        out.append(str(int(expr)))
    elif expr.is_Rational:
        out.append(f"Rational({expr.p}, {expr.q})")
    elif expr.is_Float:
        value = float(expr)
        if expr._prec != 53 or not math.isfinite(value) or sp.Float(value) != expr:
            raise NotStorable(f"float {expr}")
        out.append(f"Float({value!r})")
    elif expr in _EXACT_CONSTANTS:
        out.append(_EXACT_CONSTANTS[expr])
    elif type(expr) in _EXACT_CLASSES:
        out.append(_EXACT_CLASSES[type(expr)] + "(")
        for i, arg in enumerate(expr.args):
            if i:
                out.append(", ")
            _dump(arg, out)
        out.append(")")
    else:
        raise NotStorable(f"{type(expr).__name__} {excerpt(str(expr), 40)}")


def load_exact(text: str, max_length: int = 50_000_000) -> sp.Expr:
    """Rebuild an expression written by ``dump_exact`` (unevaluated: the tree is taken as written),
    or raise ExpressionError on anything outside the exact text's whitelist."""
    return _ExactReader().read(_parse_stored(text, max_length))


def dump_exact_list(exprs) -> str:
    """Several expressions as one text, ``[e1, e2, ...]`` (read back at once by ``load_exact_list``)."""
    return "[" + ", ".join(dump_exact(e) for e in exprs) + "]"


def load_exact_list(text: str, count: int, max_length: int = 50_000_000) -> list:
    """The ``count`` expressions of a ``dump_exact_list`` text, parsed in one go."""
    tree = _parse_stored(text, max_length)
    if not isinstance(tree, ast.List) or len(tree.elts) != count:
        raise ExpressionError(f"stored expressions: expected a list of {count}")
    reader = _ExactReader()
    return [reader.read(node) for node in tree.elts]


#: CPython 3.11's AST constructor keeps its recursion depth in shared state: two threads parsing at
#: once (a derivation read from the cache while a field is parsed) can fail with "SystemError: AST
#: constructor recursion depth mismatch" (python/cpython#106905). One parse at a time.
_AST_LOCK = threading.Lock()


def _ast_parse(text: str) -> ast.Expression:
    """``ast.parse(text, mode="eval")``, one thread at a time.

    >>> type(_ast_parse("m1*l1**2").body).__name__
    'BinOp'
    """
    with _AST_LOCK:
        return ast.parse(text, mode="eval")


def _parse_stored(text, max_length: int) -> ast.AST:
    if not isinstance(text, str) or len(text) > max_length:
        raise ExpressionError("stored expression: not a text of acceptable length")
    try:
        return _ast_parse(text).body
    except (SyntaxError, RecursionError, MemoryError, ValueError):
        raise ExpressionError("stored expression: not valid") from None


class _ExactReader:
    """Builds the tree of an exact text, one symbol object per name."""

    def __init__(self):
        self.symbols: dict = {}

    def read(self, node: ast.AST, depth: int = 0) -> sp.Expr:
        if depth > _EXACT_DEPTH:
            raise ExpressionError("stored expression: nested too deeply")
        if isinstance(node, ast.Name):
            name = node.id
            if name in _CONSTANTS:
                return _CONSTANTS[name]
            sym = self.symbols.get(name)
            if sym is None:
                sym = self.symbols[name] = symbol(name)
            return sym
        if isinstance(node, ast.Constant) and type(node.value) is int:
            if node.value.bit_length() > 4 * _MAX_FLOAT_EXPONENT:
                raise ExpressionError("stored expression: integer too large")
            return sp.Integer(node.value)
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub) and isinstance(node.operand, ast.Constant):
            return -self.read(node.operand, depth + 1)
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and not node.keywords:
            return self.call(node, depth)
        raise ExpressionError(f"stored expression: '{_shown(node)}' is not allowed")

    def call(self, node: ast.Call, depth: int) -> sp.Expr:
        head = node.func.id
        if head == "Rational" and len(node.args) == 2:
            p, q = (self.read(a, depth + 1) for a in node.args)
            if not (p.is_Integer and q.is_Integer and q > 1):
                raise ExpressionError("stored expression: bad rational")
            return sp.Rational(p, q)
        if head == "Float" and len(node.args) == 1 and isinstance(node.args[0], ast.Constant) \
                and type(node.args[0].value) is float and math.isfinite(node.args[0].value):
            return sp.Float(node.args[0].value)
        cls = _EXACT_HEADS.get(head)
        if cls is None or not node.args:
            raise ExpressionError(f"stored expression: '{_shown(node)}' is not allowed")
        return cls(*[self.read(a, depth + 1) for a in node.args], evaluate=False)
