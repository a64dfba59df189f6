# The two commands of the README:  `make repro`  and  `make test`.
# Both create .venv and install the package with its dependencies (idempotent: a second call
# installs nothing unless pyproject.toml changed).
VENV ?= .venv
PYTHON ?= python3
PY := $(VENV)/bin/python
# The exact versions behind the committed results (resolved on Python 3.11). `CONSTRAINTS=`
# installs from pyproject.toml's ranges instead (tests/test_reproduce.py then says what drifted).
CONSTRAINTS ?= -c requirements.lock
export PATH := $(abspath $(VENV))/bin:$(PATH)

.PHONY: install repro test lint bench params clean-cache lock

install: $(VENV)/.installed

$(VENV)/.installed: pyproject.toml requirements.lock
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet $(CONSTRAINTS) -e '.[dev]'
	touch $@

# Re-pin requirements.lock to what .venv holds now (after a deliberate upgrade; then make repro
# and commit the new results with it).
lock: install
	{ sed -n '/^#/p' requirements.lock; $(PY) -m pip freeze --exclude-editable | grep -v '^-e'; } > requirements.lock.tmp
	@grep -q '^mujoco==' requirements.lock.tmp || { rm -f requirements.lock.tmp; \
	  echo "make lock: pip freeze listed no mujoco pin; requirements.lock left unchanged" >&2; exit 1; }
	mv requirements.lock.tmp requirements.lock

# Run the default experiment (the paper's protocol on the embedded model) with DVC, then say
# whether data/metrics/metrics.json reproduces the committed one (and if not: what moved, which
# conclusions changed, and how this machine's environment differs from the one that made them).
repro: install
	dvc repro
	$(PY) -m interllm.cli results diff

# The test suite (what CI runs).
test: install
	$(PY) -m pytest

lint: install
	$(VENV)/bin/ruff check .

# Recompose params.yaml from conf/ after editing conf/ by hand (dvc exp run does it itself).
params: install
	$(PY) -m pipeline.params

bench: install
	for b in benchmarks/bench_*.py; do echo "== $$b"; $(PY) $$b || exit 1; done

# Forget every cached LLM answer: the next run asks the model again.
clean-cache:
	rm -rf data/llm_cache
