"""Merged requests for a slow update: ``Coalescer(fn, interval).request()`` runs ``fn`` in a worker
thread, never twice at once, with the latest state."""
from __future__ import annotations

import threading
import time
from typing import Callable


class Coalescer:
    """Runs ``fn()`` in a worker thread after ``request()``, merging requests that arrive while it
    runs, at most once per ``interval`` seconds: a slider dragged at any speed causes at most one
    pending update, always with the latest state."""

    def __init__(self, fn: Callable[[], None], interval: float = 0.0, on_error=None):
        self.fn, self.interval, self.on_error = fn, interval, on_error
        self._lock = threading.Lock()
        self._pending = False
        self._running = False

    def request(self) -> None:
        with self._lock:
            self._pending = True
            if self._running:
                return
            self._running = True
        threading.Thread(target=self._loop, daemon=True).start()

    def _loop(self) -> None:
        while True:
            with self._lock:
                if not self._pending:
                    self._running = False
                    return
                self._pending = False
            start = time.perf_counter()
            try:
                self.fn()
            except Exception as exc:   # keep the worker alive; report
                if self.on_error:
                    self.on_error(exc)
            rest = self.interval - (time.perf_counter() - start)
            if rest > 0:
                time.sleep(rest)
