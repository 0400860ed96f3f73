"""Reliability issue, server item 5: a server killed and started again on the same port gets its
tabs back as they were (robot, panel tab, exercise), because each tab's state is in its address and
viser's page reconnects by itself. The first server is ``python -m app serve`` in a process of its
own, killed (SIGKILL: no goodbye to the tabs), as a crash or a closed terminal would end it."""
import re
import subprocess
import sys
from pathlib import Path
from urllib.parse import urlparse

from app.commands.serve import lab_server
from app.viewer import screenshot as shots

ROOT = Path(__file__).resolve().parents[1]


def test_tabs_come_back_as_they_were_after_a_restart(browser):
    first = subprocess.Popen([sys.executable, "-m", "app", "serve", "--port", "0"], cwd=ROOT,
                             stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    pages = []
    try:
        announced = first.stdout.readline()                   # "Robotics II Lab: open URL in a browser ..."
        url = re.search(r"open (http://\S+) in", announced)
        assert url, f"serve did not announce its address: {announced!r}"
        port = urlparse(url.group(1)).port
        for query, robot, tab in (("robot=rp_2004_03_25&tab=steps", "rp_2004_03_25", "Steps"),
                                  ("robot=polar_2r_2016_06_06&tab=control", "polar_2r_2016_06_06", "Control")):
            page = browser.page(url.group(1).rstrip("/") + "/?" + query)
            pages.append((page, robot, tab))
            shots.wait_ready(page, robot)
            shots.wait_until(lambda: shots.selected_tab(page) == tab, 10, f"the {tab} tab")
    finally:
        first.kill()
        first.wait(10)
        first.stdout.close()
    second = lab_server(port=port)
    try:
        for page, robot, tab in pages:          # the pages were not reloaded: they reconnect on their own
            shots.wait_until(lambda: any(s.robot_name == robot and s.ready.is_set() for s in second.sessions.values()),
                             60, f"{robot} back after the restart")
            shots.wait_ready(page, robot)
            shots.wait_until(lambda: shots.selected_tab(page) == tab, 10, f"the {tab} tab back")
            assert page.evaluate("() => location.search").startswith(f"?robot={robot}")
        assert len(second.sessions) == len(pages)
    finally:
        for page, _, _ in pages:
            shots.close_tab(page)
        second.stop()
