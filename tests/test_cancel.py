"""Long work stops when asked (issue 15, server item 4).

Every long computation of the page (cold derivation, the Control tab's simulation, the throw
optimizer, the full-dynamics verification, the closed-loop Monte Carlo) runs through
``Session.run_in_background``, whose progress bar carries a Cancel button; a click makes the job's
next ``progress`` call raise ``JobCancelled``. So each computation must call its progress often and
let the exception through: checked here through the core API, with the gaps between progress calls
measured in CPU time of the working thread (a busy machine does not stretch them). The button
itself is clicked over the websocket, as a browser does.
"""
import threading
import time

import pytest
from websockets.sync.client import connect

from app.viewer import JobCancelled
from test_server_guard import PROTOCOL, say_hello, send_update, wait_for, ws_url

# most CPU time a computation may spend between two progress calls (measured: at most 0.15 s of
# wall time for derivations and simulations, 0.5 s for the optimizer and the verification, on the
# 2-core machine under load)
MAX_GAP_CPU_S = 1.5


class StopAfter:
    """A progress callback that raises JobCancelled at its ``calls``-th call (or at the first
    message containing ``until``), recording the CPU time of this thread at each call."""

    def __init__(self, calls: int, until: str = ""):
        self.calls, self.until, self.times, self.messages = calls, until, [time.thread_time()], []

    def __call__(self, fraction, message=""):
        self.times.append(time.thread_time())
        self.messages.append(message)
        if len(self.messages) >= self.calls or (self.until and self.until in message):
            raise JobCancelled("stop")

    def largest_gap(self) -> float:
        return max(b - a for a, b in zip(self.times, self.times[1:]))


def stops(work, calls, until=""):
    progress = StopAfter(calls, until)
    with pytest.raises(JobCancelled):
        work(progress)
    assert len(progress.messages) == calls or until in progress.messages[-1]     # nothing reported after the stop
    assert progress.largest_gap() < MAX_GAP_CPU_S, (progress.largest_gap(), progress.messages)
    return progress


def test_a_cold_derivation_stops():
    from app.core.dynamics import derive
    from app.core.robot import load_robot
    robot = load_robot("planar_3r")
    progress = stops(lambda p: derive(robot, progress=p, use_cache=False), calls=4)
    assert "energy" in progress.messages[-1]


def test_the_control_simulation_stops():
    from app.core.sim import simulate
    progress = stops(lambda p: simulate("planar_2r", "computed_torque", duration=120.0, progress=p), calls=5)
    assert progress.messages[-1].startswith("t = ")       # stopped a few seconds into 120 s


def test_the_throw_optimizer_stops_in_each_stage():
    from app.core.throw.arm import ThrowingArm
    from app.core.throw.optimize import ThrowOptimizer
    arm = ThrowingArm()
    # the speed-limit bound and drawing the swings report (then scoring them and the local search:
    # both report by the clock, from every batch of evaluations)
    progress = stops(lambda p: ThrowOptimizer(arm, objective="thesis").run(seed=0, progress=p), calls=100,
                     until="evaluations")
    said = " ".join(progress.messages)
    assert "speed-limit bound: polish" in said and "swings drawn" in said


def test_the_full_dynamics_verification_stops():
    from app.core.throw.simulation import simulate_full
    from app.lab import throw
    spec = throw("throw1")
    progress = stops(lambda p: simulate_full(spec, "computed_torque", progress=p), calls=6)
    assert "t = " in progress.messages[-1]


def test_the_closed_loop_monte_carlo_stops():
    from app.core.throw.closed_loop import CONTROLLERS
    from app.core.throw.plants import load_plant
    from app.core.throw.montecarlo import monte_carlo
    from app.lab import throw
    spec = throw("throw1")
    stops(lambda p: monte_carlo(spec, load_plant("heavier"), CONTROLLERS, 40, seed=0, progress=p), calls=3)


# ---------------------------------------------------------------------------------- the button
def test_the_cancel_button_stops_a_job_and_says_so(lab):
    before = set(lab.sessions)
    own = f"http://127.0.0.1:{lab.viser.get_port()}"
    with connect(ws_url(lab), subprotocols=PROTOCOL,
                 additional_headers={"Origin": own}, max_size=None) as ws:
        say_hello(ws)
        session = lab.sessions[wait_for(lambda: set(lab.sessions) - before).pop()]
        send_update(ws, session._report, {"value": "url ?robot=planar_2r"})
        wait_for(lambda: session.robot_name == "planar_2r")    # and then, as the page does once it has
        send_update(ws, session._report, {"value": "drawn"})     # drawn the robot
        wait_for(lambda: session.ready.is_set())
        state = {"calls": 0, "cancelled": 0, "finished": False}

        def job(progress):
            for k in range(3000):                    # 60 s unless stopped
                progress(k / 3000, f"step {k}")
                state["calls"] += 1
                time.sleep(0.02)
            state["finished"] = True

        def cancelled():
            state["cancelled"] += 1

        def buttons():
            return [h for h in session.gui._gui_input_handle_from_uuid.values()
                    if getattr(h._impl.props, "label", None) == "Cancel" and not h._impl.removed]

        future = session.run_in_background(job, "A long job", on_cancel=cancelled)
        button = wait_for(buttons, timeout=30)[0]       # shown with the progress bar after 0.3 s
        send_update(ws, button, {"value": True})
        clicked = time.monotonic()
        assert future.result(timeout=30) is None
        assert time.monotonic() - clicked < 5.0
        assert state["cancelled"] == 1 and not state["finished"] and state["calls"] < 3000
        wait_for(lambda: not buttons(), timeout=10)     # the bar and its button are gone
        # the tab keeps working: the next job runs to its end
        assert session.run_in_background(lambda progress: 42, "A short job").result(timeout=30) == 42
        # ``cancel_job`` on the future does what the button does
        state.update(calls=0, cancelled=0)
        future = session.run_in_background(job, "Another long job", on_cancel=cancelled)
        wait_for(lambda: state["calls"] > 2, timeout=30)
        future.cancel_job()
        assert future.result(timeout=30) is None and state["cancelled"] == 1 and not state["finished"]


def test_a_job_stops_when_its_tab_closes(lab):
    """Server item 4 (part): the tab's work stops when the tab goes away."""
    before = set(lab.sessions)
    own = f"http://127.0.0.1:{lab.viser.get_port()}"
    running, stopped = threading.Event(), threading.Event()
    with connect(ws_url(lab), subprotocols=PROTOCOL,
                 additional_headers={"Origin": own}, max_size=None) as ws:
        say_hello(ws)
        session = lab.sessions[wait_for(lambda: set(lab.sessions) - before).pop()]

        def job(progress):
            try:
                for k in range(3000):
                    progress(k / 3000)
                    running.set()
                    time.sleep(0.02)
            finally:
                stopped.set()

        session.run_in_background(job, "A long job")
        assert running.wait(30)
    assert stopped.wait(10)
