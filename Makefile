# The two commands of the README. Each creates its own virtual environment (.venv) on first use
# and re-installs when pyproject.toml changes.
PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: run test lint typecheck bench clean

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test]'
	touch $(STAMP)

## run: the main job: the planning service with the packaged skill library, SQLite job store
## under ./var and an embedded verification worker (http://127.0.0.1:8000/docs)
run: $(STAMP)
	$(BIN)/gfc serve

## bench: the benchmarks whose tables live under docs/bench/
bench: $(STAMP)
	$(BIN)/gfc bench latency --json docs/bench/latency.json
	$(BIN)/gfc bench load --json docs/bench/load.json

## test: lint, type-check and the whole test suite (slow tests included)
test: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .
	$(BIN)/mypy gfc skill_store $(wildcard service clients scripts)
	$(BIN)/pytest -n 2 --dist loadgroup

lint: $(STAMP)
	$(BIN)/ruff check . && $(BIN)/ruff format --check .

typecheck: $(STAMP)
	$(BIN)/mypy gfc skill_store $(wildcard service clients scripts)

clean:
	rm -rf $(VENV) .mypy_cache .ruff_cache .pytest_cache
