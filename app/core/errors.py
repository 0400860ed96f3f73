"""The one base class for errors caused by user input (files, expressions, values).

Anything raising a ``UserError`` is reported as a clear message: on the command line with exit
code 2, in the page as a notification. Other exceptions are bugs.

>>> issubclass(UserError, ValueError)
True
"""
import reprlib


class UserError(ValueError):
    """Bad input from the user: the message says what and where."""


def excerpt(text, limit: int = 60) -> str:
    """The input quoted for a message, cut to ``limit`` characters (any value: nested data is
    abbreviated, never walked in full).

    >>> excerpt("x" * 100, 10)
    "'xxxxxxx...'"
    """
    if not isinstance(text, str):
        return reprlib.repr(text)[:limit]
    return repr(text if len(text) <= limit else text[:limit - 3] + "...")


class SimulationError(UserError):
    """A simulation cannot be set up as asked (bad initial state, missing surface, unknown
    backend, ...)."""
