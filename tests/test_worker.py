"""Heavy jobs run in worker processes (issue 15, "a class on one server").

A job of ``Session.run_in_background`` hands its heavy part to ``in_worker``: another process, so
the server's interpreter lock stays free for every other tab's slider. Checked over the websocket
as a tab sees it (the light client of benchmarks/load.py): while a job holds the interpreter lock
for 0.4 s at a time in a worker, a slider's new pose still comes back quickly; the job really ran
in another process; its Cancel and the closing of its tab kill that process. (The 40-client
figures: ``python -m benchmarks.load``, docs/viewer.md.)

This module's top level imports little: a worker imports it to find ``hold_the_lock``.
"""
import os
import pickle
import statistics
import time

from app.viewer.worker import in_worker

#: most time a slider change may take to come back as a pose while the worker is busy (a shared
#: 2-core machine under load; on a quiet one it takes 10-30 ms, and a job in a thread of the server
#: would hold each change for up to the 0.4 s of a power)
SLIDER_BOUND_S = 2.0


def hold_the_lock(seconds: float, progress) -> int:
    """Big-integer powers, each holding the interpreter lock for ~0.4 s of CPU (as sympy's
    arithmetic does), reporting between them; returns the pid of the process it ran in."""
    end = time.monotonic() + seconds
    k = 0
    while time.monotonic() < end:
        pow(3, 3_000_000)
        k += 1
        progress(min(1.0, k / 100), f"power {k}")
    return os.getpid()


def _gone(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    return False


def _client(lab):
    from benchmarks.load import LightClient
    from test_server_guard import wait_for
    before = set(lab.sessions)
    client = LightClient(lab.viser.get_port(), index=0, seed=1)      # connected, with its q1 slider
    session = lab.sessions[wait_for(lambda: set(lab.sessions) - before).pop()]
    wait_for(lambda: session.ready.is_set())
    return client, session


def _slider_round_trip(client) -> float:
    """Move q1 to a new value; seconds until the pose comes back (raises after SLIDER_BOUND_S * 5)."""
    seconds = client.round_trip(SLIDER_BOUND_S * 5)
    assert seconds is not None, f"no pose for q1 = {client.sent[-1]}"
    return seconds


def _start_heavy(lab, session, messages):
    from test_server_guard import wait_for

    def job(progress):
        def relay(fraction, message=""):
            messages.append(message)
            progress(fraction, message)
        return in_worker(hold_the_lock, 60.0, progress=relay)

    busy_before = set(lab.workers.busy_pids())
    future = session.run_in_background(job, "Holding the lock")
    pid = wait_for(lambda: messages and set(lab.workers.busy_pids()) - busy_before, timeout=60).pop()
    return future, pid


def test_a_slider_stays_quick_while_a_heavy_job_runs_in_a_worker_and_cancel_or_closing_kills_it(lab):
    from test_server_guard import wait_for
    client, session = _client(lab)
    try:
        messages = []
        future, pid = _start_heavy(lab, session, messages)
        assert pid != os.getpid() and not _gone(pid)
        latencies = [_slider_round_trip(client) for _ in range(5)]
        assert not future.done() and messages      # the job was running all along
        print("slider round trips while the worker is busy [s]:", [round(x, 3) for x in latencies])
        assert statistics.median(latencies) < SLIDER_BOUND_S / 2 and max(latencies) < SLIDER_BOUND_S, latencies
        assert client.foreign_angles() == 0
        cancelled = time.monotonic()
        future.cancel_job()
        assert future.result(timeout=10) is None           # ended quietly (JobCancelled)
        wait_for(lambda: _gone(pid), timeout=5)
        assert time.monotonic() - cancelled < 5.0 and pid not in lab.workers.pids()
        # the next job gets a new worker; closing the tab kills it
        future, pid2 = _start_heavy(lab, session, [])
        assert pid2 != pid
    finally:
        client.close()
    wait_for(lambda: _gone(pid2), timeout=10)
    assert future.result(timeout=10) is None


def test_in_worker_outside_a_job_runs_here():
    """The command line and the core's tests call the same code without a server."""
    assert in_worker(hold_the_lock, 0.0, progress=lambda f, m="": None) == os.getpid()


def test_job_slots_are_handed_out_in_turn():
    """A tab that asks again the moment its job ends does not keep another tab's job waiting: the
    server's and the worker pool's slots go first come, first served (app.viewer.worker.FairSlots)."""
    import threading
    from app.viewer.worker import FairSlots
    slots = FairSlots(1)
    slots.acquire()
    order, waiting = [], threading.Event()

    def other_tab():
        waiting.set()
        slots.acquire()
        order.append("other")
        slots.release()

    thread = threading.Thread(target=other_tab)
    thread.start()
    waiting.wait(5)
    time.sleep(0.2)                         # the other tab now waits in the queue
    for _ in range(3):                      # this tab: release and at once ask again, three times
        slots.release()
        slots.acquire()
        order.append("greedy")
    slots.release()
    thread.join(5)
    assert order[0] == "other", order


class _Pipe:
    """A worker's end of its pipe: one call to run, then the end; ``send`` fails as given."""

    def __init__(self, *failures):
        self.calls, self.failures, self.sent = [(abs, (-2,), {})], list(failures), []

    def recv(self):
        return self.calls.pop(0) if self.calls else None

    def send(self, reply):
        if self.failures:
            raise self.failures.pop(0)
        self.sent.append(reply)


def test_a_result_that_does_not_pickle_is_reported_and_a_closed_pipe_ends_the_worker_quietly():
    from app.viewer import worker
    pipe = _Pipe(pickle.PicklingError("cannot pickle 'generator' object"))
    worker._serve(pipe, 0)
    assert pipe.sent == [("unportable", "the result of abs does not pickle: cannot pickle 'generator' object")]
    pipe = _Pipe(BrokenPipeError(32, "Broken pipe"))          # the server stopped meanwhile
    worker._serve(pipe, 0)                                      # returns, nothing printed, nothing raised
    assert pipe.sent == []
