"""The committed text field: when an edit is taken, and that a refusal never overwrites newer typing."""
import threading

import pytest

from app.core.errors import UserError
from app.viewer.fields import CommittedField


class FakeText:
    """A viser text handle as CommittedField uses it: a value and one update callback."""

    def __init__(self, value):
        self.value = value

    def on_update(self, callback):
        self.callback = callback

    def type(self, text):
        """The browser sends a new content of the field."""
        self.value = text
        self.callback(type("Event", (), {"client": object()})())


def parse_number(text):
    try:
        return float(text)
    except ValueError:
        raise UserError(f"{text!r} is not a number") from None


def test_an_emptied_field_waits_longer_than_a_typed_one():
    handle, committed, refused = FakeText("10"), [], []
    done = threading.Event()
    field = CommittedField(handle, parse_number, committed.append,
                           lambda message: (refused.append(message), done.set()), delay=0.05, empty_delay=1.5)
    handle.type("")
    assert not done.wait(0.3), "an emptied field was refused after the short pause"
    handle.type("12")                         # the user types after thinking: taken, no refusal
    field_done = threading.Event()
    field.commit = lambda value: (committed.append(value), field_done.set())
    assert field_done.wait(5)
    assert committed == [pytest.approx(12.0)] and refused == [] and handle.value == "12"
    handle.type("")                           # left empty: refused after the long pause
    assert done.wait(5)
    assert refused == ["'' is not a number"] and handle.value == "12"


def test_a_refusal_does_not_overwrite_an_edit_that_came_in_while_it_was_parsed():
    handle, committed, refused = FakeText("10"), [], []
    keys_in_flight = ["1e3"]

    def parse_while_the_user_types(text):
        if keys_in_flight:                    # the next keys arrive while this text is parsed
            handle.type(keys_in_flight.pop())
        return parse_number(text)

    field = CommittedField(handle, parse_while_the_user_types, committed.append, refused.append, delay=60)
    handle.type("1e")
    field.flush()                             # "1e" is bad, but "1e3" came in: no refusal, no restore
    assert refused == [] and handle.value == "1e3"
    field.flush()                             # the newer edit's own pause takes it
    assert committed == [pytest.approx(1000.0)] and handle.value == "1e3"
    handle.type("1e")                         # nothing newer: refused and the good text restored
    field.flush()
    assert refused == ["'1e' is not a number"] and handle.value == "1e3"
