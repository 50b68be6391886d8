# The two commands of the README: `make run` and `make test`. Each sets up .venv itself: `run`
# installs what running needs (the package), `test` adds the test extras (Ray, Playwright,
# Schemathesis, Fast Downward, the linters).
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
PACKAGES := app domain primitives sim
# pytest's worker processes (pytest-xdist): one per core; tests that share a module's server or a
# Ray instance run on one worker (their xdist_group).
PYTEST_WORKERS ?= auto

.PHONY: run test lint typecheck pytest bench clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip

$(VENV)/.installed: pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install -q -e .
	touch $@

$(VENV)/.installed-test: $(VENV)/.installed pyproject.toml
	$(BIN)/python -m pip install -q -e '.[test]'
	touch $@

run: $(VENV)/.installed
	$(BIN)/screwsnake serve --host $${HOST:-127.0.0.1} --port $${PORT:-8000}

lint: $(VENV)/.installed-test
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .

typecheck: $(VENV)/.installed-test
	$(BIN)/mypy $(PACKAGES)

pytest: $(VENV)/.installed-test
	$(BIN)/pytest -n $(PYTEST_WORKERS) --dist loadgroup

test: lint typecheck pytest

bench: $(VENV)/.installed-test
	for b in bench/[a-z]*.py; do $(BIN)/python -m bench.$$(basename $$b .py) || exit 1; done

clean:
	rm -rf $(VENV) .mypy_cache .pytest_cache .ruff_cache
