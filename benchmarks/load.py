"""A class on one server (issue 15): many light clients speaking viser's websocket protocol move
their robot's first joint while heavy clients load the server, timing each slider change to the
new pose.

Run: ``python -m benchmarks.load`` (about 2 minutes; ``--clients 40 --seconds 60``). The lab runs
as ``python -m app serve`` in its own process with an empty derivation cache, so the clients in
this process do not share its interpreter lock. Each light client is what a browser tab is to the
server: it opens the websocket, reports its camera and its address (``?robot=planar_2r``), then
every 0.5-1.5 s (seeded) sets the q1 slider to a value of its own and waits for the scene update
that turns ``link1`` to that angle; the time between is one latency sample. Phases:

1. the light clients alone (``--baseline`` s);
2. the same while three heavy clients work (``--seconds`` s): one switches its tab through robots
   never derived (each a cold derivation), one runs the throw optimizer again and again (the
   Throw studio's Optimize button), one types the power tower ``((((9**64)**64)**64)**64)`` into
   a parameter field every 2 s.

Beside them one real browser tab (headless Chromium, ``--no-browser`` to leave it out) presses an
arrow key on its q1 slider every 0.5-1.5 s and times the key press until the page's 3D scene holds
the new pose of link 1: the latency a student sees, measured in both phases.

Checked and printed: p50/p95/max latency per phase, samples lost (no pose within 10 s), the
heavy clients' work done (derivations, optimizer runs, towers refused), per-client independence
(every link1 angle a client receives is one it set itself, or its initial 0), the server's
resident memory (RSS) after the clients connected, at its peak, at the end and 5 s after every
client left, the peak RSS of its worker processes (app/viewer/worker.py, where the heavy jobs
run), the CPU time of the server's own process and of its workers in each phase (on a shared
machine wall-clock latencies follow the other jobs; CPU time does not), and the load average at
each phase's start and end. ``--switch-interval 0.005`` starts the server with another
interpreter-lock switch interval (to compare; ``serve`` sets 0.001 s, Python's default is 0.005 s);
``R2LOAD_DEBUG=1`` prints lost samples and the clients' connection errors.
"""
from __future__ import annotations

import argparse
import math
import os
import random
import socket
import subprocess
import sys
import tempfile
import threading
import time
import urllib.request
from pathlib import Path
from typing import Dict, List, Optional

import msgspec
import numpy as np
import viser
import zstandard
from websockets.sync.client import connect

ROOT = Path(__file__).resolve().parents[1]
PROTOCOL = [f"viser-v{viser.__version__}"]
TOWER = "((((9**64)**64)**64)**64)"
#: robots the deriving client switches through (none of them is derived before: the cache is empty)
COLD_ROBOTS = ("planar_4r", "viewer_demo_spatial_3r", "spatial_3r_2017_03_29", "rrpr_2021_02_04", "planar_3r",
               "cylindrical_rpp_2017_07_11", "polar_2r_2016_06_06", "planar_rpr", "planar_prr", "planar_ppr",
               "spatial_3r_2022_04_13", "spatial_3r_2024_06_12")
LOST_AFTER = 10.0


def _angle_gap(a: float, b: float) -> float:
    """|a - b| modulo 2 pi (a pose's quaternion gives the angle only modulo 2 pi)."""
    return abs((a - b + math.pi) % (2.0 * math.pi) - math.pi)


def _rss_mb(pid: int) -> float:
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    return float("nan")


def _children(pid: int) -> List[int]:
    """Process ids of ``pid``'s children (the server's worker processes)."""
    out = []
    for task in Path(f"/proc/{pid}/task").glob("*"):
        try:
            out += [int(c) for c in (task / "children").read_text().split()]
        except (OSError, ValueError):
            pass
    return out


def _cpu_s(pid: int, children: bool = False) -> float:
    """CPU seconds (user + system) of a process; with ``children`` those of its children that
    ended (and were waited for) too."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except (OSError, IndexError):
        return 0.0
    ticks = os.sysconf("SC_CLK_TCK")
    used = int(fields[11]) + int(fields[12]) + ((int(fields[13]) + int(fields[14])) if children else 0)
    return used / ticks


class CpuMeter:
    """CPU seconds of the server's own process and of its worker processes (those alive, plus
    those that ended), between ``start()`` and ``stop()``."""

    def __init__(self, pid: int):
        self.pid, self.seen = pid, {}

    def _sample(self):
        for child in _children(self.pid):
            self.seen[child] = _cpu_s(child)
        own = _cpu_s(self.pid)
        workers = (_cpu_s(self.pid, children=True) - own
                   + sum(v for c, v in self.seen.items() if Path(f"/proc/{c}").exists()))
        return own, workers

    def start(self):
        self.seen = {}
        self.begin = self._sample()

    def stop(self):
        end = self._sample()
        self.server, self.workers = end[0] - self.begin[0], end[1] - self.begin[1]


class Client:
    """One tab: a websocket, a reader thread decoding viser's frames, the widgets by label."""

    HELLO = {"type": "ViewerCameraMessage", "wxyz": [1.0, 0.0, 0.0, 0.0], "position": [0.0, -3.0, 1.0],
             "fov": 1.0, "near": 0.01, "far": 100.0, "image_height": 480, "image_width": 640,
             "look_at": [0.0, 0.0, 0.0], "up_direction": [0.0, 0.0, 1.0]}

    def __init__(self, port: int, query: Optional[str]):
        """``query``: the address the tab reports at once (``?robot=...``), or None for none."""
        self.ws = connect(f"ws://127.0.0.1:{port}", subprotocols=PROTOCOL, max_size=None, open_timeout=60,
                          additional_headers={"Origin": f"http://127.0.0.1:{port}"})
        self.widgets: Dict[str, dict] = {}          # label -> last message adding it
        self.by_uuid: Dict[str, dict] = {}
        self.link1: List[float] = []                 # q1 seen in every link1 orientation received
        self.texts: List[str] = []                   # notification titles and bodies
        self.cond = threading.Condition()
        self.closed = self.closing = False
        self._zstd = zstandard.ZstdDecompressor()
        self.reader = threading.Thread(target=self._read, daemon=True)
        self.reader.start()
        self.send(self.HELLO)
        self.report = self.wait_widget("r2-page-report", 120)
        if query is not None:
            self.update(self.report, f"url {query}")

    def send(self, message: dict) -> None:
        self.ws.send(msgspec.msgpack.encode(message))

    def update(self, widget: dict, value) -> None:
        self.send({"type": "GuiUpdateMessage", "uuid": widget["uuid"], "updates": {"value": value}})

    def _read(self) -> None:
        try:
            while True:
                frame = self.ws.recv()
                if not isinstance(frame, bytes):
                    continue
                size, packed = int.from_bytes(frame[:8], "little"), int.from_bytes(frame[8:16], "little")
                payload = msgspec.msgpack.decode(self._zstd.decompress(frame[16:16 + packed], max_output_size=size))
                with self.cond:
                    for m in payload["messages"]:
                        self._take(m)
                    self.cond.notify_all()
        except Exception as exc:
            if os.environ.get("R2LOAD_DEBUG") and not self.closing:
                import traceback
                traceback.print_exc()
            self.error = exc
            with self.cond:
                self.closed = True
                self.cond.notify_all()

    def _take(self, m: dict) -> None:
        kind = m.get("type", "")
        if kind == "SetOrientationMessage" and m["name"].endswith("/link1"):
            w, _, _, z = m["wxyz"]
            self.link1.append(2.0 * math.atan2(z, w))
        elif kind.startswith("Gui") and isinstance(m.get("props"), dict) and "uuid" in m:
            self.by_uuid[m["uuid"]] = m
            label = m["props"].get("label")
            if label is not None:
                self.widgets[str(label)] = m
        elif kind == "GuiRemoveMessage":
            gone = self.by_uuid.pop(m.get("uuid"), None)
            if gone is not None and self.widgets.get(str(gone["props"].get("label"))) is gone:
                del self.widgets[str(gone["props"]["label"])]
        elif kind == "GuiUpdateMessage" and m.get("uuid") in self.by_uuid:
            updates = m.get("updates", {})
            self.by_uuid[m["uuid"]].setdefault("props", {}).update({k: v for k, v in updates.items() if k != "value"})
            if "data-r2-drawn" in str(updates.get("content", "")):     # as the page does once it has drawn
                self.update(self.report, "drawn")                        # the robot: the panels wait for it
        elif kind in ("NotificationShowMessage", "NotificationUpdateMessage"):
            props = m.get("props", {})
            self.texts.append(f"{props.get('title', '')}: {props.get('body', '')}")

    def wait(self, condition, timeout: float):
        end = time.monotonic() + timeout
        with self.cond:
            while True:
                value = condition()
                if value or self.closed:
                    return value
                left = end - time.monotonic()
                if left <= 0:
                    return value
                self.cond.wait(left)

    def wait_widget(self, label: str, timeout: float, prefix: bool = False) -> Optional[dict]:
        def found():
            if prefix:
                return next((w for k, w in self.widgets.items() if k.startswith(label)), None)
            return self.widgets.get(label)
        return self.wait(found, timeout)

    def close(self) -> None:
        self.closing = True
        try:
            self.ws.close()
        except Exception:
            pass


class LightClient(Client):
    def __init__(self, port: int, index: int, seed: int):
        super().__init__(port, "?robot=planar_2r")
        self.index = index
        self.rng = random.Random(seed * 1000 + index)
        self.slider = self.wait_widget("q1", 180)
        if self.slider is None:
            raise RuntimeError(f"client {index}: no q1 slider after 180 s")
        self.sent: List[float] = [0.0]
        self.samples: List[tuple] = []       # (phase, seconds or None when lost)
        self.phase = "baseline"
        self.stop = threading.Event()

    def value(self) -> float:
        # distinct per client: a client's angles are its index's own lattice (independence check),
        # never the value it set last (an unchanged value sends no pose)
        while True:
            value = round(-3.0 + 0.0021 * self.index + 0.1 * self.rng.randrange(1, 60), 4)
            if abs(value - self.sent[-1]) > 1e-9:
                return value

    def round_trip(self, timeout: float) -> Optional[float]:
        """Move q1 to a new value of this client's; seconds until link1's pose at that angle comes
        back (None after ``timeout``)."""
        target = self.value()
        with self.cond:
            seen = len(self.link1)
        self.sent.append(target)
        start = time.perf_counter()
        self.update(self.slider, target)
        got = self.wait(lambda: any(_angle_gap(q, target) < 1e-6 for q in self.link1[seen:]), timeout)
        if not got and os.environ.get("R2LOAD_DEBUG"):
            print(f"client {self.index}: lost {target}; received since {self.link1[seen:]}", flush=True)
        return time.perf_counter() - start if got else None

    def run(self) -> None:
        while not self.stop.is_set():
            self.samples.append((self.phase, self.round_trip(LOST_AFTER)))
            self.stop.wait(self.rng.uniform(0.5, 1.5))

    def foreign_angles(self) -> int:
        """link1 angles received that this client never set."""
        foreign = [q for q in self.link1 if min(_angle_gap(q, s) for s in self.sent) > 1e-6]
        if foreign and os.environ.get("R2LOAD_DEBUG"):
            print(f"client {self.index}: foreign {foreign[:5]}; sent {self.sent[:8]}", flush=True)
        return len(foreign)


def _titles() -> Dict[str, str]:
    from app.core.robot import load_robot
    return {name: load_robot(name).title for name in COLD_ROBOTS}


def deriving_client(port: int, stop: threading.Event, log: dict) -> None:
    """Switches its tab through robots never derived; counts derivations finished."""
    titles = _titles()
    c = Client(port, "?robot=planar_pr")
    try:
        picker = c.wait_widget("Robot", 120)
        for name in COLD_ROBOTS:
            if stop.is_set():
                break
            option = next(o for o in picker["props"]["options"] if titles[name] in o)
            start = time.perf_counter()
            c.update(picker, option)
            # the panels' tab group is built once the model is there: wait for the Model tab's math
            status = f'data-ready="1" data-robot="{name}"'      # the page's status element, once built
            ok = c.wait(lambda: any(status in str(w["props"].get("content", "")) for w in list(c.by_uuid.values())),
                        120)
            log["derivations"].append((name, time.perf_counter() - start if ok else None))
    finally:
        c.close()


def optimizing_client(port: int, stop: threading.Event, log: dict) -> None:
    """Clicks the Throw studio's Optimize again and again; counts runs finished."""
    c = Client(port, "?robot=throwing_arm&tab=throw")
    try:
        button = c.wait_widget("Optimize", 180)
        if button is None:
            log["optimizer"].append(None)
            return
        while not stop.is_set():
            start = time.perf_counter()
            c.send({"type": "GuiUpdateMessage", "uuid": button["uuid"], "updates": {"value": True}})
            c.wait(lambda: button["props"].get("disabled") is True, 10)
            ok = c.wait(lambda: button["props"].get("disabled") is False, 120)
            log["optimizer"].append(time.perf_counter() - start if ok else None)
    finally:
        c.close()


def tower_client(port: int, stop: threading.Event, log: dict) -> None:
    """Types the power tower into the m1 field every 2 s; counts the refusals received."""
    c = Client(port, "?robot=planar_2r")
    try:
        field = c.wait_widget("m1", 180, prefix=True)
        while not stop.is_set():
            c.update(field, TOWER)
            log["towers"] += 1
            stop.wait(1.0)
            c.update(field, "2")            # a typed value: the next tower is a change again
            stop.wait(1.0)
        log["tower_refusals"] = sum(1 for t in c.texts if "not changed" in t or "too large" in t)
    finally:
        c.close()


def browser_client(port: int, phase: List[str], samples: List[tuple], ready: threading.Event,
                   stop: threading.Event, seed: int) -> None:
    """One real tab on planar_2r: arrow key on the q1 slider -> link1's new pose in the page's scene."""
    from app.viewer import screenshot as shots
    rng = random.Random(seed)
    changed = ("([name, w, z]) => { const o = window.__viserMutable.nodeRefFromName[name];"
               " return o !== undefined && (Math.abs(o.quaternion.w - w) > 1e-9 || Math.abs(o.quaternion.z - z) > 1e-9); }")
    pose = "(name) => { const o = window.__viserMutable.nodeRefFromName[name]; return [o.quaternion.w, o.quaternion.z]; }"
    with shots.Browser() as browser:
        page = browser.page(f"http://127.0.0.1:{port}/?robot=planar_2r")
        shots.wait_ready(page, "planar_2r", timeout=300)
        name = page.evaluate("() => Object.keys(window.__viserMutable.nodeRefFromName)"
                             ".find(n => n.startsWith('/robot/') && n.endsWith('/link1'))")
        thumb = shots.slider_thumb(page, "q1")
        thumb.focus()
        ready.set()
        step = 0
        while not stop.is_set():
            w, z = page.evaluate(pose, name)
            key = "ArrowRight" if (step // 20) % 2 == 0 else "ArrowLeft"       # back and forth in its range
            start = time.perf_counter()
            thumb.press(key)
            try:
                page.wait_for_function(changed, arg=[name, w, z], timeout=LOST_AFTER * 1000)
                samples.append((phase[0], time.perf_counter() - start))
            except Exception:
                samples.append((phase[0], None))
            step += 1
            stop.wait(rng.uniform(0.5, 1.5))


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def percentiles(values) -> str:
    if not values:
        return "no samples"
    a = np.array(values) * 1000.0
    return f"p50 {np.percentile(a, 50):.0f} ms, p95 {np.percentile(a, 95):.0f} ms, max {a.max():.0f} ms ({a.size} samples)"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.load", description=__doc__.split("\n\n")[0])
    parser.add_argument("--clients", type=int, default=40)
    parser.add_argument("--seconds", type=float, default=60.0, help="length of the loaded phase")
    parser.add_argument("--baseline", type=float, default=15.0, help="length of the phase without heavy clients")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--no-browser", action="store_true", help="leave out the real browser tab")
    parser.add_argument("--switch-interval", type=float, default=None,
                        help="the server's sys.setswitchinterval (how long a thread holds the interpreter lock "
                             "before another may take it; serve's own is 0.001 s, Python's default 0.005 s)")
    args = parser.parse_args(argv)
    wall0 = time.perf_counter()
    port = _free_port()
    cache = tempfile.mkdtemp(prefix="r2load-cache")
    env = {**os.environ, "R2LAB_CACHE": cache}
    log_file = open(Path(cache) / "server.log", "w")
    command = [sys.executable, "-m", "app", "serve", "--port", str(port)]
    if args.switch_interval is not None:
        command = [sys.executable, "-c", f"import sys; sys.setswitchinterval({args.switch_interval!r}); "
                   f"from app.cli import main; sys.exit(main(['serve', '--port', '{port}']))"]
    server = subprocess.Popen(command, cwd=ROOT, env=env,
                              stdout=subprocess.DEVNULL, stderr=log_file)
    rss = {}
    peak = [0.0]
    sampling = threading.Event()

    worker_peak = [0.0]
    meter = CpuMeter(server.pid)

    def sample_rss():
        while not sampling.wait(0.5):
            peak[0] = max(peak[0], _rss_mb(server.pid))
            worker_peak[0] = max(worker_peak[0], sum(_rss_mb(c) for c in _children(server.pid)))
            meter.seen.update({c: _cpu_s(c) for c in _children(server.pid)})

    threading.Thread(target=sample_rss, daemon=True).start()
    clients: List[LightClient] = []
    try:
        for _ in range(600):
            try:
                with urllib.request.urlopen(f"http://127.0.0.1:{port}/", timeout=5) as page:
                    page.read(100)
                break
            except OSError:
                time.sleep(0.1)
        rss["started"] = _rss_mb(server.pid)
        meter.start()
        own0 = time.process_time()
        t = time.perf_counter()
        for i in range(args.clients):
            clients.append(LightClient(port, i, args.seed))
        connect_s = time.perf_counter() - t
        rss["connected"] = _rss_mb(server.pid)
        print(f"{args.clients} light clients connected in {connect_s:.1f} s; server RSS {rss['connected']:.0f} MB "
              f"(at start {rss['started']:.0f} MB)", flush=True)
        threads = [threading.Thread(target=c.run, daemon=True) for c in clients]
        browser_phase, browser_samples, browser_ready, browser_stop = ["baseline"], [], threading.Event(), threading.Event()
        if not args.no_browser:
            threads.append(threading.Thread(target=browser_client, daemon=True, args=(
                port, browser_phase, browser_samples, browser_ready, browser_stop, args.seed)))
        for th in threads:
            th.start()
        if not args.no_browser and not browser_ready.wait(300):
            print("the browser tab did not become ready within 300 s", flush=True)
        meter.stop()
        connect_cpu = (meter.server, meter.workers)
        meter.start()
        baseline_load = os.getloadavg()[0]
        time.sleep(args.baseline)
        meter.stop()
        baseline_cpu = (meter.server, meter.workers, time.process_time() - own0)
        for c in clients:
            c.phase = "loaded"
        browser_phase[0] = "loaded"
        meter.start()
        own1 = time.process_time()
        loaded_wall = time.perf_counter()
        stop = threading.Event()
        log = {"derivations": [], "optimizer": [], "towers": 0, "tower_refusals": 0}
        heavy = [threading.Thread(target=fn, args=(port, stop, log), daemon=True)
                 for fn in (deriving_client, optimizing_client, tower_client)]
        load0 = os.getloadavg()[0]
        for th in heavy:
            th.start()
        time.sleep(args.seconds)
        stop.set()
        browser_stop.set()
        for c in clients:
            c.stop.set()
        for th in threads + heavy:
            th.join(LOST_AFTER + 130)
        meter.stop()
        loaded_wall = time.perf_counter() - loaded_wall
        loaded_cpu = (meter.server, meter.workers, time.process_time() - own1)
        rss["end"] = _rss_mb(server.pid)
        load1 = os.getloadavg()[0]
        for c in clients:
            c.close()
        time.sleep(5.0)
        rss["after"] = _rss_mb(server.pid)
        sampling.set()
        # ------------------------------------------------------------------ report
        for phase in ("baseline", "loaded"):
            got = [s for c in clients for p, s in c.samples if p == phase and s is not None]
            lost = sum(1 for c in clients for p, s in c.samples if p == phase and s is None)
            print(f"slider -> pose, {phase}: {percentiles(got)}, lost {lost}")
        if not args.no_browser:
            for phase in ("baseline", "loaded"):
                got = [t for p, t in browser_samples if p == phase and t is not None]
                lost = sum(1 for p, t in browser_samples if p == phase and t is None)
                print(f"real browser tab, arrow key -> pose in its scene, {phase}: {percentiles(got)}, lost {lost}")
        per_client = [np.percentile([s for p, s in c.samples if p == "loaded" and s is not None] or [np.nan], 95)
                      for c in clients]
        print(f"per-client p95 under load: best {np.nanmin(per_client) * 1000:.0f} ms, "
              f"worst {np.nanmax(per_client) * 1000:.0f} ms")
        derived = [(n, s) for n, s in log["derivations"] if s is not None]
        print(f"heavy clients: {len(derived)} cold derivations finished "
              f"({', '.join(f'{n} {s:.1f} s' for n, s in derived)}); "
              f"optimizer runs finished: {sum(1 for s in log['optimizer'] if s is not None)} "
              f"({', '.join(f'{s:.1f} s' for s in log['optimizer'] if s is not None)}); "
              f"power towers sent {log['towers']}, refusals shown {log['tower_refusals']}")
        foreign = sum(c.foreign_angles() for c in clients)
        print(f"independence: {foreign} link1 angles received that the client had not set "
              f"(over {sum(len(c.link1) for c in clients)} received)")
        print(f"server RSS: {rss['connected']:.0f} MB with the clients connected, peak {peak[0]:.0f} MB, "
              f"{rss['end']:.0f} MB at the end, {rss['after']:.0f} MB 5 s after the clients left")
        print(f"server's worker processes: peak RSS {worker_peak[0]:.0f} MB (all of them together)")
        print(f"CPU time: connecting: server {connect_cpu[0]:.1f} s, workers {connect_cpu[1]:.1f} s; "
              f"light clients alone: server {baseline_cpu[0]:.1f} s, workers {baseline_cpu[1]:.1f} s; "
              f"loaded phase ({loaded_wall:.0f} s): server {loaded_cpu[0]:.1f} s, workers {loaded_cpu[1]:.1f} s, "
              f"this benchmark's clients {loaded_cpu[2]:.1f} s")
        print(f"load average (1 min) {baseline_load:.1f} at the light phase's start, {load0:.1f} at the loaded "
              f"phase's start, {load1:.1f} at its end; {os.cpu_count()} cores; "
              f"{time.perf_counter() - wall0:.0f} s in all")
        return 0
    finally:
        sampling.set()
        for c in clients:
            c.close()
        server.terminate()
        try:
            server.wait(10)
        except subprocess.TimeoutExpired:
            server.kill()
        log_file.close()
        errors = (Path(cache) / "server.log").read_text(errors="replace").strip()
        if errors:
            print("server's stderr (last lines):\n  " + "\n  ".join(errors.splitlines()[-30:]))


if __name__ == "__main__":
    sys.exit(main())
