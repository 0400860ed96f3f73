"""Shared by the tests.

Browser tests: one lab server and one headless Chromium for the whole run (per pytest worker),
started by the first browser test and shared by every browser test module. A test that starts from
a robot picked in the page takes the tab its module shares (``module_tab``: the robot loaded anew,
as a new tab would start); the tests of addresses, reloads and several tabs open their own tabs.

Random numbers: every generator that a test or the lab's code makes during a test
(``numpy.random.default_rng``, ``random.Random``) must be given a seed, so that a run repeats
exactly; a test that fails prints the seeds it used (section "random seeds" of its report)."""
import random
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
OURS = (str(ROOT / "app"), str(ROOT / "tests"))


@pytest.fixture(scope="session")
def lab():
    from app.commands.serve import lab_server
    server = lab_server(port=0)
    yield server
    server.stop()


@pytest.fixture(scope="session")
def browser():
    from app.viewer import screenshot as shots
    # a small laptop's window (960 x 540 CSS px) rather than the docs' 1280 x 720, the 3D view at
    # most 10 frames a second, one profile for the tabs (the page's scripts compiled once): software
    # WebGL draws every pixel of every frame on the CPU, and the browser is half of the suite's CPU
    with shots.Browser(size=(960, 540), max_fps=10, shared_cache=True) as b:
        yield b


@pytest.fixture(scope="module")
def module_tab(lab, browser):
    """``module_tab(robot, tab=None, height=None, hide=True)``: (page, session) of a tab the module's
    tests share, with ``robot`` loaded anew at every call (default q and parameters, the panels built
    per robot rebuilt, the panel tab ``tab`` on display), notifications closed and then hidden or
    shown, no page error left from the test before (``page.r2_errors``): a new tab's start without
    its cost (2-4 s of CPU in software WebGL). One tab per window height."""
    from app.viewer import screenshot as shots
    tabs = {}

    def fresh(robot, tab=None, height=None, hide=True):
        page, session = tabs.get(height, (None, None))
        if page is None or page.is_closed() or session.closed:
            page, session = shots.open_tab(lab, browser, robot, tab, height=height, hide=False)
            page.r2_errors = []
            page.on("pageerror", lambda exc, errors=page.r2_errors: errors.append(str(exc)))
            tabs[height] = (page, session)
        else:
            page.keyboard.press("Escape")                 # a dropdown the test before left open
            if shots.field(page, "Group").input_value() != "All robots":     # the whole list, as on a new tab
                shots.choose(page, "Group", "All robots")
            shots.show_notifications(page)
            page.evaluate("() => document.querySelectorAll('.mantine-Notification-root button').forEach(b => b.click())")
            shots.wait_until(lambda: not page.locator(".mantine-Notification-root").count(), 10,
                             "the earlier notifications to close")
            shots.reload_robot(page, session, robot)
            if tab:
                shots.select_tab(page, tab)
        (shots.hide_notifications if hide else shots.show_notifications)(page)
        page.r2_errors.clear()
        return page, session

    yield fresh
    for page, _session in tabs.values():
        shots.close_tab(page)


@pytest.fixture(autouse=True)
def _seeded_randomness(request, monkeypatch):
    """Record the seed of every random generator made during the test; refuse one without a seed."""
    seeds = request.node.random_seeds = []
    default_rng = np.random.default_rng

    def check(seed, what):
        caller = sys._getframe(2).f_code.co_filename       # a library's own generators are its business
        if seed is None and caller.startswith(OURS):
            raise AssertionError(f"{what} without a seed in {caller}: give it a fixed seed")
        seeds.append(seed)

    def seeded_default_rng(seed=None, *args, **kwargs):
        check(seed, "numpy.random.default_rng()")
        return default_rng(seed, *args, **kwargs)

    class SeededRandom(random.Random):
        def __init__(self, x=None):
            check(x, "random.Random()")
            super().__init__(x)

    monkeypatch.setattr(np.random, "default_rng", seeded_default_rng)
    monkeypatch.setattr(random, "Random", SeededRandom)


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    outcome = yield
    report = outcome.get_result()
    seeds = getattr(item, "random_seeds", None)
    if report.failed and any(s is not None for s in seeds):
        unique = list(dict.fromkeys(repr(s) for s in seeds if s is not None))
        report.sections.append(("random seeds", "seeds of the random generators this test made: " + ", ".join(unique)))


SOLUTION_MODULES = ("test_exercises.py", "test_readable_steps.py", "test_latex_out.py")


def pytest_collection_modifyitems(items):
    """Put the checks of one exercise's solution next to each other (answers, readability, LaTeX):
    pytest-xdist's worksteal hands each worker a contiguous run of items, so a solution is then
    computed once per run (the ``solved`` fixture) instead of once per worker."""
    grouped = [i for i in items if i.path.name in SOLUTION_MODULES and hasattr(i, "callspec")]
    if not grouped:
        return
    first = items.index(grouped[0])
    chosen = set(map(id, grouped))
    rest = [i for i in items if id(i) not in chosen]
    order = {name: k for k, name in enumerate(SOLUTION_MODULES)}
    grouped.sort(key=lambda i: (i.callspec.id, order[i.path.name]))
    items[:] = rest[:first] + grouped + rest[first:]


@pytest.fixture(scope="session")
def solved():
    """``solved(exercise)``: the engine's solution of a shipped exercise, solved once per test
    session (the answer checks and the readability walk share it)."""
    from app.core.exercise import solve
    cache = {}

    def get(exercise):
        if exercise.id not in cache:
            cache[exercise.id] = solve(exercise)
        return cache[exercise.id]
    return get
