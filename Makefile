# Robotics II Lab. `make run` sets up and starts the app; `make test` sets up and runs every test.
PY ?= python3
VENV := .venv
BIN := $(VENV)/bin

.PHONY: setup browser run test bench screenshots

$(BIN)/python:
	$(PY) -m venv $(VENV)

setup: $(BIN)/python
	$(BIN)/pip install -q -e '.[test]'

# Debian's chromium for the headless browser tests (Playwright's own download does not work here).
browser:
	@test -x /usr/bin/chromium || { \
	  if [ "$$(id -u)" = 0 ]; then SUDO=""; else SUDO=sudo; fi; \
	  $$SUDO apt-get update -q && $$SUDO apt-get install -y -q --no-install-recommends chromium; }

run: setup
	$(BIN)/python -m app

# Two workers: on 2 cores a third one made the same run slower (319 s against 288 s, fresh clone, 2026-12-03).
# The workers read compiled modules instead of each compiling app/ and the tests again (about 3 s of
# CPU per worker), also where the environment sets PYTHONDONTWRITEBYTECODE.
test: setup browser
	$(BIN)/python -m compileall -q -j 2 app tests > /dev/null
	PYTHONDONTWRITEBYTECODE= $(BIN)/python -m pytest -q -n 2 --dist worksteal --durations=15

bench: setup
	$(BIN)/python -m benchmarks

screenshots: setup browser
	$(BIN)/python -m app screenshot --all-docs
