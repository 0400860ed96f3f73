"""Safe parsing of user and file expressions into sympy, through a whitelist of Python's ``ast``.

Nothing here calls ``eval``, ``sympify`` or ``parse_expr`` on text: the text is parsed by
``ast.parse`` and every node is checked against a whitelist before a sympy object is built.

>>> parse_expression("m1*d1**2 + I1", {"m1", "d1", "I1"})
I1 + d1**2*m1
"""
from __future__ import annotations

import ast
import math
from typing import Iterable, Mapping

import sympy as sp

from .errors import UserError


class ExpressionError(UserError):
    """An expression could not be parsed; the message says where and why."""


_FUNCTIONS = {
    "sin": sp.sin, "cos": sp.cos, "tan": sp.tan, "atan2": sp.atan2, "atan": sp.atan,
    "asin": sp.asin, "acos": sp.acos, "sqrt": sp.sqrt, "exp": sp.exp, "log": sp.log,
    "Abs": sp.Abs, "abs": sp.Abs, "sign": sp.sign,
}
_CONSTANTS = {"pi": sp.pi, "E": sp.E}
_MAX_LENGTH = 2000


def symbol(name: str) -> sp.Symbol:
    """The one sympy symbol used for a name everywhere in the lab (all symbols are real).

    >>> symbol("q1").is_real
    True
    """
    return sp.Symbol(name, real=True)


def parse_expression(text, allowed_names: Iterable[str] | None = None,
                     extra: Mapping[str, sp.Basic] | None = None) -> sp.Expr:
    """Parse ``text`` (a string or a number) into a sympy expression.

    Only numbers, the names in ``allowed_names`` (or any identifier when it is None), ``pi``,
    ``E``, the arithmetic operators ``+ - * / **`` and the functions sin, cos, tan, atan2, atan,
    asin, acos, sqrt, exp, log, abs are accepted. ``^`` is read as a power.

    >>> parse_expression("2*pi/3")
    2*pi/3
    >>> parse_expression("__import__('os')")
    Traceback (most recent call last):
    ...
    app.core.expressions.ExpressionError: unknown function '__import__' in "__import__('os')"
    """
    if isinstance(text, bool):
        raise ExpressionError(f"expected a number or an expression, got {text!r}")
    if isinstance(text, (int,)):
        return sp.Integer(text)
    if isinstance(text, float):
        if not math.isfinite(text):
            raise ExpressionError(f"expected a finite number, got {text!r}")
        return sp.Float(text)
    if isinstance(text, sp.Basic):
        return text
    if not isinstance(text, str):
        raise ExpressionError(f"expected a number or an expression, got {type(text).__name__} {text!r}")
    source = text.strip()
    if not source:
        raise ExpressionError("empty expression")
    if len(source) > _MAX_LENGTH:
        raise ExpressionError(f"expression longer than {_MAX_LENGTH} characters")
    source = source.replace("^", "**")
    try:
        tree = ast.parse(source, mode="eval")
    except SyntaxError as exc:
        raise ExpressionError(f"syntax error in {text!r}: {exc.msg}") from None
    allowed = None if allowed_names is None else set(allowed_names)
    extra = dict(extra or {})

    def build(node: ast.AST) -> sp.Expr:
        if isinstance(node, ast.Expression):
            return build(node.body)
        if isinstance(node, ast.Constant):
            value = node.value
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise ExpressionError(f"unexpected constant {value!r} in {text!r}")
            if isinstance(value, float):
                if not math.isfinite(value):
                    raise ExpressionError(f"non-finite number in {text!r}")
                return sp.nsimplify(value) if value == int(value) else sp.Float(value)
            return sp.Integer(value)
        if isinstance(node, ast.Name):
            name = node.id
            if name in extra:
                return extra[name]
            if name in _CONSTANTS:
                return _CONSTANTS[name]
            if allowed is not None and name not in allowed:
                raise ExpressionError(f"unknown name '{name}' in {text!r}")
            return symbol(name)
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.UAdd, ast.USub)):
            operand = build(node.operand)
            return operand if isinstance(node.op, ast.UAdd) else -operand
        if isinstance(node, ast.BinOp):
            left, right = build(node.left), build(node.right)
            op = node.op
            if isinstance(op, ast.Add):
                return left + right
            if isinstance(op, ast.Sub):
                return left - right
            if isinstance(op, ast.Mult):
                return left * right
            if isinstance(op, ast.Div):
                if right == 0:
                    raise ExpressionError(f"division by zero in {text!r}")
                return left / right
            if isinstance(op, ast.Pow):
                if right.is_number and abs(float(right)) > 64:
                    raise ExpressionError(f"exponent too large in {text!r}")
                return left ** right
            raise ExpressionError(f"operator {type(op).__name__} not allowed in {text!r}")
        if isinstance(node, ast.Call):
            if not isinstance(node.func, ast.Name) or node.keywords:
                raise ExpressionError(f"only plain function calls are allowed in {text!r}")
            name = node.func.id
            if name not in _FUNCTIONS:
                raise ExpressionError(f"unknown function '{name}' in {text!r}")
            args = [build(arg) for arg in node.args]
            expected = 2 if name == "atan2" else 1
            if len(args) != expected:
                raise ExpressionError(f"{name} takes {expected} argument(s) in {text!r}")
            return _FUNCTIONS[name](*args)
        raise ExpressionError(f"'{ast.unparse(node) if hasattr(ast, 'unparse') else node}' is not allowed in {text!r}")

    return build(tree)


def parse_number(text, what: str = "value") -> float:
    """Parse a plain numeric value (expressions of constants allowed), or raise ExpressionError.

    >>> f"{parse_number('pi/2'):.12f}"
    '1.570796326795'
    >>> parse_number("abc", "mass")
    Traceback (most recent call last):
    ...
    app.core.expressions.ExpressionError: mass: unknown name 'abc' in 'abc'
    """
    try:
        expr = parse_expression(text, allowed_names=())
    except ExpressionError as exc:
        raise ExpressionError(f"{what}: {exc}") from None
    value = float(expr)
    if not math.isfinite(value):
        raise ExpressionError(f"{what}: not a finite number ({text!r})")
    return value
