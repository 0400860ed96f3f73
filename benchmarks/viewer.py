"""The viewer in headless Chromium (software WebGL, like CI): time to the first frame, time to switch
robots (cached and cold), and pose updates while a slider is dragged.

- first frame: from creating the server (``LabServer``, what ``python -m app`` does) and opening
  the page until the robot's link colour is on the canvas; and until the panels are built.
- switch: from choosing another robot (``session.load_robot``, what the picker calls) until the
  browser shows the new robot with its panels built (the page's ready marker), for robots already
  derived in this process (cached) and with empty memory and disk caches (cold: derivation,
  compilation and drawing from scratch).
- drag: the mouse drags the q1 slider for 3 s; counted are the slider updates the server
  receives, the poses it applies, and the distinct poses the browser renders per second. In
  software WebGL the browser itself is the bottleneck (it renders a frame per mouse move), so a
  synthetic drag feeds 1000 slider updates per second straight into the session's handler with
  the browser attached; and the server alone pushes poses as fast as it can (its capacity).

Run: ``python -m benchmarks.viewer`` (needs /usr/bin/chromium). Numbers go to docs/viewer.md.
"""
from __future__ import annotations

import colorsys
import os
import statistics
import tempfile
import threading
import time

import numpy as np

CACHED = ["planar_2r", "rp_2004_03_25", "throwing_arm", "viewer_demo_spatial_3r"]
COLD = ["planar_3r", "viewer_demo_spatial_3r"]


def _robot_on_canvas(page) -> bool:
    from app.scene import PALETTE
    from app.viewer.screenshot import image
    img = image(page)[:, :800].reshape(-1, 3)[::7].astype(float) / 255
    target = colorsys.rgb_to_hsv(*(np.asarray(PALETTE[0]) / 255))[0]
    hsv = np.array([colorsys.rgb_to_hsv(*px) for px in img])
    hits = (hsv[:, 1] > 0.3) & (np.minimum(abs(hsv[:, 0] - target), 1 - abs(hsv[:, 0] - target)) < 0.04)
    return int(hits.sum()) > 20


def first_frame(browser, robot="planar_2r"):
    from app.viewer.screenshot import wait_ready
    from app.commands.serve import lab_server
    t0 = time.perf_counter()
    lab = lab_server(port=0, robot=robot)
    listening = time.perf_counter() - t0
    page = browser.page(lab.url)
    while not _robot_on_canvas(page):
        if time.perf_counter() - t0 > 120:
            raise RuntimeError("no robot on the canvas after 120 s")
        page.wait_for_timeout(50)
    frame = time.perf_counter() - t0
    wait_ready(page, robot)
    ready = time.perf_counter() - t0
    page.context.close()
    lab.stop()
    return listening, frame, ready


def _switch(page, session, name) -> float:
    t0 = time.perf_counter()
    threading.Thread(target=session.load_robot, args=(name,), daemon=True).start()
    page.wait_for_selector(f'.r2-status[data-ready="1"][data-robot="{name}"]', state="attached", timeout=300000)
    return time.perf_counter() - t0


def switching(browser):
    from app.viewer.screenshot import new_session, wait_ready
    from app.commands.serve import lab_server
    lab = lab_server(port=0, robot=CACHED[0])
    page = browser.page(lab.url)
    wait_ready(page, CACHED[0])
    session = new_session(lab, set())
    for name in CACHED[1:] + CACHED[:1]:          # warm every robot once
        _switch(page, session, name)
    cached = {}
    for name in CACHED[1:]:
        times = []
        for _ in range(3):
            times.append(_switch(page, session, name))
            _switch(page, session, CACHED[0])
        cached[name] = statistics.median(times)
    cold = {}
    import app.core.dynamics as dynamics
    import app.core.numeric as numeric
    import app.scene as scene
    saved = os.environ.get("R2LAB_CACHE")
    for name in COLD:
        with tempfile.TemporaryDirectory() as tmp:
            os.environ["R2LAB_CACHE"] = tmp           # an empty disk cache
            dynamics.forget_derivations()
            numeric._LAMBDA_CACHE.clear()
            scene._FRAMES_CACHE.clear()
            lab._robots.clear()
            cold[name] = _switch(page, session, name)
            _switch(page, session, CACHED[0])
    if saved is None:
        os.environ.pop("R2LAB_CACHE", None)
    else:
        os.environ["R2LAB_CACHE"] = saved
    page.context.close()
    lab.stop()
    return cached, cold


def drag(browser, seconds=3.0):
    from app.viewer.screenshot import slider_thumb, wait_ready, new_session
    from app.viewer.scene_view import SceneView
    from app.commands.serve import lab_server
    lab = lab_server(port=0, robot="planar_2r")
    page = browser.page(lab.url)
    wait_ready(page, "planar_2r")
    session = new_session(lab, set())
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


def main():
    from app.viewer.screenshot import Browser
    with Browser() as browser:
        runs = [first_frame(browser) for _ in range(3)]
        listening = statistics.median(r[0] for r in runs)
        frame = statistics.median(r[1] for r in runs)
        ready = statistics.median(r[2] for r in runs)
        print("start to first frame (planar_2r, median of 3)")
        print(f"  server listening        {listening:6.2f} s")
        print(f"  robot on the canvas     {frame:6.2f} s")
        print(f"  panels built            {ready:6.2f} s")
        cached, cold = switching(browser)
        print("switch robots (until the new robot and its panels are in the browser)")
        for name, t in cached.items():
            print(f"  cached  {name:<26} {t:6.2f} s")
        for name, t in cold.items():
            print(f"  cold    {name:<26} {t:6.2f} s")
        rates = drag(browser)
        print("dragging the q1 slider for 3 s")
        for key, value in rates.items():
            print(f"  {key:<30} {value:8.1f}")


if __name__ == "__main__":
    main()
