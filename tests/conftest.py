"""Fixtures shared by the browser tests: one lab server and one headless Chromium for the whole run,
started by the first browser test and shared by every browser test module (every test opens its own
browser context, i.e. an independent tab with its own session)."""
import pytest


@pytest.fixture(scope="session")
def lab():
    from app.viewer.server import LabServer
    server = LabServer(port=0, verbose=False)
    yield server
    server.stop()


@pytest.fixture(scope="session")
def browser():
    from app.viewer import screenshot as shots
    with shots.Browser() as b:
        yield b
