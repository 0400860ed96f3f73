"""A client faster than a browser (found by benchmarks/load.py): it reports the page's address as
soon as the hidden report field reaches it, while the server is still building the session. The
session used to crash on such a report (``'Session' object has no attribute '_panel_specs'``:
the tab stayed blank), or, with the report before the field's callback, would have lost it and
shown the default robot after 20 s."""
import time

import app.viewer.session as session_module
from benchmarks.load import Client


def test_an_address_reported_while_the_session_is_built_is_used(lab, monkeypatch):
    discover = session_module.discover_panels_with_errors

    def slow_discovery():          # the window between the report field and its callback, widened
        time.sleep(1.5)
        return discover()

    monkeypatch.setattr(session_module, "discover_panels_with_errors", slow_discovery)
    before = set(lab.sessions)
    client = Client(lab.viser.get_port(), "?robot=planar_pr")      # reports at once
    try:
        status = 'data-ready="1" data-robot="planar_pr"'
        assert client.wait(lambda: any(status in str(w["props"].get("content", ""))
                                       for w in list(client.by_uuid.values())), 60)
        session = next(lab.sessions[k] for k in set(lab.sessions) - before)
        assert session.robot_name == "planar_pr"
    finally:
        client.close()
