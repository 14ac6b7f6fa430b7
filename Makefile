# One command per task; CI runs the same ones (.ci/run -> make test).
# Every target that needs the environment depends on `setup`, which is idempotent and does nothing
# when pyproject.toml and the client's package-lock.json have not changed since the last install.

PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMPS := $(VENV)/.stamps
ARGS   ?=

.PHONY: setup run test test-heavy lint bench clean

setup: $(STAMPS)/python $(STAMPS)/npm $(STAMPS)/nav2_msgs

$(BIN)/python:
	@$(PYTHON) -c 'import sys; sys.exit(0 if sys.version_info >= (3, 11) else "Python 3.11 or newer is needed (set PYTHON=python3.11)")'
	$(PYTHON) -m venv $(VENV)

$(STAMPS)/python: pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet --upgrade pip
	# zenoh too: its backend's tests (tests/test_zenoh_backend.py, two-relay fleets) and `make run ARGS="--backend
	# zenoh"` (tools/fake_fleet.py --zenoh) run on every machine, with no ROS install.
	$(BIN)/python -m pip install --quiet -e '.[dev,ros,zenoh]'
	@mkdir -p $(STAMPS) && touch $@

# Nav2's nav2_msgs (NavigateToPose), which the ROS wheels lack, built with ROS 2's own generators: with it the ros
# backend reads Nav2's feedback and error codes over DDS, as with a sourced ROS 2 (tools/build_nav2_msgs.py).
$(STAMPS)/nav2_msgs: tools/build_nav2_msgs.py relay/ros/nav2_types.py $(STAMPS)/python
	$(BIN)/python tools/build_nav2_msgs.py > $(VENV)/nav2_msgs-build.log 2>&1 || { cat $(VENV)/nav2_msgs-build.log; exit 1; }
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

# pytest in parallel (pytest-xdist), in two parts. The tests without a browser mostly wait (relays, DDS peers),
# so more workers than cores. The browser tests compute: WebGL on SwiftShader takes every core it is given, and
# four browsers at once on two cores (the end of a single run) slowed pages to 1-2 frames a second and failed five
# of them; one browser per core. TEST_WORKERS=0 runs each part in this process, one test after the other. Both
# parts always run; the target fails if either did.
TEST_WORKERS ?= 4
BROWSER_WORKERS ?= 2
PYTEST = $(BIN)/python -m pytest -q -p no:cacheprovider --dist worksteal --durations=15

test: setup $(CHROMIUM) $(POSTGRES)
	cd xr_client && node --test test/
	$(PYTEST) -n $(TEST_WORKERS) --ignore=tests/e2e tests; relay=$$?; \
	$(PYTEST) -n $(BROWSER_WORKERS) tests/e2e; browser=$$?; \
	echo "tests without a browser: exit $$relay; browser tests: exit $$browser"; \
	test $$relay -eq 0 && test $$browser -eq 0

# The heavy VR scenarios (tests marked `heavy`: the valve turned by hand, the 3D map in a headset), one at a time:
# each draws for minutes on SwiftShader at full CPU, and beside the other browser tests on two cores they made their
# neighbours miss their bounds. `make test` skips them, saying how to run them.
test-heavy: setup $(CHROMIUM) $(POSTGRES)
	XR_RELAY_HEAVY=1 $(PYTEST) -n 0 -m heavy tests/e2e

lint: setup
	$(BIN)/ruff check relay tools tests
	$(BIN)/ruff format --check relay tools tests
	$(BIN)/mypy
	cd xr_client && npx --no-install tsc -p jsconfig.json
	# The client's formatter (prettier, xr_client/.prettierrc.json: 120 columns): a module grows by lines, not by packing.
	cd xr_client && npx --no-install prettier --check src test

# The benchmarks (bench/run.py): bench/results/*.json, docs/benchmarks.md and docs/img/bench_*.png, about
# 15-20 minutes; QUICK=1 runs a subset in under 2 minutes into bench/results/scratch/quick/ (ignored by git).
# Their extra packages (the Foxglove SDK, matplotlib) are installed here when missing.
bench: setup
	@$(BIN)/python -c 'import foxglove, matplotlib' 2>/dev/null || $(BIN)/python -m pip install --quiet -e '.[dev,ros,zenoh,bench]'
	$(BIN)/python -m bench.run $(if $(QUICK),--quick)

clean:
	rm -rf $(VENV) build *.egg-info
