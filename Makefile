# stictionbench: two commands for a fresh machine — `make replicate` and `make test`.
PY      ?= python3
VENV    := .venv
BIN     := $(VENV)/bin
STAMP   := $(VENV)/.installed
export MPLBACKEND := Agg
export NUMBA_CACHE_DIR ?= $(CURDIR)/.venv/numba-cache

.PHONY: venv test replicate bench lint clean real concealed

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

# real plant recordings (needs ../shared/data): batch verdicts, oscillation benchmark,
# model-free diagnosis of the ISDB stiction loops
DATA ?= ../shared/data
real: venv
	$(BIN)/stictionbench batch $(DATA)/isdb --labels $(DATA)/isdb/labels.csv --json reports/real/isdb/batch.json --report reports/real/isdb
	$(BIN)/stictionbench batch $(DATA)/plant --labels $(DATA)/plant/labels.csv --json reports/real/plant/batch.json --report reports/real/plant
	$(BIN)/stictionbench oscillation-benchmark $(DATA)/isdb-oscillation/benchmark.mat --out reports/real/oscillation
	$(BIN)/python experiments/isdb_diagnose.py --data $(DATA)/isdb

# concealed-data benchmark of the diagnosis (about 3 minutes on 2 cores)
concealed: venv
	$(BIN)/python experiments/concealed.py --seeds 10

lint: venv
	$(BIN)/ruff check stictionbench tests benchmarks experiments

clean:
	rm -rf $(VENV) .pytest_cache .ruff_cache .benchmarks
