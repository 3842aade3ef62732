# repro: two commands do all set-up —  `make reproduce`  and  `make test`.
# Both create .venv with pip when it is missing or stale (requirements changed).

PYTHON ?= python3.11
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed
LAB    := $(VENV)/.installed-lab
FLOW   := $(VENV)/.installed-workflow
JOBS   ?= 2
SEED   ?= 0
SCALE  ?= standard
ARGS   ?=
# results/ holds a standard-scale run only: the other scales never refresh it.
SNAPSHOT := $(if $(filter standard,$(SCALE)),--snapshot)
# Bytecode is compiled once, on every core, for what can be imported: not the packages' own
# test suites, nor transformers' other model families (MiniLM is a BERT). pip alone compiles
# everything on one core (~40 s). This machine and CI set PYTHONDONTWRITEBYTECODE, so a module
# left uncompiled is compiled again at every import: --no-compile never goes alone. A file that
# does not compile (as pip, which skips them silently) fails the set-up here.
NOT_IMPORTED := /tests?/|/torch/testing/_internal/|/transformers/models/(?!auto/|bert/|__init__)

.DEFAULT_GOAL := help
.PHONY: help setup test test-workflow unit notebooks-quick reproduce bench lint check-rendered lab clean

help:  ## list the targets
	@grep -E '^[a-z-]+:.*##' $(MAKEFILE_LIST) | awk -F':.*## ' '{printf "  make %-16s %s\n", $$1, $$2}'

$(STAMP): requirements.txt requirements-dev.txt pyproject.toml
	@command -v $(PYTHON) >/dev/null 2>&1 || { echo "error: $(PYTHON) not found (Python 3.11 is required; set PYTHON=...)"; exit 1; }
	@test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet --no-compile -r requirements-dev.txt
	$(PY) -m compileall -q -j 0 -x '$(NOT_IMPORTED)' $(VENV)/lib
	$(PY) -m pip install --quiet --no-deps --no-build-isolation -e .
	$(PY) -m ipykernel install --sys-prefix --name repro --display-name "repro (.venv)" >/dev/null
	@touch $(STAMP)

$(LAB): $(STAMP) requirements-lab.txt
	$(PY) -m pip install --quiet -r requirements-lab.txt
	@touch $(LAB)

$(FLOW): $(STAMP) requirements-workflow.txt
	$(PY) -m pip install --quiet -r requirements-workflow.txt
	@touch $(FLOW)

setup: $(STAMP) $(LAB) $(FLOW)  ## create or refresh .venv (pinned requirements, kernel "repro", JupyterLab, Snakemake)

# Jupyter refuses to start as root (containers, CI images) without --allow-root.
ROOT_FLAG := $(if $(filter 0,$(shell id -u 2>/dev/null)),--allow-root)

lab: $(LAB)  ## open the notebooks in JupyterLab (ARGS="--no-browser --port 8899"; as root, --allow-root)
	$(VENV)/bin/jupyter lab notebooks $(ROOT_FLAG) $(ARGS)

unit: $(STAMP)  ## unit tests only (no notebooks)
	$(PY) -m pytest -q -n $(JOBS) --dist loadfile -m "not notebook"

test: $(STAMP) $(FLOW)  ## lint + unit tests + every notebook executed with quick parameters
	$(PY) -m ruff check src tests notebooks scripts
	$(PY) -m pytest -q -n $(JOBS) --dist loadfile -m "not workflow"

test-workflow: $(FLOW)  ## a real local Snakemake run of two notebooks at the quick scale against reproduce
	$(PY) -m pytest -q -m workflow tests/workflow

reproduce: $(STAMP)  ## every notebook at the standard scale (SCALE=paper: the papers' settings); build/report, results/
	$(PY) -m repro reproduce --scale $(SCALE) --jobs $(JOBS) --seed $(SEED) $(SNAPSHOT) $(ARGS)

bench: $(STAMP)  ## time budgets and training throughput; writes build/bench/bench.json (ARGS="--full", "--warm-cache DIR")
	$(PY) -m repro bench $(ARGS)
	$(PY) -m repro bench --training

check-rendered: $(STAMP)  ## open results/ and build/report in headless Chromium, offline: figures load, links work, equations typeset
	$(PY) scripts/check_rendered.py $(ARGS)

lint: $(STAMP)  ## ruff on the library, tests and notebooks
	$(PY) -m ruff check src tests notebooks scripts

clean:  ## remove build outputs and caches (keeps .venv)
	rm -rf build .pytest_cache .ruff_cache
