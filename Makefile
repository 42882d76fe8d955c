# stictionbench: two commands for a fresh machine — `make replicate` and `make test`.
PY      ?= python3
VENV    := .venv
BIN     := $(VENV)/bin
STAMP   := $(VENV)/.installed
export MPLBACKEND := Agg
export NUMBA_CACHE_DIR ?= $(CURDIR)/.venv/numba-cache

.PHONY: venv test replicate bench lint clean

venv: $(STAMP)

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PY) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev]'
	touch $(STAMP)

test: venv
	$(BIN)/python -m pytest -q -m "not slow and not benchmark" -p no:cacheprovider

replicate: venv
	$(BIN)/stictionbench replicate

bench: venv
	$(BIN)/python -m pytest benchmarks -q -s -m "benchmark" -p no:cacheprovider --benchmark-columns=min,median,mean,rounds

lint: venv
	$(BIN)/ruff check stictionbench tests benchmarks experiments

clean:
	rm -rf $(VENV) .pytest_cache .ruff_cache .benchmarks
