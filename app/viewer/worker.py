"""Heavy jobs of the server in worker processes (issue 15: a class on one server).

A cold derivation, the throw optimizer and other long computations hold Python's interpreter lock
for seconds; in a thread of the server every other tab's slider waits its turn. Inside a job of
``Session.run_in_background`` a panel hands such a computation to a worker process with

    result = in_worker(fn, *args, progress=progress, **kwargs)

``fn`` must be a module-level function, and its arguments and result picklable (the server's own
processes only: nothing from the network is unpickled); when they are not, it runs in the job's
thread as before (and says so on stderr). In the worker ``fn`` gets a ``progress``
that reports back to the job's ``progress`` (its progress bar); the job's Cancel button, its tab
going away, or its ``progress`` returning False (the simulator's way to stop a run) kills the
worker process within 0.1 s (a new one is started for the next job), so a
computation is stopped even when it does not report. Outside such a job (the command line, tests of
the core) ``in_worker`` just calls ``fn`` here.

The pool (``WorkerPool``, one per ``LabServer``) runs at most ``size`` jobs at once in as many
processes (one per core, the server's job limit; a second pool of one process takes the pinocchio
badge's cross-checks), started when first needed as fresh interpreters (no copy of the server's
threads and locks), each lowered in priority (``os.nice``) so that the server's event loop
wins the CPU; a worker whose memory grew past ``max_rss_mb`` is replaced after its job.
"""
from __future__ import annotations

import collections
import os
import pickle
import subprocess
import sys
import threading
import time
import traceback
from multiprocessing.connection import Connection
from pathlib import Path
from typing import Callable, List, Optional

from app.viewer.panel_api import JobCancelled

#: niceness added to a worker process (the server keeps its own): the lowest priority, so that a
#: slider's pose never waits behind a derivation or the optimizer (benchmarks/load.py: loaded p95
#: 202 ms at nice 5, 138-164 ms at 19, the same work done)
NICE = 19
#: seconds between two progress reports a worker sends (the last of a burst may be skipped)
REPORT_INTERVAL = 0.1


class WorkerDied(RuntimeError):
    """The worker process ended in the middle of a job (killed from outside, out of memory)."""


class NotPortable(TypeError):
    """A job's function, arguments or result cannot cross to or from a worker process (pickle)."""


class _RemoteTraceback(Exception):
    """The worker's traceback, chained to an error it sent back (shown by ``traceback``)."""

    def __str__(self):
        return self.args[0]


class _Job(threading.local):
    pool: Optional["WorkerPool"] = None
    cancelled: Callable[[], bool] = staticmethod(lambda: False)


_current = _Job()


class job_context:
    """``with job_context(pool, cancelled):`` - ``in_worker`` calls in this thread go to ``pool``
    and stop when ``cancelled()`` becomes true (used by the session's job runner)."""

    def __init__(self, pool: Optional["WorkerPool"], cancelled: Callable[[], bool]):
        self.pool, self.cancelled = pool, cancelled

    def __enter__(self):
        self._saved = (_current.pool, _current.cancelled)
        _current.pool, _current.cancelled = self.pool, self.cancelled
        return self

    def __exit__(self, *exc):
        _current.pool, _current.cancelled = self._saved
        return False


class FairSlots:
    """``n`` slots handed out first come, first served. (A semaphore polled with time-outs wakes
    whoever asks first: a tab that starts one job the moment its last one ends could keep another
    tab's job waiting for ever.)

    >>> slots = FairSlots(1)
    >>> slots.acquire(); slots.release()
    """

    def __init__(self, n: int):
        self._free = n
        self._queue: collections.deque = collections.deque()
        self._cond = threading.Condition()

    def acquire(self, waiting: Callable[[], None] = lambda: None, interval: float = 0.5) -> None:
        """Wait for a slot in turn; ``waiting()`` runs every ``interval`` s meanwhile (outside the
        lock; it may raise, e.g. JobCancelled, to give up the place in the queue)."""
        me = object()
        with self._cond:
            self._queue.append(me)
        try:
            while True:
                with self._cond:
                    if self._queue[0] is me and self._free > 0:
                        self._queue.popleft()
                        self._free -= 1
                        self._cond.notify_all()           # the next in the queue may take a slot too
                        return
                    if self._cond.wait(interval):
                        continue
                waiting()
        except BaseException:
            with self._cond:
                if me in self._queue:
                    self._queue.remove(me)
                self._cond.notify_all()
            raise

    def release(self) -> None:
        with self._cond:
            self._free += 1
            self._cond.notify_all()


def in_worker(fn: Callable, *args, progress: Optional[Callable] = None, **kwargs):
    """``fn(*args, **kwargs)`` (with ``progress=`` when given) in a worker process of the server
    when called inside one of its jobs, else here."""
    pool = _current.pool
    if progress is not None:
        kwargs["progress"] = progress
    if pool is not None:
        try:
            return pool.call(fn, args, kwargs, _current.cancelled)
        except NotPortable as exc:       # a value that does not pickle: as before, in this thread
            print(f"in_worker: {exc}; running it in the server", file=sys.stderr, flush=True)
    return fn(*args, **kwargs)


# ---------------------------------------------------------------------------------- in the worker
class _Reporter:
    """The ``progress`` a computation gets in the worker: sends (fraction, message) to the server,
    at most every REPORT_INTERVAL seconds."""

    def __init__(self, conn):
        self.conn, self.last = conn, 0.0

    def __call__(self, fraction, message: str = ""):
        now = time.monotonic()
        if now - self.last >= REPORT_INTERVAL:
            self.last = now
            self.conn.send(("progress", float(fraction), str(message)))


def _portable(exc: BaseException) -> BaseException:
    """``exc`` if it survives pickling, else a RuntimeError (or UserError) with its text; the
    worker's traceback rides along in ``remote_traceback``."""
    text = "".join(traceback.format_exception(type(exc), exc, exc.__traceback__))
    try:
        pickle.loads(pickle.dumps(exc))
        out = exc
    except Exception:
        from app.core.errors import UserError
        out = (UserError if isinstance(exc, UserError) else RuntimeError)(f"{type(exc).__name__}: {exc}")
    out.__traceback__ = None
    out.remote_traceback = text
    return out


def serve_pipes(recv_fd: int, send_fd: int, nice: int) -> None:
    """The worker process: runs the jobs read from ``recv_fd``, answers on ``send_fd``."""
    _serve(_Duplex(Connection(recv_fd, writable=False), Connection(send_fd, readable=False)), nice)


class _Duplex:
    def __init__(self, recv, send):
        self.recv, self.send = recv.recv, send.send


def _orphan_watch(parent: int) -> None:
    """End the worker when the server is gone (killed: no one would read its result)."""
    while True:
        time.sleep(1.0)
        if os.getppid() != parent:
            os._exit(3)


def _serve(conn, nice: int) -> None:
    try:
        os.nice(nice)
    except OSError:
        pass
    threading.Thread(target=_orphan_watch, args=(os.getppid(),), daemon=True, name="orphan-watch").start()
    while True:
        try:
            message = conn.recv()
        except (EOFError, OSError, KeyboardInterrupt):
            return
        if message is None:
            return
        fn, args, kwargs = message
        if "progress" in kwargs:
            kwargs["progress"] = _Reporter(conn)
        try:
            reply = ("done", fn(*args, **kwargs))
        except BaseException as exc:        # everything goes back to the job (KeyboardInterrupt too)
            reply = ("error", _portable(exc))
        try:
            conn.send(reply)
        except OSError:                     # the server closed the pipe (stopped, or the job cancelled)
            return
        except Exception as exc:            # the result does not pickle: the server runs it itself
            try:
                conn.send(("unportable", f"the result of {getattr(fn, '__name__', fn)} does not pickle: {exc}"))
            except OSError:
                return


# ---------------------------------------------------------------------------------- in the server
def _rss_mb(pid: int) -> float:
    try:
        with open(f"/proc/{pid}/status") as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) / 1024.0
    except (OSError, ValueError):
        pass
    return 0.0


class _Worker:
    """One worker: ``python -c`` running ``serve_pipes`` on two pipes (not multiprocessing's own
    start methods, which run the server's main script again in the child when it has no
    ``if __name__ == "__main__"`` guard)."""

    def __init__(self, nice: int):
        to_child, from_parent = os.pipe()
        to_parent, from_child = os.pipe()
        # the server's import path (the lab's root first): a job's function is imported by name
        root = str(Path(__file__).resolve().parents[2])
        env = {**os.environ, "PYTHONPATH": os.pathsep.join(dict.fromkeys([root] + [p for p in sys.path if p]))}
        try:
            self.process = subprocess.Popen(
                [sys.executable, "-c", f"from app.viewer.worker import serve_pipes; "
                                       f"serve_pipes({to_child}, {from_child}, {int(nice)})"],
                pass_fds=(to_child, from_child), env=env, stdin=subprocess.DEVNULL)
        finally:
            os.close(to_child)
            os.close(from_child)
        self._recv = Connection(to_parent, writable=False)
        self._send = Connection(from_parent, readable=False)
        self.jobs = 0

    @property
    def pid(self) -> int:
        return self.process.pid

    def alive(self) -> bool:
        return self.process.poll() is None

    def send(self, message) -> None:
        self._send.send(message)

    def poll(self, timeout: float) -> bool:
        return self._recv.poll(timeout)

    def recv(self):
        return self._recv.recv()

    def _close(self) -> None:
        for conn in (self._recv, self._send):
            try:
                conn.close()
            except OSError:
                pass

    def kill(self) -> None:
        try:
            self.process.kill()
            self.process.wait(5)
        except Exception:
            pass
        self._close()

    def stop(self) -> None:
        try:
            self._send.send(None)
        except Exception:
            pass
        try:
            self.process.wait(2)
        except subprocess.TimeoutExpired:
            pass
        if self.alive():
            self.kill()
        else:
            self._close()


class WorkerPool:
    """Up to ``size`` worker processes for the server's heavy jobs (see the module's doc)."""

    def __init__(self, size: int, nice: int = NICE, max_rss_mb: float = 1500.0):
        self.size, self.nice, self.max_rss_mb = max(1, size), nice, max_rss_mb
        self._lock = threading.Lock()
        self._idle: List[_Worker] = []
        self._busy: List[_Worker] = []
        self._closed = False
        self._free = FairSlots(self.size)                     # at most ``size`` jobs at once, in turn
        self.started = 0            # worker processes started so far
        self.killed = 0             # killed by a Cancel or a closed tab

    def pids(self) -> List[int]:
        """Process ids of the workers alive now."""
        with self._lock:
            return [w.pid for w in self._idle + self._busy if w.alive()]

    def busy_pids(self) -> List[int]:
        with self._lock:
            return [w.pid for w in self._busy]

    def _new(self) -> _Worker:
        worker = _Worker(self.nice)
        with self._lock:
            self.started += 1
        return worker

    def _take(self) -> _Worker:
        with self._lock:
            if self._closed:
                raise RuntimeError("the server is stopping")
            while self._idle:
                worker = self._idle.pop()
                if worker.alive():
                    self._busy.append(worker)
                    return worker
                worker._close()
        worker = self._new()
        with self._lock:
            self._busy.append(worker)
        return worker

    def _release(self, worker: _Worker, healthy: bool) -> None:
        with self._lock:
            if worker in self._busy:
                self._busy.remove(worker)
            keep = (healthy and not self._closed and len(self._idle) < self.size
                    and _rss_mb(worker.pid) < self.max_rss_mb)
            if keep:
                self._idle.append(worker)
        if not keep:
            (worker.stop if healthy else worker.kill)()

    def call(self, fn: Callable, args: tuple, kwargs: dict, cancelled: Callable[[], bool] = lambda: False):
        """Run ``fn(*args, **kwargs)`` in a worker; a ``progress`` in ``kwargs`` receives the
        worker's reports here. Raises JobCancelled (and kills the worker) as soon as
        ``cancelled()`` is true or ``progress`` raises it."""
        progress = kwargs.get("progress")
        def waiting():                                    # every worker busy: wait for one, in turn
            if cancelled():
                raise JobCancelled(getattr(fn, "__name__", "job"))
        self._free.acquire(waiting, interval=0.1)
        try:
            worker = self._take()
        except BaseException:
            self._free.release()
            raise
        healthy = False
        try:
            try:
                worker.send((fn, args, kwargs if progress is None else {**kwargs, "progress": True}))
            except (pickle.PicklingError, TypeError, AttributeError) as exc:
                healthy = True         # nothing was sent
                raise NotPortable(f"{getattr(fn, '__name__', fn)} cannot be sent to a worker: {exc}") from None
            worker.jobs += 1
            while True:
                if cancelled():
                    self.killed += 1
                    raise JobCancelled(getattr(fn, "__name__", "job"))
                if not worker.poll(0.1):
                    if not worker.alive():
                        raise WorkerDied(f"the worker process ended during the computation "
                                         f"(exit code {worker.process.returncode})")
                    continue
                try:
                    kind, *rest = worker.recv()
                except (EOFError, OSError):
                    raise WorkerDied("the worker process ended during the computation") from None
                if kind == "progress":
                    if progress is not None:
                        try:
                            stop = progress(*rest) is False      # the simulator's "stop the run"
                        except JobCancelled:
                            self.killed += 1
                            raise
                        if stop:
                            self.killed += 1
                            raise JobCancelled(f"{getattr(fn, '__name__', 'job')}: stopped by its progress")
                elif kind == "done":
                    healthy = True
                    return rest[0]
                elif kind == "unportable":
                    healthy = True
                    raise NotPortable(rest[0])
                else:
                    healthy = True
                    error = rest[0]
                    remote = getattr(error, "remote_traceback", None)
                    raise error from (_RemoteTraceback("\n" + remote) if remote else None)
        finally:
            self._release(worker, healthy)
            self._free.release()

    def close(self) -> None:
        """Stop every worker (jobs still running are killed)."""
        with self._lock:
            self._closed = True
            idle, busy = self._idle, self._busy
            self._idle, self._busy = [], []
        for worker in idle:
            worker.stop()
        for worker in busy:
            worker.kill()


# ---------------------------------------------------------------------------------- jobs
def derive_in_worker(robot, known=None, progress=None):
    """A cold derivation in a worker: derives and writes the disk cache, from which the server
    then reads the model (``derive``); returns the model itself only when the disk cache could not
    take it (no cache folder, an expression its text cannot carry)."""
    from app.core.dynamics import cache_entry_path, derive
    dyn = derive(robot, progress=progress, known=known)
    path = cache_entry_path(robot, known)
    return None if path is not None and path.is_file() else dyn
