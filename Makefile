# One command per task; CI runs the same ones (.ci/run -> make test).
# Every target that needs the environment depends on `setup`, which is idempotent and does nothing
# when pyproject.toml and the client's package-lock.json have not changed since the last install.

PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMPS := $(VENV)/.stamps
ARGS   ?=

.PHONY: setup run test lint bench clean

setup: $(STAMPS)/python $(STAMPS)/npm

$(BIN)/python:
	@$(PYTHON) -c 'import sys; sys.exit(0 if sys.version_info >= (3, 11) else "Python 3.11 or newer is needed (set PYTHON=python3.11)")'
	$(PYTHON) -m venv $(VENV)

$(STAMPS)/python: pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet --upgrade pip
	# zenoh too: its backend's tests (tests/test_zenoh_backend.py, two-relay fleets) and `make run ARGS="--backend
	# zenoh"` (tools/fake_fleet.py --zenoh) run on every machine, with no ROS install.
	$(BIN)/python -m pip install --quiet -e '.[dev,ros,zenoh]'
	@mkdir -p $(STAMPS) && touch $@

# The client's npm packages: three.js and the controller models it serves, and the tools the tests use
# (TypeScript's checker, the Khronos glTF validator, the IWER headset emulator).
$(STAMPS)/npm: xr_client/package.json xr_client/package-lock.json
	cd xr_client && npm ci --no-audit --no-fund --loglevel=error
	@mkdir -p $(STAMPS) && touch $@

run: setup
	$(BIN)/xr-relay $(ARGS)

# The browser tests drive Debian's Chromium; Playwright never downloads one.
CHROMIUM := /usr/bin/chromium

$(CHROMIUM):
	@command -v apt-get >/dev/null || { echo "Install Chromium at $(CHROMIUM) for the browser tests"; exit 1; }
	apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium

# The inspection store's tests run against a real PostgreSQL server, from Debian's package.
POSTGRES := /usr/lib/postgresql

$(POSTGRES):
	@command -v apt-get >/dev/null || { echo "Install PostgreSQL (Debian's postgresql) for the store's tests"; exit 1; }
	apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq postgresql

# pytest in parallel (pytest-xdist): the tests mostly wait (relays, browsers, DDS peers; about 5 of the suite's 14
# minutes are CPU), so more workers than cores. TEST_WORKERS=0 runs them in this process, one after the other.
# worksteal, not load: load hands each worker a first slice of the collection in order, and the first slice is the
# browser tests (tests/e2e sorts first), which then ran on one worker long after the others had finished.
TEST_WORKERS ?= 4

test: setup $(CHROMIUM) $(POSTGRES)
	cd xr_client && node --test test/
	$(BIN)/python -m pytest -q -p no:cacheprovider -n $(TEST_WORKERS) --dist worksteal

lint: setup
	$(BIN)/ruff check relay tools tests
	$(BIN)/ruff format --check relay tools tests
	$(BIN)/mypy
	cd xr_client && npx --no-install tsc -p jsconfig.json

# The benchmarks (bench/run.py): bench/results/*.json, docs/benchmarks.md and docs/img/bench_*.png, about
# 15-20 minutes; QUICK=1 runs a subset in under 2 minutes into bench/results/scratch/quick/ (ignored by git).
# Their extra packages (the Foxglove SDK, matplotlib) are installed here when missing.
bench: setup
	@$(BIN)/python -c 'import foxglove, matplotlib' 2>/dev/null || $(BIN)/python -m pip install --quiet -e '.[dev,ros,zenoh,bench]'
	$(BIN)/python -m bench.run $(if $(QUICK),--quick)

clean:
	rm -rf $(VENV) build *.egg-info
