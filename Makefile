# Quick start: `make run` and `make test`. Both create .venv when missing and are
# idempotent: the install step re-runs only when setup.cfg or pyproject.toml change.
# `make install` only sets up .venv (with the test tools); `make bench` runs every
# benchmark of `mrss bench` at full size.
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
PROJECT ?= wildfire
PROJECT_DIRS := $(wildcard projects/*/)

.PHONY: install bytecode run test lint typecheck pytest bench clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

# Said once, after an install: the command lives in the virtualenv, not on PATH.
ON_PATH := "mrss is installed as $(BIN)/mrss; '. $(BIN)/activate' puts it on PATH for this shell"

$(VENV)/.installed-run: $(BIN)/python setup.cfg pyproject.toml
	$(BIN)/python -m pip install --quiet -e .
	touch $@
	@echo $(ON_PATH)

$(VENV)/.installed-dev: $(BIN)/python setup.cfg pyproject.toml
	$(BIN)/python -m pip install --quiet -e '.[dev]'
	touch $@ $(VENV)/.installed-run
	@echo $(ON_PATH)

install: $(VENV)/.installed-dev

# Bytecode of mrss, the projects and the tests, written ahead: a process that may not
# write it (PYTHONDONTWRITEBYTECODE set, a read-only checkout) compiles every module it
# imports from source at each start, about 0.4 s of the system's start (`mrss bench
# memory`). compileall writes only what changed since, so this is quick when re-run.
bytecode: $(VENV)/.installed-run
	$(BIN)/python -m compileall -q mrss projects tests > /dev/null

run: $(VENV)/.installed-run bytecode
	$(BIN)/mrss supervise $(PROJECT)

# The package layers and the components' independence (pyproject.toml, docs/architecture.md).
lint: $(VENV)/.installed-dev
	$(BIN)/ruff check mrss tests projects
	$(BIN)/lint-imports --no-cache

# Each project on its own: two projects' rcl.py would be one module name to mypy.
typecheck: $(VENV)/.installed-dev
	$(BIN)/mypy mrss
	@set -e; for p in $(PROJECT_DIRS); do echo "mypy $$p"; $(BIN)/mypy $$p; done

# One worker per logical CPU (pytest-xdist); each has ports of its own (tests/conftest.py).
# TEST_WORKERS=0 runs the suite in this one process.
TEST_WORKERS ?= logical
pytest: $(VENV)/.installed-dev bytecode
	$(BIN)/python -m pytest -n $(TEST_WORKERS) --dist worksteal

test: lint typecheck pytest

bench: $(VENV)/.installed-run
	$(BIN)/mrss bench all

clean:
	rm -rf $(VENV) .mypy_cache .pytest_cache .ruff_cache
	find mrss projects tests -name __pycache__ -type d -prune -exec rm -rf {} +
