# Quick start: `make run` and `make test` work on a fresh machine with only Python.
PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: run test test-fast lint typecheck bench figures view-check clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

$(STAMP): pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e ".[dev,nxt,cluster,viz]"
	touch $(STAMP)

install: $(STAMP)

run: $(STAMP)
	mkdir -p out
	$(BIN)/nxtnav run --plot out/mission.png --json out/mission.json

# pytest runs on every core (pytest-xdist)
PYTEST := $(BIN)/python -m pytest -q -n auto

test: $(STAMP)
	$(BIN)/ruff check toolkit planners localisation tests notebooks
	$(BIN)/mypy
	$(PYTEST)

# the same without the slow end-to-end checks (pytest -m "not slow"), for a quick loop while editing
test-fast: $(STAMP)
	$(BIN)/ruff check toolkit planners localisation tests notebooks
	$(BIN)/mypy
	$(PYTEST) -m "not slow"

bench: $(STAMP)
	$(BIN)/nxtnav bench world --map map1

figures: $(STAMP)
	$(BIN)/nxtnav figures --out docs/img

# a mission saved as a Rerun recording, rendered by Rerun's web viewer (shipped in the rerun-sdk wheel) in
# headless Chromium (Debian's package; installed here when missing, which needs root), screenshot in docs/img
view-check: $(STAMP)
	@command -v chromium >/dev/null || { apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium; }
	$(BIN)/python -m pip install --quiet -e ".[viewcheck]"
	mkdir -p out
	$(BIN)/nxtnav run --map map1 --view-save out/view-check.rrd
	$(BIN)/python -m toolkit.view.check out/view-check.rrd docs/img/rerun-view.png

clean:
	rm -rf $(VENV) out .pytest_cache .mypy_cache .ruff_cache
