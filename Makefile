# `make demo` and `make test` set everything up on a fresh machine (Python >= 3.11 and pip only).
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: demo test test-fast test-min docs bench clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)

$(STAMP): pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[test,docs,codegen,dask,mhe]"
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/nlobs demo gnss-ins --out out/gnss-ins

# the tests in parallel, one worker per core (pytest-xdist), each single-threaded in BLAS (no oversubscription)
TEST_WORKERS ?= auto
test: $(STAMP)
	MPLBACKEND=Agg OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1 \
	  $(BIN)/python -m pytest -q -p no:cacheprovider -n $(TEST_WORKERS)

# the inner loop of a developer: every test but those marked slow (each ≥ 1.5 s); `make test` runs them all
test-fast: $(STAMP)
	MPLBACKEND=Agg OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1 \
	  $(BIN)/python -m pytest -q -p no:cacheprovider -n $(TEST_WORKERS) -m "not slow"

# the declared minimum version of every dependency, in a second venv, against .venv (.ci/min_versions.py)
test-min: $(STAMP)
	$(PYTHON) .ci/min_versions.py --reference $(BIN)/python

# the documentation site (MkDocs + mkdocstrings) into build/site; a warning or a broken link fails it
docs: $(STAMP)
	NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs build --strict

bench: $(STAMP)
	for b in benchmarks/*.py; do $(BIN)/python $$b || exit 1; done

clean:
	rm -rf $(VENV) $(VENV)-min build dist
