# kbplanner: every target sets up .venv on first use, so each is one command on a fresh machine.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed-stamp

.PHONY: all setup run test test-slow check lint layers typecheck bench clean

all: test

$(STAMP): pyproject.toml
	@test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[dev]"
	@touch $(STAMP)

setup: $(STAMP)

## The main job: the full pipeline on the bundled case study, every robotized task (framing, layout marking).
run: $(STAMP)
	$(BIN)/kbplanner run data/case_study --tasks all --workers 2 --out runs/case_study

## The tests: lint, types, then the default (fast) test suite.
test: check
	$(BIN)/python -m pytest -n 2 -q

## The tests marked slow (whole case-study runs, multi-process and cluster runs, the notebook);
## .ci/run runs them after `make test`, so CI runs every test.
test-slow: $(STAMP)
	$(BIN)/python -m pytest -n 2 -q -m slow

check: lint typecheck layers

layers: $(STAMP)
	$(BIN)/lint-imports

lint: $(STAMP)
	$(BIN)/ruff check src tests benchmarks

typecheck: $(STAMP)
	$(BIN)/mypy

bench: $(STAMP)
	$(BIN)/python benchmarks/run.py

clean:
	rm -rf $(VENV) runs build dist .mypy_cache .ruff_cache .pytest_cache
