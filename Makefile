# Quick start: `make run` and `make test` work on a fresh machine with only Python.
PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: install run test test-fast docs-commands lint typecheck bench figures view-check dist-check docs clean \
        compiled

$(BIN)/python:
	@echo "make: creating the virtual environment $(VENV)"
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

# uv (from PyPI, through pip) installs the same releases as pip in a fraction of the time (40-50 s on a
# fresh machine, where pip takes about 100 s), bytecode compiled as pip would; where uv cannot be had
# or fails, pip does it (one line per package)
EXTRAS := dev,nxt,cluster,viz,docs
$(STAMP): pyproject.toml setup.py | $(BIN)/python
	@echo "make: installing nxtnav and its dependencies into $(VENV)"
	$(BIN)/python -m pip install --quiet uv || echo "make: uv not installed; pip installs instead"
	$(BIN)/python -m uv pip install --python $(BIN)/python --compile-bytecode -e ".[$(EXTRAS)]" \
	    || $(BIN)/python -m pip install --progress-bar off -e ".[$(EXTRAS)]"
	touch $(STAMP)
	@echo "make: nxtnav installed: $(BIN)/nxtnav"

install: $(STAMP)

run: $(STAMP)
	mkdir -p out
	$(BIN)/nxtnav run --plot out/mission.png --json out/mission.json

# pytest runs on every core (pytest-xdist); tests marked with one xdist_group share a worker (one Dask cluster);
# --durations: each run lists its slowest tests (the candidates for the slow tier)
PYTEST := $(BIN)/python -m pytest -q -n auto --dist loadgroup

# every tier in one run, so the cores stay busy to the end: the quick tests, the slow end-to-end ones and
# the documented commands (tier docs: every shell block of README.md and docs/, tools/docs_commands.py)
# mypy runs in the background beside pytest (its report comes at the end); pytest starts the slow tests and
# the documented commands first (tests/conftest.py), so that both workers finish together
test: $(STAMP)
	$(BIN)/ruff check toolkit planners localisation tests notebooks tools
	$(BIN)/python tools/docs_commands.py --summary
	mypy_log=$$(mktemp); $(BIN)/mypy > $$mypy_log 2>&1 & mypy_pid=$$!; \
	$(PYTEST) --durations=30; rc=$$?; \
	wait $$mypy_pid; mypy_rc=$$?; echo "mypy (exit $$mypy_rc):"; cat $$mypy_log; rm -f $$mypy_log; \
	test $$rc -eq 0 && test $$mypy_rc -eq 0

# every shell block of README.md and docs/ run in a temporary folder outside the repository, at the sizes
# its docs-run marker gives CI, and every stated figure checked (tools/docs_commands.py; --list: what runs)
docs-commands: $(STAMP)
	$(BIN)/python tools/docs_commands.py --summary
	$(PYTEST) -m docs tests/test_docs_commands.py --durations=40

# the same without the slow end-to-end checks (pytest -m "not slow"), for a quick loop while editing
test-fast: $(STAMP)
	$(BIN)/ruff check toolkit planners localisation tests notebooks tools
	$(BIN)/mypy
	$(PYTEST) -m "not slow and not docs"

# opt-in, part of neither install nor test: the robot-time objective compiled against the installed ompl wheel
# (planners/_compiled/README.md), which the OMPL planners then use (objective_impl=auto). Needs g++, cmake and
# Eigen (Debian: g++ cmake libeigen3-dev), PyPI (nanobind's wheel) and OMPL's source at the wheel's version:
# OMPL_SRC=DIR, a checkout of that tag, else downloaded with curl. Rebuild after any change of the ompl wheel.
OMPL_SRC ?=
compiled: $(STAMP)
	PYTHON=$(BIN)/python planners/_compiled/build.sh "$(OMPL_SRC)"

bench: $(STAMP)
	$(BIN)/nxtnav bench world --map map1

figures: $(STAMP)
	$(BIN)/nxtnav figures --out docs/img

# a mission saved as a Rerun recording, rendered by Rerun's web viewer (shipped in the rerun-sdk wheel) in
# headless Chromium (Debian's package; installed here when missing, which needs root), screenshot in
# out/ (untracked; VIEW_PNG=docs/img/rerun-view.png updates the README's picture); the viewer runs in
# its own process group, ended with it, so no process is left; the viewcheck extra only when missing
VIEW_PNG ?= out/rerun-view.png
view-check: $(STAMP)
	@command -v chromium >/dev/null || { apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium; }
	@$(BIN)/python -c "import playwright" 2>/dev/null || $(BIN)/python -m pip install --quiet -e ".[viewcheck]"
	mkdir -p out
	$(BIN)/nxtnav run --map map1 --view-save out/view-check.rrd
	$(BIN)/python tools/view_check.py out/view-check.rrd $(VIEW_PNG)

# the wheel and sdist (python -m build, into dist/), the wheel installed in a fresh venv outside the
# repository, and nxtnav --version, maps list, import sweeps and run from there (tools/dist_check.py)
dist-check: $(STAMP)
	$(BIN)/python tools/dist_check.py

# the documentation site (MkDocs Material) into site/; --strict: a broken link or a missing page fails
docs: $(STAMP)
	NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs build --strict

clean:
	rm -rf $(VENV) out .pytest_cache .mypy_cache .ruff_cache dist site planners/_compiled/_robot_time*.so \
	       planners/_compiled/build_info.json
