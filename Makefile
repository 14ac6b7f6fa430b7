# One command per task; CI runs the same ones (.ci/run -> make test).
# Every target that needs the environment depends on `setup`, which is idempotent and does nothing
# when pyproject.toml and the client's package-lock.json have not changed since the last install.

PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMPS := $(VENV)/.stamps
ARGS   ?=

.PHONY: setup run test lint bench clean

setup: $(STAMPS)/python

$(BIN)/python:
	@$(PYTHON) -c 'import sys; sys.exit(0 if sys.version_info >= (3, 11) else "Python 3.11 or newer is needed (set PYTHON=python3.11)")'
	$(PYTHON) -m venv $(VENV)

$(STAMPS)/python: pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev]'
	@mkdir -p $(STAMPS) && touch $@

# The client's npm packages (type checker now; three.js and friends as the 3D client lands).
$(STAMPS)/npm: xr_client/package.json xr_client/package-lock.json | $(BIN)/python
	cd xr_client && npm ci --no-audit --no-fund --loglevel=error
	@mkdir -p $(STAMPS) && touch $@

run: setup
	$(BIN)/xr-relay $(ARGS)

test: setup
	$(BIN)/python -m pytest -q -p no:cacheprovider

lint: setup $(STAMPS)/npm
	$(BIN)/ruff check relay tools tests
	$(BIN)/ruff format --check relay tools tests
	$(BIN)/mypy
	cd xr_client && npx --no-install tsc -p jsconfig.json

clean:
	rm -rf $(VENV) build *.egg-info
