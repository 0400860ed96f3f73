"""Fixtures shared by the browser tests: one lab server and one headless Chromium per test module
(every test opens its own browser context, i.e. an independent tab with its own session)."""
import pytest

from app.viewer import screenshot as shots
from app.viewer.server import LabServer


@pytest.fixture(scope="module")
def lab():
    server = LabServer(port=0, verbose=False)
    yield server
    server.stop()


@pytest.fixture(scope="module")
def browser():
    with shots.Browser() as b:
        yield b
