"""Text fields whose value is taken when the user has finished typing.

The browser sends a text field's content on every keystroke, so reading a value per key turns
"1e9" into "1", then an error for "1e", then 1e9 (and a slider's number box, which drops the
"e", into 19). A ``CommittedField`` waits until the typing pauses (``COMMIT_DELAY``), then parses
the text once: a good value is handed to ``commit``; a bad one gets one message and the last
good text comes back. An emptied field waits longer (``EMPTY_DELAY``): clearing a field and then
thinking before typing is common, and the restored text would otherwise land over the keys the
browser has not sent yet. A refusal never overwrites an edit that arrived after its text was read.

>>> class Handle:                     # stands in for a viser text handle in this example
...     value = "2"
...     def on_update(self, cb): self.cb = cb
>>> class Event:
...     client = object()
>>> got = []
>>> handle = Handle()
>>> def parse(text):
...     try:
...         return float(text)
...     except ValueError:
...         raise UserError("not a number") from None
>>> field = CommittedField(handle, parse, got.append, lambda message: got.append(message), delay=60)
>>> handle.value = "1e9"; handle.cb(Event()); field.flush(); got    # exact: float("1e9")
[1000000000.0]
>>> handle.value = "1e"; handle.cb(Event()); field.flush(); got[-1], handle.value
('not a number', '1e9')
"""
from __future__ import annotations

import threading
from typing import Callable, Optional

from app.core.errors import UserError
from app.core.expressions import ExpressionError, excerpt, parse_number
from app.core.robot_model import ParameterError

COMMIT_DELAY = 0.6       # seconds without a keystroke that count as "done typing"
EMPTY_DELAY = 3.0        # seconds an emptied field waits before it is refused


class CommittedField:
    """A text handle (``gui.add_text``) read when its edit is committed.

    ``parse(text) -> value`` raises ``UserError`` on bad text; ``commit(value)`` applies a good
    value; ``refuse(message)`` shows the message of a bad one (the text is then restored to
    ``format(last good value)``). Changes made by the server (``event.client is None``) are
    ignored; ``set(value)`` shows a value without committing it."""

    def __init__(self, handle, parse: Callable[[str], object], commit: Callable[[object], None],
                 refuse: Callable[[str], None], format: Callable[[object], str] = str,
                 delay: float = COMMIT_DELAY, empty_delay: float = EMPTY_DELAY):
        self.handle, self.parse, self.commit, self.refuse, self.format = handle, parse, commit, refuse, format
        self.delay, self.empty_delay = delay, empty_delay
        self._lock = threading.Lock()
        self._timer: Optional[threading.Timer] = None
        self._edits = 0                    # edits received: a refusal checks that none came since
        self._good_text = handle.value
        self.closed = False
        handle.on_update(self._typed)

    def set(self, value) -> None:
        """Show ``value`` (set by the program): it becomes the last good value."""
        with self._lock:
            self._cancel()
            self._good_text = self.format(value)
        self.handle.value = self._good_text

    def close(self) -> None:
        """Stop: a pending edit is dropped (the field is being removed)."""
        with self._lock:
            self.closed = True
            self._cancel()

    def flush(self) -> None:
        """Commit a pending edit now (tests; the timer does it after the pause)."""
        with self._lock:
            pending = self._timer is not None
            self._cancel()
        if pending:
            self._take()

    def _cancel(self) -> None:
        if self._timer is not None:
            self._timer.cancel()
            self._timer = None

    def _typed(self, event) -> None:
        if event.client is None:
            return
        with self._lock:
            if self.closed:
                return
            self._cancel()
            self._edits += 1
            wait = self.empty_delay if not str(self.handle.value).strip() else self.delay
            self._timer = threading.Timer(wait, self._take)
            self._timer.daemon = True
            self._timer.start()

    def _take(self) -> None:
        with self._lock:
            self._timer = None
            if self.closed:
                return
            text, edits = self.handle.value, self._edits
        try:
            value = self.parse(text)
        except UserError as exc:
            with self._lock:
                if self.closed or self._edits != edits:
                    return                 # a newer edit came in: its own pause decides
                self.handle.value = self._good_text
            self.refuse(str(exc))
            return
        with self._lock:
            self._good_text = text
        self.commit(value)


def parse_parameter(robot, name: str, text: str) -> float:
    """The value typed into a parameter field: a number or a constant expression (``0.5``, ``1/3``,
    ``pi/4``), finite, and not negative for masses, inertias, stiffnesses and friction.

    >>> from app.core.robot import load_robot
    >>> parse_parameter(load_robot("planar_2r"), "m1", " 2.5 ")      # exact: the number typed
    2.5
    >>> parse_parameter(load_robot("planar_2r"), "m1", "-1")
    Traceback (most recent call last):
    ...
    app.core.robot_model.ParameterError: m1: a mass must not be negative (got -1)
    """
    text = (text or "").strip()
    if not text:
        raise ParameterError(f"{name}: empty value; type a number")
    try:
        value = parse_number(text)
    except (ExpressionError, TypeError, ValueError):
        raise ParameterError(f"{name}: {excerpt(text)} is not a number") from None
    return robot.check_parameter_value(name, value)


def format_number(value: float) -> str:
    """Short text of a number for a field: ``0.5``, ``9.81``, ``1e-06``."""
    return f"{value:.6g}"
