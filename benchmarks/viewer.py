"""The viewer in headless Chromium (software WebGL, like CI): what a user waits for when starting the
lab and switching robots, each beside viser's own minimal app in the same run, CPU time beside wall
time (a busy machine inflates wall time much more than CPU time).

- server up, first frame, ready: ``python -m app serve --port 0`` in its own process, as a user
  starts it (a derivation cache filled by an earlier start, so planar 2R is not derived again): from
  starting the process until it prints its address (server up), then from server up until a
  fresh browser tab has drawn the robot (first frame: timed in the page, the second animation
  frame after its first link is in the scene, confirmed by a picture holding the link's colour;
  pictures alone took 0.2-1 s each while the page loads, which hid when the frame came) and until
  its panels are built (ready: the second animation frame after the page's ready marker, timed in
  the page). CPU: the server process's (at server up and at ready). Baseline: viser's minimal app (a process that starts ``viser.ViserServer`` and adds one
  box of the same colour), timed the same way.
- switch: from choosing another robot (``session.load_robot``, what the picker calls) until the
  browser shows the new robot with its panels built (the second animation frame after the page's
  ready marker names the robot, timed in the page; Playwright's wait for the marker, which
  answered 0.1-0.25 s later, only confirms it), for every robot of ``SWITCH`` (both arms
  among them; ``--all-robots``: every shipped robot): first after a restart (derived before: the
  disk caches are filled, the process's memory caches empty) before the server's idle warm-up
  reached the robot, then once the warm-up (``LabServer.warm_up(every_robot=True)``, what ``serve``
  starts) is done, then again (memory); the warm-up's own time and CPU beside. CPU: the
  benchmark process's, which holds the server, and its worker processes' (the browser's own work
  is not in it). Cold: empty
  memory and disk caches (derivation, compilation and drawing from scratch).
- drag: the mouse drags the q1 slider for 3 s; counted are the slider updates the server
  receives, the poses it applies, and the distinct poses the browser renders per second. In
  software WebGL the browser itself is the bottleneck (it renders a frame per mouse move), so a
  synthetic drag feeds 1000 slider updates per second straight into the session's handler with
  the browser attached; and the server alone pushes poses as fast as it can (its capacity).

Goals (issue 16): server up <= 2 s; first frame <= 2 s and ready <= 3 s after the server is up;
a cached robot switch <= 0.5 s for every shipped robot.

Run: ``python -m benchmarks.viewer [--all-robots] [--repeats N]`` (needs /usr/bin/chromium).
Numbers go to docs/viewer.md.
"""
from __future__ import annotations

import argparse
import colorsys
import os
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SWITCH = ["rp_2004_03_25", "viewer_demo_spatial_3r", "spatial_3r_2017_03_29", "throwing_arm", "catching_arm",
          "planar_2r"]
COLD = ["planar_3r", "viewer_demo_spatial_3r"]
GOAL_UP, GOAL_FRAME, GOAL_READY, GOAL_SWITCH = 2.0, 2.0, 3.0, 0.5
TICK = os.sysconf("SC_CLK_TCK")

#: viser's own minimal app: a server and one box in the lab's first link colour
VISER_APP = """
import sys, time, viser
server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
server.scene.add_box("/box", color=(70, 114, 196), dimensions=(0.5, 0.5, 0.5))     # app.scene.PALETTE[0]
print(f"open http://127.0.0.1:{server.get_port()}/", flush=True)
while True:
    time.sleep(3600)
"""


def _process_cpu(pid: int) -> float:
    """User + system CPU seconds of a running process (Linux /proc)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / TICK


def _robot_on_canvas(page) -> bool:
    import imageio.v3 as iio
    from app.scene import PALETTE
    try:      # software WebGL under load: a picture may take longer than playwright's 30 s
        shot = page.screenshot(timeout=120000)
    except Exception:
        return False
    img = iio.imread(shot, extension=".png")[:, :800, :3].reshape(-1, 3)[::7].astype(float) / 255
    target = colorsys.rgb_to_hsv(*(np.asarray(PALETTE[0]) / 255))[0]
    hue, saturation = _hue_saturation(img)
    hits = (saturation > 0.3) & (np.minimum(abs(hue - target), 1 - abs(hue - target)) < 0.04)
    return int(hits.sum()) > 20


def _hue_saturation(rgb: np.ndarray) -> tuple:
    """Hue and saturation (as ``colorsys.rgb_to_hsv``) of an N x 3 array of RGB in [0, 1], at once
    (a Python loop over the pixels took about 0.3 s per picture: the first frame came later than seen).

    >>> h, s = _hue_saturation(np.array([[0.2, 0.4, 0.8], [0.5, 0.5, 0.5]]))
    >>> f"{h[0]:.4f} {s[0]:.4f} {s[1]:.1f}", "%.4f %.4f" % colorsys.rgb_to_hsv(0.2, 0.4, 0.8)[:2]
    ('0.6111 0.7500 0.0', '0.6111 0.7500')
    """
    high, low = rgb.max(axis=1), rgb.min(axis=1)
    span = high - low
    saturation = np.where(high > 0, span / np.where(high > 0, high, 1), 0.0)
    safe = np.where(span > 0, span, 1)
    r, g, b = ((high - rgb[:, k]) / safe for k in range(3))
    hue = np.where(rgb[:, 0] == high, b - g, np.where(rgb[:, 1] == high, 2.0 + r - b, 4.0 + g - r))
    hue = np.where(span > 0, (hue / 6.0) % 1.0, 0.0)
    return hue, saturation


def _lab(**options):
    """A lab server with the page's panels, as ``python -m app serve`` starts it."""
    from app.commands.serve import lab_server
    return lab_server(port=0, **options)


#: installed in the page before it loads: the time (epoch ms) of the second animation frame after a
#: scene node whose name ends with SUFFIX is in viser's scene (that frame has drawn it)
FIRST_FRAME_JS = """(() => { const look = () => {
  const refs = window.__viserMutable && window.__viserMutable.nodeRefFromName;
  if (refs && Object.keys(refs).some(n => n.endsWith("SUFFIX") && refs[n])) {
    requestAnimationFrame(() => requestAnimationFrame(() => {
      window.__r2FirstFrame = performance.timeOrigin + performance.now(); }));
    return; }
  requestAnimationFrame(look); };
  requestAnimationFrame(look); })()"""


#: installed in the page: for each robot and generation the ready marker names, the time (epoch ms)
#: of the second animation frame after the marker says ready (that frame shows the new robot and
#: its panels). Playwright's own wait noticed the marker 0.1-0.25 s late on a busy page (it polls
#: on animation frames and answers through its driver), which hid how soon the page was ready.
READY_JS = """(() => { if (window.__r2Ready) return; window.__r2Ready = {};
  const look = () => {
    const el = document.querySelector('.r2-status[data-ready="1"]');
    if (!el) return;
    const key = el.getAttribute('data-robot') + ':' + el.getAttribute('data-generation');
    if (key in window.__r2Ready) return;
    window.__r2Ready[key] = null;
    requestAnimationFrame(() => requestAnimationFrame(() => {
      window.__r2Ready[key] = performance.timeOrigin + performance.now(); })); };
  const start = () => { new MutationObserver(look).observe(document.documentElement,
    {subtree: true, childList: true, attributes: true, characterData: true}); look(); };
  if (document.documentElement) start(); else document.addEventListener('DOMContentLoaded', start); })()"""


def _ready_at(page, robot: str, generation) -> float:
    """Epoch seconds of the frame that showed ``robot`` (of ``generation``) ready (READY_JS)."""
    key = f"{robot}:{generation}"
    page.wait_for_function(f"() => window.__r2Ready && window.__r2Ready[{key!r}]", timeout=120000)
    return page.evaluate(f"() => window.__r2Ready[{key!r}]") / 1000.0


def start_to_ready(browser, args, env, ready: bool = True, node_suffix: str = "/link1") -> dict:
    """Start a server process (``python ARGS``) and open its page: wall and CPU figures. First
    frame: the second animation frame after the scene node ``…node_suffix`` exists in the page
    (timed in the page), confirmed by a picture holding its colour."""
    from app.viewer.screenshot import wait_ready
    t0 = time.perf_counter()
    proc = subprocess.Popen([sys.executable, *args], cwd=ROOT, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.DEVNULL, text=True)
    try:
        line = proc.stdout.readline()
        while line and "open http" not in line:       # viser's banner comes first in its own app
            line = proc.stdout.readline()
        up = time.perf_counter() - t0
        up_cpu = _process_cpu(proc.pid)
        url = line[line.index("http"):].split()[0]
        t1, t1_epoch = time.perf_counter(), time.time()
        context = browser.browser.new_context(viewport={"width": 1280, "height": 720}, device_scale_factor=1)
        context.add_init_script(FIRST_FRAME_JS.replace("SUFFIX", node_suffix))
        context.add_init_script(READY_JS)
        page = context.new_page()
        page.goto(url)
        frame = float("nan")                       # not drawn within 120 s
        from playwright.sync_api import TimeoutError as NotDrawn
        try:
            page.wait_for_function("() => window.__r2FirstFrame !== undefined", timeout=120000)
            drawn = page.evaluate("() => window.__r2FirstFrame") / 1000.0 - t1_epoch
            # confirmed by a picture: the robot's colour is on the canvas
            while time.perf_counter() - t1 < 120:
                if _robot_on_canvas(page):
                    frame = drawn
                    break
                page.wait_for_timeout(50)
        except NotDrawn:
            pass
        out = {"up": up, "up cpu": up_cpu, "frame": frame}
        if ready:
            wait_ready(page, "planar_2r")
            generation = page.get_attribute(".r2-status", "data-generation")
            out["ready"] = _ready_at(page, "planar_2r", generation) - t1_epoch
        out["cpu"] = _process_cpu(proc.pid)
        page.context.close()
        return out
    finally:
        proc.terminate()
        proc.wait(30)


def first_frame(browser, repeats: int = 3) -> dict:
    """Median figures of the lab and of viser's minimal app, runs interleaved."""
    with tempfile.TemporaryDirectory(prefix="r2lab-viewer-") as cache:
        env = {**os.environ, "R2LAB_CACHE": cache}
        lab_args = ["-m", "app", "serve", "--port", "0", "--robot", "planar_2r"]
        start_to_ready(browser, lab_args, env)                  # fills the derivation cache
        runs = {"lab": [], "viser": []}
        for _ in range(repeats):
            runs["lab"].append(start_to_ready(browser, lab_args, env))
            runs["viser"].append(start_to_ready(browser, ["-c", VISER_APP], env, ready=False, node_suffix="/box"))
    return {who: {key: statistics.median(r[key] for r in rs) for key in rs[0]} for who, rs in runs.items()}


def _server_cpu(lab) -> dict:
    """CPU seconds of this process (which holds the server) and of each live worker process."""
    out = {"self": time.process_time()}
    workers = getattr(lab, "workers", None)
    for pid in (workers.pids() if workers is not None else []):
        try:
            out[pid] = _process_cpu(pid)
        except (OSError, ValueError, IndexError):
            pass
    return out


def _cpu_since(lab, before: dict) -> float:
    now = _server_cpu(lab)
    return sum(value - before.get(key, 0.0) for key, value in now.items())


def _switch(page, session, name) -> tuple:
    """(wall, CPU of the server: this process and its workers) from ``load_robot`` until the
    browser shows the robot ready (the frame after the ready marker, timed in the page: READY_JS,
    installed in ``page`` by ``switching``)."""
    t0, c0 = time.time(), _server_cpu(session.lab)
    threading.Thread(target=session.load_robot, args=(name,), daemon=True).start()
    page.wait_for_selector(f'.r2-status[data-ready="1"][data-robot="{name}"]', state="attached", timeout=300000)
    cpu = _cpu_since(session.lab, c0)
    return _ready_at(page, name, session.generation) - t0, cpu


def _forget_memory(lab) -> None:
    """Empty the process's caches of models, compiled functions, drawings and typeset formulas
    (what a restarted server has); the disk cache stays."""
    import app.core.dynamics as dynamics
    import app.core.numeric as numeric
    dynamics.forget_derivations()
    numeric.forget_compiled()           # every compiled function of every robot (frames too)
    try:
        from app.viewer import html_cache
        html_cache._MEMORY.clear()
    except ImportError:
        pass
    lab._robots.clear()


def switching(browser, robots=SWITCH) -> dict:
    """Per robot, (wall, CPU) of: the first switch after a restart before the idle warm-up reached
    it ("early"), the first after a restart once the warm-up is done ("warmed"), a switch again
    ("again"), and cold switches ("cold"); "warm-up": the warm-up's (wall, CPU) from the page being
    ready until every robot is warmed."""
    from app.viewer.screenshot import new_session, wait_ready
    from app.core.dynamics import derive
    from app.core.robot import load_robot
    saved = os.environ.get("R2LAB_CACHE")
    out = {"early": {}, "warmed": {}, "again": {}, "cold": {}}
    try:
        with tempfile.TemporaryDirectory(prefix="r2lab-viewer-") as cache:
            os.environ["R2LAB_CACHE"] = cache
            for name in robots:                       # derived before: the disk cache holds them
                derive(load_robot(name))
            lab = _lab(robot="planar_2r")
            try:
                page = browser.page(lab.url + "?robot=planar_2r")
                wait_ready(page, "planar_2r")
                page.evaluate(READY_JS)
                session = new_session(lab, page)
                for name in robots:                   # warm the disk caches the page itself fills
                    _switch(page, session, name)
                _forget_memory(lab)
                for name in robots:
                    out["early"][name] = _switch(page, session, name)
                _forget_memory(lab)
                t0, c0 = time.time(), _server_cpu(lab)
                lab.warm_up(every_robot=True)         # what ``serve`` starts
                lab.warmed.wait(600)
                out["warm-up"] = (time.time() - t0, _cpu_since(lab, c0))
                for name in robots:
                    out["warmed"][name] = _switch(page, session, name)
                for name in robots:
                    out["again"][name] = _switch(page, session, name)
                for name in COLD:
                    with tempfile.TemporaryDirectory() as tmp:
                        os.environ["R2LAB_CACHE"] = tmp           # an empty disk cache
                        _forget_memory(lab)
                        out["cold"][name] = _switch(page, session, name)
                        _switch(page, session, "planar_2r")
                    os.environ["R2LAB_CACHE"] = cache
                page.context.close()
            finally:
                lab.stop()
    finally:
        if saved is None:
            os.environ.pop("R2LAB_CACHE", None)
        else:
            os.environ["R2LAB_CACHE"] = saved
    return out


def drag(browser, seconds=3.0):
    from app.viewer.screenshot import slider_thumb, wait_ready, new_session
    from app.viewer.scene_view import SceneView
    lab = _lab(robot="planar_2r")
    page = browser.page(lab.url)
    wait_ready(page, "planar_2r")
    session = new_session(lab, page)
    counts = {"updates": 0, "poses": 0}
    original_moved, original_pose = session._slider_moved, SceneView.set_pose

    def moved(event):
        counts["updates"] += 1
        original_moved(event)

    def pose(self, q):
        counts["poses"] += 1
        original_pose(self, q)

    session._sliders[0].remove_update_callback()
    session._sliders[0].on_update(moved)
    SceneView.set_pose = pose
    box = slider_thumb(page, "q1").bounding_box()
    track = page.locator("xpath=//label[normalize-space()='q1']/ancestor::div[contains(@class,'mantine-Flex-root')][1]"
                         "//*[contains(@class,'Slider-root')]").first.bounding_box()
    y = box["y"] + box["height"] / 2
    page.evaluate("(p) => { window.__r2link2 = p; }", session.scene.robot_root + "/link2")
    page.evaluate("""() => { window.__poses = new Set(); window.__sampling = true;
        const node = () => window.__viserMutable.nodeRefFromName[window.__r2link2];
        function f() { const n = node(); if (n) window.__poses.add(n.position.toArray().join(','));
                       if (window.__sampling) requestAnimationFrame(f); }
        requestAnimationFrame(f); }""")
    page.mouse.move(box["x"] + box["width"] / 2, y)
    page.mouse.down()
    t0 = time.perf_counter()
    k = 0
    while time.perf_counter() - t0 < seconds:
        frac = 0.5 + 0.45 * np.sin(2 * np.pi * k / 90)
        page.mouse.move(track["x"] + frac * track["width"], y)
        k += 1
    elapsed = time.perf_counter() - t0
    page.mouse.up()
    page.wait_for_timeout(300)
    rendered = page.evaluate("() => { window.__sampling = false; return window.__poses.size; }")
    mouse_updates, mouse_poses = counts["updates"], counts["poses"]
    SceneView.set_pose = original_pose
    # a synthetic drag at 1 kHz: slider updates straight into the session's handler (as viser
    # delivers them), with the browser attached; the coalescer applies the latest value each time
    SceneView.set_pose = pose
    counts["poses"] = 0
    slider = session._sliders[0]

    class Event:
        client, target = object(), slider

    page.evaluate("() => { window.__poses = new Set(); window.__sampling = true; }")
    page.evaluate("""() => { const node = () => window.__viserMutable.nodeRefFromName[window.__r2link2];
        function f() { const n = node(); if (n) window.__poses.add(n.position.toArray().join(','));
                       if (window.__sampling) requestAnimationFrame(f); }
        requestAnimationFrame(f); }""")
    sent, t2 = 0, time.perf_counter()
    while time.perf_counter() - t2 < seconds:
        slider._impl.value = float(2.5 * np.sin(sent / 200))
        session._slider_moved(Event())
        sent += 1
        time.sleep(0.001)
    synthetic = time.perf_counter() - t2
    page.wait_for_timeout(300)
    synthetic_rendered = page.evaluate("() => { window.__sampling = false; return window.__poses.size; }")
    SceneView.set_pose = original_pose
    # the server alone: how many poses per second can it push to this tab
    n, t1 = 0, time.perf_counter()
    while time.perf_counter() - t1 < 2.0:
        session.scene.set_pose([np.sin(n / 50), np.cos(n / 50)])
        n += 1
    push = n / (time.perf_counter() - t1)
    page.context.close()
    lab.stop()
    return {"mouse moves/s": k / elapsed, "slider updates/s": mouse_updates / elapsed,
            "poses applied/s": mouse_poses / elapsed, "poses rendered/s": rendered / elapsed,
            "synthetic slider updates/s": sent / synthetic,
            "synthetic poses applied/s": counts["poses"] / synthetic,
            "synthetic poses rendered/s": synthetic_rendered / synthetic,
            "server push capacity poses/s": push}


def figures(browser=None, robots=SWITCH, repeats: int = 3) -> list:
    """The issue-16 figures of the page: (name, wall s, CPU s or None, goal or None, baseline text)."""
    from app.viewer.screenshot import Browser
    own = browser is None
    browser = browser or Browser()
    try:
        start = first_frame(browser, repeats)
        switches = switching(browser, robots)
    finally:
        if own:
            browser.close()
    lab, base = start["lab"], start["viser"]
    out = [("page: server up (python -m app serve)", lab["up"], lab["up cpu"], GOAL_UP,
            f"viser's minimal app {base['up']:.2f} s, {base['up cpu']:.2f} s CPU"),
           ("page: first frame after server up", lab["frame"], None, GOAL_FRAME,
            f"viser's minimal app {base['frame']:.2f} s"),
           ("page: ready after server up", lab["ready"], lab["cpu"] - lab["up cpu"], GOAL_READY, "")]
    for name in robots:
        out.append((f"switch to {name}, first after restart", *switches["warmed"][name], GOAL_SWITCH,
                    f"before the idle warm-up {switches['early'][name][0]:.2f} s"))
    again = switches["again"]
    worst = max(robots, key=lambda n: again[n][0])
    out.append((f"switch again, slowest ({worst})", *again[worst], GOAL_SWITCH, "memory caches"))
    out.append(("page: idle warm-up of every robot", *switches["warm-up"], None, "from the page being ready"))
    return out


def main(argv=None):
    from app.viewer.screenshot import Browser
    parser = argparse.ArgumentParser(prog="python -m benchmarks.viewer")
    parser.add_argument("--all-robots", action="store_true", help="time the switch to every shipped robot")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--no-drag", action="store_true")
    args = parser.parse_args(argv)
    robots = SWITCH
    if args.all_robots:
        from app.core.catalog import list_robot_names
        robots = [n for n in list_robot_names() if n != "planar_2r"] + ["planar_2r"]
    print(f"load average at start: {' '.join(f'{x:.1f}' for x in os.getloadavg())}")
    with Browser() as browser:
        start = first_frame(browser, args.repeats)
        print(f"start (median of {args.repeats}, interleaved; wall s, CPU s of the server process)")
        print(f"  {'':<38}{'lab':>14}{'viser minimal app':>20}{'goal':>8}")
        lab, base = start["lab"], start["viser"]
        print(f"  {'server up (process start to address)':<38}{lab['up']:>6.2f} /{lab['up cpu']:>5.2f} CPU"
              f"{base['up']:>11.2f} /{base['up cpu']:>5.2f} CPU{GOAL_UP:>6.1f}")
        print(f"  {'first frame after server up':<38}{lab['frame']:>6.2f}{'':>8}{base['frame']:>11.2f}{'':>10}{GOAL_FRAME:>6.1f}")
        print(f"  {'ready (panels built) after server up':<38}{lab['ready']:>6.2f} /{lab['cpu'] - lab['up cpu']:>5.2f} CPU"
              f"{'':>20}{GOAL_READY:>6.1f}")
        switches = switching(browser, robots)
        print("switch robots, until the new robot and its panels are in the browser (wall s / CPU s of the "
              f"server's process and its workers; goal {GOAL_SWITCH} s). First after a restart: before the "
              "server's idle warm-up reached the robot, and once it is done")
        print(f"  {'robot':<34}{'first, before warm-up':>22}{'first, warmed':>18}{'again':>18}")
        for name in robots:
            cells = [switches[kind][name] for kind in ("early", "warmed", "again")]
            print(f"  {name:<34}" + "".join(f"{w:>{12 if k == 0 else 8}.2f} /{c:>5.2f} CPU"
                                            for k, (w, c) in enumerate(cells)))
        for name, (w, c) in switches["cold"].items():
            print(f"  cold {name:<29}{w:>12.2f} /{c:>5.2f} CPU")
        w, c = switches["warm-up"]
        print(f"  idle warm-up of every robot (from the page being ready): {w:.1f} s / {c:.1f} CPU")
        if not args.no_drag:
            rates = drag(browser)
            print("dragging the q1 slider for 3 s")
            for key, value in rates.items():
                print(f"  {key:<30} {value:8.1f}")
    print(f"load average at end: {' '.join(f'{x:.1f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
