"""A new tab's first robot comes from the address of the page load it most likely belongs to (the
server saw that request; the page's own report of its address comes about 0.3 s after it
connects), so the robot is on its way before the page reports; the report then confirms the guess
or corrects it, and two different page loads at once make no guess."""
import time
import urllib.request

import pytest

from app.commands.serve import lab_server
from app.viewer.screenshot import wait_until as wait_for
from app.viewer.url_state import PageRequests
from benchmarks.load import Client


@pytest.fixture()
def fresh_lab():
    server = lab_server(port=0)          # no other test's page loads in its memory
    yield server
    server.stop()


def _load_page(lab, query):
    with urllib.request.urlopen(f"http://127.0.0.1:{lab.viser.get_port()}/{query}", timeout=30) as page:
        assert page.status == 200


def _session(lab, before):
    wait_for(lambda: set(lab.sessions) - before, 30, "a session")
    return lab.sessions[(set(lab.sessions) - before).pop()]


def test_a_tab_that_never_reports_gets_the_robot_and_tab_of_its_page_load(fresh_lab):
    _load_page(fresh_lab, "?robot=rp_2004_03_25&tab=steps")
    before = set(fresh_lab.sessions)
    client = Client(fresh_lab.viser.get_port(), None)          # its report never comes
    try:
        session = _session(fresh_lab, before)
        started = time.monotonic()
        wait_for(lambda: session.robot_name == "rp_2004_03_25" and session.ready.is_set(), 10, "rp_2004_03_25")
        assert time.monotonic() - started < 10                # the default page would come after 20 s
        assert session.url.get("tab") == "steps"
    finally:
        client.close()


def test_the_page_report_corrects_a_wrong_guess(fresh_lab):
    _load_page(fresh_lab, "?robot=rp_2004_03_25")     # another tab's load: this client reports planar_pr
    before = set(fresh_lab.sessions)
    client = Client(fresh_lab.viser.get_port(), "?robot=planar_pr")
    try:
        session = _session(fresh_lab, before)
        wait_for(lambda: session.robot_name == "planar_pr" and session.ready.is_set(), 30, "planar_pr")
        time.sleep(1.0)                                    # and it stays there
        assert session.robot_name == "planar_pr"
    finally:
        client.close()


def test_a_robot_the_student_picked_is_not_undone_by_a_late_report(fresh_lab):
    from app.core.robot import load_robot
    _load_page(fresh_lab, "?robot=rp_2004_03_25")
    before = set(fresh_lab.sessions)
    client = Client(fresh_lab.viser.get_port(), None)
    try:
        session = _session(fresh_lab, before)
        wait_for(lambda: session.robot_name == "rp_2004_03_25" and session.ready.is_set(), 10, "rp_2004_03_25")
        picker = client.wait_widget("Robot", 60)
        title = load_robot("planar_2r").title
        client.update(picker, next(o for o in picker["props"]["options"] if title in o))
        wait_for(lambda: session.robot_name == "planar_2r" and session.ready.is_set(), 30, "planar_2r")
        client.update(client.report, "url ?robot=planar_pr")     # the page's report, very late
        time.sleep(1.5)
        assert session.robot_name == "planar_2r"
    finally:
        client.close()


def test_page_loads_make_a_guess_only_when_they_agree():
    pages = PageRequests()
    pages.note("/?robot=a", {"Upgrade": "websocket"})            # a websocket is not a page load
    pages.note("/assets/x.js", {})                               # nor is anything but the page
    assert pages.take() is None
    pages.note("/?robot=a", {})
    pages.note("/?robot=b", {})
    assert pages.take() is None                                  # two tabs at once: wait for reports
    pages = PageRequests(window=0.2)
    pages.note("/", {})
    time.sleep(0.3)
    assert pages.take() is None                                  # too old to be this tab's
    pages.note("/?robot=a&tab=model", {})
    pages.note("/?robot=a&tab=model", {})
    assert pages.take() == pages.take() == "?robot=a&tab=model"  # one each
    assert pages.take() is None
