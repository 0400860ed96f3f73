"""What the lab's web server lets in: which handshakes open a session, which widget values reach
the page's callbacks.

Handshake (``HandshakePolicy``): a page on another site must not drive the lab through the
student's browser, and a name that merely resolves to this machine (DNS rebinding) must not reach
it. Bound to a loopback address, the server answers only requests whose ``Host`` is a loopback
name (``127.0.0.1``, ``localhost``, ``[::1]``) and whose ``Origin``, when present, is the page's
own. Bound beyond loopback (``--host 0.0.0.0``), every request must also carry the per-server
token as the first segment of its path (``http://HOST:PORT/TOKEN/``, printed at start); the page
loaded from there opens its websocket on the same path, so the browser needs nothing else.

Widget values (``guard_widget_updates``): a client can send any value for any widget, whatever
the page's own limits. Only the ``value`` of a widget is accepted from a client, and only within
the widget's declared range (numbers, sliders, vectors), among its options (dropdowns, button
groups), finite, and for text at most ``MAX_TEXT_CHARS`` characters; anything else is refused
before any callback runs, with a message in that tab.

>>> policy = HandshakePolicy("127.0.0.1")
>>> policy.refusal("/", {"Host": "127.0.0.1:8080", "Origin": "http://127.0.0.1:8080"}) is None
True
>>> policy.refusal("/", {"Host": "127.0.0.1:8080", "Origin": "http://evil.example.com"})
'foreign Origin'
>>> policy.refusal("/", {"Host": "evil.example.com:8080"})
'Host is not a loopback name'
>>> problem_with_value(_Limits(min=0.1, max=120.0, step=0.1), 1e4)
'10000 is outside 0.1 ... 120'
"""
from __future__ import annotations

import contextlib
import dataclasses
import http
import ipaddress
import math
import secrets
import threading
from typing import Any, Callable, Mapping, Optional
from urllib.parse import urlsplit

LOOPBACK_NAMES = ("localhost", "127.0.0.1", "::1")
MAX_TEXT_CHARS = 4000


def is_loopback(host: str) -> bool:
    """Whether a bind address or host name stays on this machine.

    >>> is_loopback("127.0.0.1"), is_loopback("localhost"), is_loopback("0.0.0.0")
    (True, True, False)
    """
    host = host.strip("[]").lower()
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def _host_name(authority: str) -> str:
    """``127.0.0.1:8080`` -> ``127.0.0.1``; ``[::1]:8080`` -> ``::1``."""
    try:
        return (urlsplit("//" + authority).hostname or "").lower()
    except ValueError:
        return ""


def _all_values(headers, name: str) -> list:
    """Every value of header ``name`` (websockets' ``Headers`` or a plain mapping)."""
    if hasattr(headers, "get_all"):
        return list(headers.get_all(name))
    return [headers[name]] if name in headers else []


class HandshakePolicy:
    """Decides, from the request line and headers alone, whether an HTTP request or a websocket
    handshake may proceed (``refusal`` returns None) or gets 403 (the reason)."""

    def __init__(self, bind_host: str, token: Optional[str] = None):
        self.loopback_only = is_loopback(bind_host)
        self.token = None if self.loopback_only else (token or secrets.token_urlsafe(16))

    def strip_token(self, path: str) -> Optional[str]:
        """The request path without the token segment, or None when the token is required and
        missing. ``/TOKEN/`` -> ``/``; ``/TOKEN`` (the websocket) -> ``/``."""
        if self.token is None:
            return path
        head, _, rest = path.lstrip("/").partition("/")
        head = head.partition("?")[0]
        if not secrets.compare_digest(head.encode(), self.token.encode()):
            return None
        return "/" + rest

    def refusal(self, path: str, headers) -> Optional[str]:
        hosts, origins = _all_values(headers, "Host"), _all_values(headers, "Origin")
        if len(hosts) > 1 or len(origins) > 1:
            return "repeated Host or Origin header"
        host = hosts[0] if hosts else ""
        if self.loopback_only and _host_name(host) not in LOOPBACK_NAMES:
            return "Host is not a loopback name"
        if origins:                 # browsers send it on websockets: the page must be ours
            parts = urlsplit(origins[0])
            if parts.scheme not in ("http", "https") or parts.netloc.lower() != host.lower():
                return "foreign Origin"
        if self.strip_token(path) is None:
            return "missing or wrong token"
        return None


_SERVE_PATCH_LOCK = threading.Lock()


@contextlib.contextmanager
def handshake_checked(policy: HandshakePolicy, on_request: Optional[Callable[[str, Any], None]] = None):
    """Run ``policy`` on every request of the viser server created inside this block.

    Adapter, because viser 1.1.1 has no public hook for the handshake: its ``WebsockServer``
    passes its own ``process_request`` (the static page server) to
    ``websockets.asyncio.server.serve``, which is websockets' documented interception point.
    While the block runs (``ViserServer.__init__`` returns only once the socket is bound), that
    ``serve`` is wrapped so that our check runs first, the token segment is taken off the path,
    and then viser's own handler runs (``on_request(path, headers)`` is told of each request let
    in, the path without the token). The lock keeps two servers started at once apart."""
    import websockets.asyncio.server as ws_server
    from websockets.datastructures import Headers
    from websockets.http11 import Response

    original = ws_server.serve

    def serve(*args, process_request=None, **kwargs):
        def checked(connection, request):
            reason = policy.refusal(request.path, request.headers)
            if reason is not None:
                body = f"Forbidden: {reason}.\n".encode()
                return Response(http.HTTPStatus.FORBIDDEN, "Forbidden",
                                Headers({"Content-Type": "text/plain", "Content-Length": str(len(body))}),
                                body)
            request = dataclasses.replace(request, path=policy.strip_token(request.path))
            if on_request is not None:
                on_request(request.path, request.headers)
            return process_request(connection, request) if process_request else None
        return original(*args, process_request=checked, **kwargs)

    with _SERVE_PATCH_LOCK:
        ws_server.serve = serve
        try:
            yield
        finally:
            ws_server.serve = original


# ---------------------------------------------------------------------------------- widget values
@dataclasses.dataclass(frozen=True)
class _Limits:
    """What a widget accepts (for the doctest; real widgets are read by ``limits_of``)."""
    min: Any = None
    max: Any = None
    step: Any = None
    options: Any = None


def limits_of(handle) -> _Limits:
    """The declared limits of a viser widget handle (those it does not have are None)."""
    return _Limits(*(getattr(handle, name, None) for name in ("min", "max", "step", "options")))


def _number_problem(value, low, high, step) -> Optional[str]:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return f"{str(value)[:20]!r} is not a number"
    if not math.isfinite(value):
        return f"{value} is not a finite number"
    slack = 0.5 * abs(step or 0.0) + 1e-9 * max(abs(low or 0.0), abs(high or 0.0), 1.0)
    if (low is not None and value < low - slack) or (high is not None and value > high + slack):
        low_text = "-inf" if low is None else f"{low:g}"
        high_text = "inf" if high is None else f"{high:g}"
        return f"{value:g} is outside {low_text} ... {high_text}"
    return None


def problem_with_value(limits: _Limits, value) -> Optional[str]:
    """Why ``value`` sent by a client does not fit a widget with ``limits`` (None: it fits).

    >>> problem_with_value(_Limits(options=("pd", "computed_torque")), "rm -rf")
    "'rm -rf' is not one of the options"
    >>> problem_with_value(_Limits(min=(-1.0, -1.0), max=(1.0, 1.0), step=0.01), (0.5, float("nan")))
    'nan is not a finite number'
    """
    if limits.options is not None:
        return None if value in tuple(limits.options) else f"{str(value)[:40]!r} is not one of the options"
    if isinstance(value, str):
        return None if len(value) <= MAX_TEXT_CHARS else f"a text of more than {MAX_TEXT_CHARS} characters"
    if isinstance(value, (list, tuple)):
        n = len(value)
        lows = limits.min if isinstance(limits.min, (list, tuple)) else (limits.min,) * n
        highs = limits.max if isinstance(limits.max, (list, tuple)) else (limits.max,) * n
        if len(lows) != n or len(highs) != n:
            return f"{n} values where {len(lows)} are expected"
        for v, lo, hi in zip(value, lows, highs):
            problem = _number_problem(v, lo, hi, limits.step)
            if problem:
                return problem
        return None
    if isinstance(value, bool) or value is None:
        return None
    return _number_problem(value, limits.min, limits.max, limits.step)


def update_problem(handle, updates: Mapping[str, Any]) -> Optional[str]:
    """Why a client's update of ``handle`` is refused (None: accepted). Clients may only set
    ``value``; its type must match the widget's current value."""
    if set(updates) != {"value"}:
        return "only a widget's value may be changed"
    value, current = updates["value"], handle.value
    if isinstance(current, bool) != isinstance(value, bool):
        return f"{str(value)[:20]!r} is not {'true or false' if isinstance(current, bool) else 'accepted'}"
    if isinstance(current, str) != isinstance(value, str):
        return f"{str(value)[:20]!r} is not a text"
    if isinstance(current, tuple) and (not isinstance(value, (list, tuple)) or len(value) != len(current)):
        return f"expected {len(current)} values"
    return problem_with_value(limits_of(handle), value)


def guard_widget_updates(gui_api, refused: Callable[[Any, str], None]) -> None:
    """Check every widget update a client sends to ``gui_api`` (viser's server-wide ``server.gui``
    or a tab's ``client.gui``) before viser applies it and runs the widget's callbacks; a refused
    update calls ``refused(handle, reason)``, sends the widget's current value back to the page
    and goes no further.

    Adapter, because viser 1.1.1 applies client updates in ``GuiApi._handle_gui_updates``, which
    it registers as the handler of ``GuiUpdateMessage`` through the infra's public
    ``register_handler``/``unregister_handler``: we swap that handler for a checked wrapper."""
    from viser import _messages

    interface = gui_api._websock_interface
    apply_update = gui_api._handle_gui_updates

    async def checked(client_id, message) -> None:
        handle = gui_api._gui_input_handle_from_uuid.get(message.uuid)
        if handle is not None and not handle._impl.removed:
            reason = update_problem(handle, message.updates)
            if reason is not None:
                interface.queue_message(_messages.GuiUpdateMessage(message.uuid, {"value": handle.value}))
                refused(handle, reason)
                return
        await apply_update(client_id, message)

    interface.unregister_handler(_messages.GuiUpdateMessage, apply_update)
    interface.register_handler(_messages.GuiUpdateMessage, checked)


def widget_name(handle) -> str:
    """The label a student sees on a widget (for messages)."""
    return str(getattr(handle, "label", "") or "a field")[:60]
