"""Background jobs of one browser tab: ``JobRunner.submit(fn, title, on_done, on_cancel)`` runs
``fn(progress)`` off the event thread with a progress bar and a Cancel button in the page (shown
when the job takes more than 0.3 s). ``Session.run_in_background`` is its front; docs/panels.md
says what a panel may expect of it.
"""
from __future__ import annotations

import html
import threading
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Callable, Optional

from app.core.errors import UserError
from app.viewer.panel_api import JobCancelled
from app.viewer.worker import job_context

SHOW_AFTER = 0.3        # seconds before a job's progress bar appears


class JobRunner:
    """Runs one tab's jobs, two at a time.

    ``gui`` gets the progress bars (at ``order``); ``notify(title, body, error=)`` and
    ``internal_error()`` report; ``limit(fn)`` wraps a job before it runs (the server's job slots,
    ``LabServer.limited``); ``closed()`` tells whether the tab went away; callbacks ``on_done`` run
    under ``callback_lock`` (the session's panel-building lock). Inside ``fn``,
    ``app.viewer.in_worker(f, *args, progress=progress)`` runs a heavy ``f`` in one of ``workers``'
    processes (app/viewer/worker.py); a Cancel or a closed tab kills it there."""

    def __init__(self, gui, notify: Callable, internal_error: Callable, limit: Callable[[Callable], Callable],
                 closed: Callable[[], bool], callback_lock, order: float, name: str = "session", workers=None):
        self.gui, self.notify, self.internal_error, self.limit = gui, notify, internal_error, limit
        self.workers = workers      # the server's WorkerPool: ``in_worker`` inside a job runs there
        self.closed, self.callback_lock, self.order = closed, callback_lock, order
        self._executor = ThreadPoolExecutor(max_workers=2, thread_name_prefix=name)

    def submit(self, fn: Callable, title: str, on_done: Optional[Callable] = None,
               on_cancel: Optional[Callable] = None) -> Future:
        """Start ``fn(progress)``; the future's ``cancel_job()`` does what the Cancel button does."""
        cancelled = threading.Event()
        future = self._executor.submit(self._job, self.limit(fn), title, on_done, cancelled, on_cancel)
        future.cancel_job = cancelled.set
        return future

    def shutdown(self) -> None:
        self._executor.shutdown(wait=False, cancel_futures=True)

    def _job(self, fn, title: str, on_done, cancelled: threading.Event, on_cancel=None):
        bar = _ProgressBar(self.gui, title, self.order, cancelled)
        timer = threading.Timer(SHOW_AFTER, bar.show)
        timer.daemon = True
        timer.start()

        def progress(fraction: float, message: str = "") -> None:
            if self.closed() or cancelled.is_set():
                raise JobCancelled(title)
            bar.update(fraction, message)

        try:
            with job_context(self.workers, lambda: self.closed() or cancelled.is_set()):
                result = fn(progress)
            timer.cancel()       # the work is done: no bar while the page is updated (``on_done``
            bar.remove()         # may wait on the page, as the first robot's panels do)
            if on_done is not None:
                with self.callback_lock:      # panels are not rebuilt under a callback's feet
                    on_done(result)
            return result
        except JobCancelled:
            if cancelled.is_set() and not self.closed():      # the student's Cancel (else the tab went away)
                try:
                    if on_cancel is not None:
                        on_cancel()
                finally:
                    self.notify(f"{title}: cancelled")
        except UserError as exc:
            self.notify(title, str(exc), error=True)
        except Exception:
            self.internal_error()
        finally:
            timer.cancel()
            bar.remove()
        return None


class _ProgressBar:
    """A job's label, bar and Cancel button in the page, made on ``show`` (if the job still runs)."""

    def __init__(self, gui, title: str, order: float, cancelled: threading.Event):
        self.gui, self.title, self.order, self.cancelled = gui, title, order, cancelled
        self.lock = threading.Lock()
        self.fraction, self.message, self.done = 0.0, "", False
        self.handles = None          # (label, bar, button) once shown

    def show(self) -> None:
        with self.lock:
            if self.done or self.handles is not None:
                return
            label = self.gui.add_html(progress_html(self.title, self.message), order=self.order)
            bar = self.gui.add_progress_bar(_percent(self.fraction), animated=True, order=self.order + 0.1)
            button = self.gui.add_button("Cancel", color="gray", order=self.order + 0.2, hint=f"stop: {self.title}")
            button.on_click(lambda _: self.cancelled.set())
            self.handles = (label, bar, button)

    def update(self, fraction: float, message: str) -> None:
        with self.lock:
            self.fraction, self.message = float(fraction), message
            if self.handles is not None:
                label, bar, _ = self.handles
                bar.value = _percent(self.fraction)
                label.content = progress_html(self.title, message)

    def remove(self) -> None:
        with self.lock:
            self.done = True
            for handle in self.handles or ():
                handle.remove()
            self.handles = None


def _percent(fraction: float) -> float:
    return max(0.0, min(100.0, 100 * float(fraction)))


def progress_html(title: str, message: str) -> str:
    """The line above a progress bar.

    >>> progress_html("Deriving", "M(q)")
    '<div style="font-size:0.85em;color:#333">Deriving — M(q)</div>'
    """
    return (f'<div style="font-size:0.85em;color:#333">{html.escape(title)}'
            f'{" — " + html.escape(message) if message else ""}</div>')
