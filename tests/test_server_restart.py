"""Reliability issue, server item 5: a server killed and started again on the same port gets its
tabs back as they were (robot, panel tab, exercise), because each tab's state is in its address and
viser's page reconnects by itself."""
import time

from app.viewer import screenshot as shots
from app.commands.serve import lab_server


def test_tabs_come_back_as_they_were_after_a_restart(browser):
    first = lab_server(port=0)
    port = first.viser.get_port()
    pages = []
    try:
        for query, robot, tab in (("robot=rp_2004_03_25&tab=steps", "rp_2004_03_25", "Steps"),
                                  ("robot=polar_2r_2016_06_06&tab=control", "polar_2r_2016_06_06", "Control")):
            page = browser.page(shots.page_url(first, query))
            shots.wait_ready(page, robot)
            shots.new_session(first, page)
            shots.wait_until(lambda: shots.selected_tab(page) == tab, 10, f"the {tab} tab")
            pages.append((page, robot, tab))
    finally:
        first.stop()
    time.sleep(0.5)
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
