"""The one base class for errors caused by user input (files, expressions, values).

Anything raising a ``UserError`` is reported as a clear message: on the command line with exit
code 2, in the page as a notification. Other exceptions are bugs.

>>> issubclass(UserError, ValueError)
True
"""


class UserError(ValueError):
    """Bad input from the user: the message says what and where."""
