"""Headless pictures and browser automation of the page (Debian's Chromium through Playwright).

``Browser`` opens pages in headless Chromium (software WebGL); ``open_lab_page`` waits until the
session of a tab is ready; ``capture`` starts a lab server in-process, selects a robot and a
panel, runs optional set-up code on the server side (``setup(session)``) and in the page
(``action(page)``), and saves a 1280x720 PNG. Tests and other panels' screenshot commands reuse
these pieces.
"""
from __future__ import annotations

import os
import shutil
import tempfile
import time
from pathlib import Path
from typing import Callable, Optional

CHROMIUM = os.environ.get("R2LAB_CHROMIUM", "/usr/bin/chromium")
#: no GPU here: WebGL runs in SwiftShader; the page's own raster and compositing are done in software
#: directly instead of through SwiftShader's emulated GL (5-12 % less CPU over the browser tests)
CHROMIUM_ARGS = ["--no-sandbox", "--enable-unsafe-swiftshader", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync", "--no-first-run",
                 "--disable-gpu-rasterization", "--disable-gpu-compositing"]
HIDE_NOTIFICATIONS_CSS = ".mantine-Notifications-root{display:none !important}"
WIDTH, HEIGHT = 1280, 720

#: run in a page before its own scripts when a ``Browser`` caps the 3D view's frame rate: the
#: animation frames react-three-fiber asks for (its render loop, the only callback whose source
#: names its ``frameloop``) come at most MAX_FPS times a second; every other callback runs at once
FRAME_CAP_JS = """(() => {
  const every = 1000 / MAX_FPS, native = window.requestAnimationFrame.bind(window),
        cancelNative = window.cancelAnimationFrame.bind(window), isLoop = new WeakMap(), pending = new Map();
  let ids = 1e9, last = -1e9;
  const renderLoop = (callback) => {
    if (!isLoop.has(callback)) isLoop.set(callback, String(callback).includes("frameloop"));
    return isLoop.get(callback); };
  window.requestAnimationFrame = (callback) => {
    if (typeof callback !== "function" || !renderLoop(callback)) return native(callback);
    const id = ++ids, entry = {}, wait = last + every - performance.now();
    const ask = () => { entry.frame = native((t) => {
      if (!pending.delete(id)) return;
      last = performance.now(); callback(t); }); };
    pending.set(id, entry);
    if (wait <= 0) ask(); else entry.timer = setTimeout(ask, wait);
    return id; };
  window.cancelAnimationFrame = (id) => {
    const entry = pending.get(id);
    if (!entry) return cancelNative(id);
    pending.delete(id); clearTimeout(entry.timer); if (entry.frame) cancelNative(entry.frame); };
})()"""


class Browser:
    """A headless Chromium; every ``page()`` is a fresh browser context (an independent tab) of
    ``size`` CSS pixels unless the call names another. ``max_fps`` caps the 3D view's frames a
    second (the tests: viser's page draws frames back to back for a while after every change, and
    software WebGL draws each on the CPU); without it pages draw as a user's browser does
    (pictures, benchmarks). ``shared_cache``: the tabs of scale 1 share one profile on disk, so
    that the page's scripts are compiled once (the tests: a new tab costs 2.3 s of CPU instead of
    3.3 s); their storage is shared too, which the lab's page does not use. Close a tab with
    ``close_tab``. E.g. ``with Browser((960, 540), max_fps=20) as b: b.page(lab.url)``.
    """

    def __init__(self, size: tuple = (WIDTH, HEIGHT), max_fps: Optional[float] = None, shared_cache: bool = False):
        self.size, self.max_fps = tuple(size), max_fps
        from playwright.sync_api import sync_playwright
        if not Path(CHROMIUM).exists():
            raise RuntimeError(f"{CHROMIUM} not found: install Debian's chromium (make browser)")
        self._pw = sync_playwright().start()
        self._browser = None
        self._shared = self._profile = None
        if shared_cache:
            self._profile = tempfile.mkdtemp(prefix="r2lab-chromium-")
            self._shared = self._pw.chromium.launch_persistent_context(
                self._profile, executable_path=CHROMIUM, args=CHROMIUM_ARGS, headless=True,
                viewport={"width": self.size[0], "height": self.size[1]}, device_scale_factor=1)
            self._cap(self._shared)
        #: (id of the lab, width, height) -> (page, session): a tab ``capture`` keeps for the next picture
        self.kept_tabs: dict = {}

    @property
    def browser(self):
        """Playwright's browser for contexts of their own (launched when first needed)."""
        if self._browser is None:
            self._browser = self._pw.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS, headless=True)
        return self._browser

    def _cap(self, context) -> None:
        if self.max_fps:
            context.add_init_script(FRAME_CAP_JS.replace("MAX_FPS", repr(float(self.max_fps))))

    def new_context(self, width: Optional[int] = None, height: Optional[int] = None, scale: float = 1.0):
        """A fresh browser context (its own tabs; ``close()`` closes them) of this browser's size and
        frame cap: tabs of the shared profile when there is one and ``scale`` is 1."""
        viewport = {"width": width or self.size[0], "height": height or self.size[1]}
        if self._shared is not None and scale == 1:
            return SharedProfileTabs(self._shared, viewport)
        context = self.browser.new_context(viewport=viewport, device_scale_factor=scale)
        self._cap(context)
        return context

    def page(self, url: str, width: Optional[int] = None, height: Optional[int] = None, scale: float = 1.0):
        """A new tab on ``url`` (``scale``: device pixels per CSS pixel); close it with ``close_tab``."""
        page = self.new_context(width, height, scale).new_page()
        page.goto(url)
        return page

    def close(self) -> None:
        try:
            for owner in (self._shared, self._browser):
                if owner is not None:
                    owner.close()
        finally:
            self._pw.stop()
            if self._profile:
                shutil.rmtree(self._profile, ignore_errors=True)

    def __enter__(self) -> "Browser":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


class SharedProfileTabs:
    """What a browser context is to its user (``new_page``, ``close``), for tabs opened in a
    profile other tabs share: ``close`` closes only the tabs opened through it."""

    def __init__(self, context, viewport: dict):
        self.context, self.viewport, self.pages = context, viewport, []

    def new_page(self):
        page = self.context.new_page()
        page.set_viewport_size(self.viewport)
        page.r2_tabs = self
        self.pages.append(page)
        return page

    def close(self) -> None:
        for page in self.pages:
            if not page.is_closed():
                page.close()


def close_tab(page) -> None:
    """Close a tab ``Browser.page`` opened, with the context it was opened in (only the tab
    itself when the profile is shared)."""
    tabs = getattr(page, "r2_tabs", None)
    if tabs is not None:
        tabs.close()
    else:
        page.context.close()


def wait_connected(page, timeout: float = 60.0) -> None:
    """Until viser's "Connecting..." message is gone."""
    page.wait_for_function("() => !document.body.innerText.includes('Connecting...')", timeout=timeout * 1000)


def wait_ready(page, robot: Optional[str] = None, timeout: float = 120.0) -> None:
    """Until the tab's robot (any, or ``robot``) is loaded and its panels are built."""
    wait_connected(page, timeout)
    selector = '.r2-status[data-ready="1"]' + (f'[data-robot="{robot}"]' if robot else "")
    page.wait_for_selector(selector, state="attached", timeout=timeout * 1000)
    page.evaluate("() => document.fonts.ready.then(() => true)")


def select_tab(page, title: str, timeout: float = 60.0) -> None:
    """Click a panel's tab by its title and wait until its panel is built (a tab opened for the
    first time since the robot was loaded is built then)."""
    page.get_by_role("tab", name=title, exact=True).first.click()
    page.wait_for_selector(f'.r2-panel[data-title="{title}"]', state="attached", timeout=timeout * 1000)


def selected_tab(page) -> str:
    """The title of the panel tab on display."""
    return page.evaluate("() => document.querySelector('[role=tab][aria-selected=true]').textContent.trim()")


def scroll_to_tab(page, title: str) -> None:
    """Scroll the side panel so that a tab's content starts at its top."""
    page.evaluate("""(t) => { const el = [...document.querySelectorAll('[role=tab]')]
                             .find(e => e.textContent.trim() === t);
                             if (el) el.scrollIntoView({block: 'start'}); }""", title)


def field(page, label: str):
    """The input of a labelled row of the side panel (a parameter field, a slider's number box)."""
    return page.locator(f"xpath=//label[normalize-space()='{label}']"
                        "/ancestor::div[contains(@class,'mantine-Flex-root')][1]//input").first


#: true once no height transition (a folder opening or closing) has run for four polls in a row
_STILL = ("() => { const moving = document.getAnimations().some(a => a.playState === 'running'"
          " && a.transitionProperty === 'height');"
          " window.__r2still = moving ? 0 : (window.__r2still || 0) + 1; return window.__r2still >= 4; }")


def open_folder(page, title: str, timeout: float = 10.0) -> None:
    """Open the side panel's folder ``title`` as a user does, by clicking its title (nothing when
    it is open), and wait until it has finished opening: a folder grows for 0.2 s, longer on a
    busy machine, and a click meanwhile can land where a control was a frame before (and be lost)."""
    head = (page.get_by_text(title, exact=True).locator("visible=true")
            .filter(has=page.locator("svg.tabler-icon")).first)
    if head.locator("svg.tabler-icon-chevron-down").count():
        head.click()
    head.locator("svg.tabler-icon-chevron-up").wait_for(state="attached", timeout=timeout * 1000)
    page.evaluate("() => { window.__r2still = 0; }")
    page.wait_for_function(_STILL, polling=50, timeout=timeout * 1000)


def choose(page, label: str, option: str) -> None:
    """Pick ``option`` in the labelled dropdown, as a user does (open the list, click the option)."""
    field(page, label).click()
    page.get_by_role("option", name=option, exact=True).click()


def slider_thumb(page, label: str):
    """The thumb of a labelled slider (focus it and press keys: ArrowRight, End, ...)."""
    return page.locator(f"xpath=//label[normalize-space()='{label}']"
                        "/ancestor::div[contains(@class,'mantine-Flex-root')][1]//*[@role='slider']").first


def set_checkbox(box, on: bool = True, attempts: int = 3) -> None:
    """Tick (or clear) a checkbox as a user does, and click again if a click was lost: a click that
    lands while the panel around the box still moves (a folder opening) may change nothing.
    Example: ``set_checkbox(page.get_by_role("checkbox", name="Presenter mode"), on=False)``."""
    from playwright.sync_api import Error
    for attempt in range(attempts):
        try:
            box.set_checked(on, timeout=10000)
            return
        except Error as exc:
            if "did not change its state" not in str(exc) or attempt == attempts - 1:
                raise


def image(page):
    """The page as an RGB numpy array (H x W x 3)."""
    import imageio.v3 as iio
    return iio.imread(page.screenshot(), extension=".png")[:, :, :3]


def scene_node_names(page):
    """Names of the scene nodes the browser holds (viser's test hook)."""
    return page.evaluate("() => Object.keys(window.__viserSceneTree.getState())")


def project(camera, points, size=None):
    """Pixel coordinates (x right, y down) of world points in a tab's camera (viser's camera
    frame follows OpenCV: z forward, y down). The camera reports the size of its drawing buffer,
    which viser lowers when software WebGL draws slowly; ``size`` = (width, height) of the picture
    to scale to (a screenshot's or the page's CSS pixels), by default the camera's own."""
    import numpy as np
    w, x, y, z = camera.wxyz
    R = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                  [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                  [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])
    cam = (np.asarray(points, float) - camera.position) @ R
    f = camera.image_height / 2 / np.tan(camera.fov / 2)
    u = camera.image_width / 2 + f * cam[:, 0] / cam[:, 2]
    v = camera.image_height / 2 + f * cam[:, 1] / cam[:, 2]
    if size is not None:
        u, v = u * size[0] / camera.image_width, v * size[1] / camera.image_height
    return np.stack([u, v], axis=1)


def page_size(page):
    """(width, height) of a page's window in CSS pixels, the size the 3D view fills."""
    return page.viewport_size["width"], page.viewport_size["height"]


def hide_notifications(page) -> None:
    page.add_style_tag(content=HIDE_NOTIFICATIONS_CSS)


def settle(page, seconds: float = 1.0) -> None:
    """Let software WebGL draw a few frames after the last scene change."""
    page.wait_for_timeout(int(seconds * 1000))


def capture(robot: str, out: str | Path, panel: Optional[str] = None,
            setup: Optional[Callable] = None, action: Optional[Callable] = None,
            width: int = WIDTH, height: int = HEIGHT, lab=None, browser: Optional[Browser] = None,
            scroll: bool = True) -> Path:
    """Save a picture of the page showing ``robot`` with the tab ``panel`` open.

    ``setup(session)`` runs on the server once the robot's panels are ready (set q, open a step,
    load a run); ``action(page)`` runs in the browser before the shot (clicks, scrolling). With
    ``scroll`` the side panel is scrolled so that the panel's tab starts at its top. Give a lab
    server with the panels (``app.commands.serve.lab_server``; without one a server with no tabs
    is started) and a ``Browser`` to reuse them across pictures."""
    from app.viewer.server import LabServer
    own_lab = lab is None
    lab = lab or LabServer(port=0, robot=robot, verbose=False)
    own_browser = browser is None
    browser = browser or Browser()
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    # a picture of a tab without browser-side actions leaves the tab as a robot switch resets it:
    # the next such picture reuses it (issue 16: a page takes seconds to boot in software WebGL)
    reusable = panel is not None and action is None
    key = (id(lab), width, height)
    try:
        page, session = _kept_tab(browser, key, robot, panel) if reusable else (None, None)
        if page is None:
            page, session = open_tab(lab, browser, robot, tab=panel, width=width, height=height)
        keep = False
        try:
            if setup is not None:
                setup(session)
                session.ready.wait(60)
                wait_ready(page, session.robot_name)
                session.scene.frame_camera()
            if panel and scroll:
                settle(page, 0.3)
                scroll_to_tab(page, panel)
            if action is not None:
                action(page)
            save_still(page, out)
            keep = reusable and not own_browser
        finally:
            if keep:
                browser.kept_tabs[key] = (page, session)
            else:
                close_tab(page)
    finally:
        if own_browser:
            browser.close()
        if own_lab:
            lab.stop()
    return out


def save_still(page, out: Path, least: float = 0.5, most: float = 4.0) -> None:
    """Save a picture of the page once software WebGL has drawn the last change: after ``least``
    seconds, the first of two pictures in a row that are the same (at most ``most`` seconds)."""
    settle(page, least)
    deadline = time.time() + most
    shot = page.screenshot()
    while time.time() < deadline:
        page.wait_for_timeout(100)
        again = page.screenshot()
        if again == shot:
            break
        shot = again
    Path(out).write_bytes(shot)


def _kept_tab(browser: "Browser", key, robot: str, tab: str):
    """The tab a previous picture kept, switched to ``robot`` (a switch resets the coordinates, the
    parameters, the camera and the panels built per robot) with ``tab`` open; (None, None) when
    there is none or it went away."""
    kept = getattr(browser, "kept_tabs", {}).pop(key, None)
    if kept is None:
        return None, None
    page, session = kept
    try:
        if session.closed or page.is_closed():
            raise RuntimeError("the kept tab went away")
        reload_robot(page, session, robot)
        select_tab(page, tab)
        return page, session
    except Exception:
        try:
            close_tab(page)
        except Exception:
            pass
        return None, None


def _barrier(page, session, timeout: float = 60.0) -> None:
    """Until the browser has applied every update the server sent to this tab so far (an empty
    element added now and removed once the page shows it: updates arrive in order)."""
    import uuid
    nonce = uuid.uuid4().hex
    handle = session.gui.add_html(f'<span class="r2-barrier" data-n="{nonce}"></span>')
    try:
        page.wait_for_selector(f'.r2-barrier[data-n="{nonce}"]', state="attached", timeout=timeout * 1000)
    finally:
        handle.remove()


def new_session(lab, page, timeout: float = 30.0):
    """The server's session of the tab ``page`` shows (after it opened or reloaded): the page's
    status marker names its tab, so a tab another test opens meanwhile is never taken for it."""
    deadline = time.time() + timeout
    while time.time() < deadline:
        tab = page.evaluate("() => document.querySelector('.r2-status')?.dataset.tab ?? null")
        session = lab.sessions.get(int(tab)) if tab is not None else None
        if session is not None and not session.closed:
            return session
        time.sleep(0.05)
    raise RuntimeError("the page connected but no session appeared")


def page_url(lab, query: str) -> str:
    """The address of the lab's page with a query (``robot=planar_2r&tab=model``)."""
    return lab.url.rstrip("/") + "/?" + query


def reload_robot(page, session, robot: str, timeout: float = 120.0) -> None:
    """Load ``robot`` anew in an open tab (the same robot too: default q and parameters, panels
    rebuilt) and wait until the page shows that load ready: a test's fresh start without the cost of
    a new tab (about 4 s of CPU in software WebGL). Also how ``capture`` reuses a kept tab."""
    session.load_robot(robot)
    generation = session.generation
    if not session.ready.wait(timeout):
        raise RuntimeError(f"{robot} not ready after {timeout:g} s")
    _barrier(page, session, timeout)                 # the browser has every update sent before
    selector = f'.r2-status[data-ready="1"][data-robot="{robot}"][data-generation="{generation}"]'
    page.wait_for_selector(selector, state="attached", timeout=timeout * 1000)
    page.evaluate("() => document.fonts.ready.then(() => true)")


def show_notifications(page) -> None:
    """Undo ``hide_notifications``."""
    page.evaluate("(css) => document.querySelectorAll('style').forEach(s => { if (s.textContent === css) s.remove(); })",
                  HIDE_NOTIFICATIONS_CSS)


def open_tab(lab, browser: "Browser", robot: str, tab: Optional[str] = None, width: Optional[int] = None,
             height: Optional[int] = None, hide: bool = True):
    """A new browser tab on ``robot`` (with the tab ``tab`` open): (page, its server-side session)."""
    lab.initial_robot = robot
    page = browser.page(page_url(lab, f"robot={robot}"), width, height)
    wait_ready(page, robot)
    session = new_session(lab, page)
    if hide:
        hide_notifications(page)
    if tab:
        select_tab(page, tab)
    return page, session


def wait_until(condition: Callable[[], bool], timeout: float = 30.0, what: str = "condition") -> None:
    """Poll ``condition`` every 50 ms; AssertionError naming ``what`` after ``timeout`` seconds."""
    deadline = time.time() + timeout
    while time.time() < deadline:
        if condition():
            return
        time.sleep(0.05)
    raise AssertionError(f"timed out waiting for {what}")
