# The two commands of the README:  `make repro`  and  `make test`  (`make test-all`: every test).
# Both create .venv and install the package with its dependencies (idempotent: a second call
# installs nothing unless pyproject.toml, requirements.lock or the llama.cpp build choice changed).
VENV ?= .venv
PYTHON ?= python3
PY := $(VENV)/bin/python
# The exact versions behind the committed results (resolved on Python 3.11). `CONSTRAINTS=`
# installs from pyproject.toml's ranges instead (tests/test_reproduce.py then says what drifted).
CONSTRAINTS ?= -c requirements.lock
export PATH := $(abspath $(VENV))/bin:$(PATH)

# llama-cpp-python compiles llama.cpp at install time. It is built here for one pinned, portable
# CPU baseline (x86-64: AVX2 + FMA + F16C, no AVX-512 or AMX; see interllm/llama_build.py), into a
# project-local wheel folder named by the version, the flags and the Python (pip's own wheel cache
# is keyed by version only and would hand back a native wheel built earlier).
# `make install LLAMA_NATIVE=1` builds for this CPU instead: faster, but cold-run answers then
# depend on the CPU, and provenance.json records the choice.
LLAMA_NATIVE ?= 0
LLAMA_VERSION := $(shell sed -n 's/^llama_cpp_python==//p' requirements.lock)
LLAMA_BUILD = $(PYTHON) -m interllm.llama_build --version $(LLAMA_VERSION) --native $(LLAMA_NATIVE)
LLAMA_KEY := $(shell $(LLAMA_BUILD) key)
LLAMA_WHEELS := .wheels/llama-cpp-python-$(LLAMA_KEY)
LLAMA_STAMP := $(VENV)/.llama-$(LLAMA_KEY)
JOBS := $(shell nproc 2>/dev/null || echo 2)

.PHONY: results mechanism sweeps sweep-report install install-llama repro test test-ci test-all lint bench params clean-cache lock

install: $(VENV)/.installed

$(PY):
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip

# The wheel, built once per key (about 8 minutes on 2 cores); written to a partial folder first,
# so an interrupted build leaves nothing that looks finished. The caller's compiler flags and
# scikit-build-core settings are dropped: the flags are the baseline's, whoever runs make.
$(LLAMA_WHEELS)/.built: | $(PY)
	@echo "make: building llama-cpp-python $(LLAMA_VERSION) ($$($(LLAMA_BUILD) kind) build, about 8 minutes on 2 cores)"
	rm -rf $(LLAMA_WHEELS).partial
	env -u CFLAGS -u CXXFLAGS -u SKBUILD_CMAKE_ARGS -u SKBUILD_CMAKE_DEFINE -u FORCE_CMAKE \
	  CMAKE_ARGS="$$($(LLAMA_BUILD) cmake-args)" CMAKE_BUILD_PARALLEL_LEVEL=$(JOBS) \
	  $(PY) -m pip wheel --quiet --no-deps --no-cache-dir --no-binary llama-cpp-python \
	  'llama-cpp-python==$(LLAMA_VERSION)' -w $(LLAMA_WHEELS).partial
	touch $(LLAMA_WHEELS).partial/.built
	rm -rf $(LLAMA_WHEELS) && mv $(LLAMA_WHEELS).partial $(LLAMA_WHEELS)

# Install that wheel (replacing any other llama-cpp-python build) and record which build it is.
$(LLAMA_STAMP): $(LLAMA_WHEELS)/.built | $(PY)
	rm -f $(VENV)/.llama-* $(VENV)/.installed
	$(PY) -m pip install --quiet --force-reinstall --no-deps $(LLAMA_WHEELS)/llama_cpp_python-*.whl
	$(LLAMA_BUILD) record --wheel $$(ls $(LLAMA_WHEELS)/llama_cpp_python-*.whl) > $(VENV)/llama-build.json.tmp
	mv $(VENV)/llama-build.json.tmp $(VENV)/llama-build.json
	touch $@

# Everything else. --only-binary keeps pip from building llama-cpp-python again from source.
# Two data packages are installed without their dependencies: the Stretch robot's URDF and meshes
# (sim/robot=stretch; its URDF loader urchin, with pyglet and trimesh, is not needed, since
# interllm/sim/urdf_chain.py reads the file itself) and ProcTHOR's asset database (procthor: its
# house generator's numpy, matplotlib, trimesh, python-sat and AI2-THOR are not needed, since
# interllm/scene/procthor_db.py reads the JSON files itself).
$(VENV)/.installed: pyproject.toml requirements.lock $(LLAMA_STAMP)
	$(PY) -m pip install --quiet $(CONSTRAINTS) --only-binary llama-cpp-python \
	  --find-links $(LLAMA_WHEELS) -e '.[dev]'
	$(PY) -m pip install --quiet --no-deps $(CONSTRAINTS) hello-robot-stretch-urdf procthor
	touch $@

# Reinstall the llama.cpp build this Makefile's settings choose (the fix that a model-load check
# names when the installed build is not the pinned baseline).
install-llama:
	rm -f $(LLAMA_STAMP)
	$(MAKE) install

# Re-pin requirements.lock to what .venv holds now (after a deliberate upgrade; then make repro
# and commit the new results with it).
lock: install
	{ sed -n '/^#/p' requirements.lock; $(PY) -m pip list --format=freeze --exclude-editable --exclude pip --exclude setuptools; } > requirements.lock.tmp
	@grep -q '^mujoco==' requirements.lock.tmp || { rm -f requirements.lock.tmp; \
	  echo "make lock: pip listed no mujoco pin; requirements.lock left unchanged" >&2; exit 1; }
	mv requirements.lock.tmp requirements.lock

# Run the default experiment (the paper's protocol on the embedded model) with DVC, then say
# whether data/metrics/metrics.json reproduces the committed one (and if not: what moved, which
# conclusions changed, and how this machine's environment differs from the one that made them).
repro: install
	$(PY) -m pipeline.check_outputs
	dvc repro
	$(PY) -m interllm.cli results diff

# Test tiers (markers in pyproject.toml). `make test`: the fast tier, every unit and component test
# (the real embedded model included) but none that runs stages or the whole pipeline.
# `make test-ci`: the fast tier plus the integration tests (quick experiments through DVC, the
# committed results reproduced from the cache, real LLM servers): what .ci/run runs.
# `make test-all`: every test, the `slow` ones too (each repeats a path a shorter test covers).
# The tests run on every core (pytest-xdist, TEST_WORKERS=1 for one process); each file's tests stay
# on one worker (--dist loadfile), so a module's fixtures (a started server, a generated house) are
# built once.
TEST_WORKERS ?= $(JOBS)
PYTEST = $(PY) -m pytest -n $(TEST_WORKERS) --dist loadfile

test: install
	$(PYTEST) -m "not slow and not integration"

test-ci: install
	$(PYTEST) -m "not slow" --durations=15

test-all: install
	$(PYTEST) -m ""

lint: install
	$(VENV)/bin/ruff check .

# The mechanism experiments: conf/experiment/mechanism.yaml at oracle error 0 and 0.25, and
# conf/experiment/mechanism_model.yaml (the embedded model on the default houses); each run's
# metrics and report are copied to data/mechanism/<run>/ (committed) and compared with the
# committed versions (`interllm results diff`). Resumable: a run already finished with the same
# config, code and benchmark is skipped (resume=true; `make mechanism FRESH=1` starts over).
MECHANISM_ERRORS ?= 0,0.25
mechanism: install
	$(if $(FRESH),rm -rf multirun/mechanism)
	$(PY) -m pipeline.run -m experiment=mechanism llm.oracle_error=$(MECHANISM_ERRORS) resume=true scenes_cache=multirun/scenes_cache \
	    hydra.sweep.dir=multirun/mechanism 'hydra.sweep.subdir=oracle_error_$${llm.oracle_error}'
	$(PY) -m pipeline.run experiment=mechanism_model resume=true scenes_cache=multirun/scenes_cache hydra.run.dir=multirun/mechanism/embedded
	$(PY) -m pipeline.collect_runs multirun/mechanism data/mechanism
	$(PY) -m interllm.cli results diff --file data/mechanism/*/metrics/metrics.json

# Every committed result re-made by one command, each compared with its committed version: the
# default experiment, the sweeps and the mechanism runs (about 1.5 h on 2 cores, committed cache).
# Interrupted, it resumes job by job: DVC skips the default run's finished stages, and every sweep
# or mechanism job already finished with the same config, code and benchmark is skipped, or restored
# from its committed copy on a fresh clone (interllm/stages/resume.py); the jobs of one scene setting share its scenes, made once
# (scenes_cache, interllm/stages/shared_scenes.py). FRESH=1 discards the finished jobs first.
results: repro sweeps mechanism

# The sweeps: each experiment of SWEEPS runs the grid its conf/experiment/<name>.yaml declares
# (hydra.sweeper.params) into multirun/sweeps/<name>/; the jobs' config and metrics are copied to
# data/sweeps/<name>/<job>/ (committed), the sweep report is built from that copy into
# data/report_sweeps/, and every job's metrics.json is compared with its committed version.
# `make sweeps SWEEPS=oracle_sweep` re-runs one; the others' committed copies stay. Finished jobs
# are skipped (resume=true); FRESH=1 starts every sweep of SWEEPS over (needed after a grid
# shrinks: its old job folders would otherwise be collected too).
SWEEPS ?= encoding_comparison oracle_sweep m_ablation temperature_ablation estimate_comparison
sweeps: install
	for e in $(SWEEPS); do $(if $(FRESH),rm -rf multirun/sweeps/$$e;) \
	    $(PY) -m pipeline.run -m experiment=$$e resume=true scenes_cache=multirun/scenes_cache hydra.sweep.dir=multirun/sweeps/$$e || exit 1; done
	$(PY) -m pipeline.collect_sweeps multirun/sweeps data/sweeps $(SWEEPS)
	$(MAKE) sweep-report

# The sweeps re-made on paper-v3 so far (issue 56): the report is built from them alone, so that no
# section pairs a paper-v3 run with a paper-v2 job; the rest is quoted from the frozen
# data/report_sweeps_paper_v2/report.md. `data/sweeps` once every sweep is re-made.
SWEEP_REPORT_FROM ?= data/sweeps/encoding_comparison data/sweeps/oracle_sweep data/sweeps/m_ablation

sweep-report: install
	$(PY) -m interllm.cli report --sweeps $(SWEEP_REPORT_FROM) --out data/report_sweeps
	$(PY) -m interllm.cli results diff --file data/sweeps/*/*/data/metrics/metrics.json

# Recompose params.yaml from conf/ after editing conf/ by hand (dvc exp run does it itself).
params: install
	$(PY) -m pipeline.params

bench: install
	for b in benchmarks/bench_*.py; do echo "== $$b"; $(PY) $$b || exit 1; done

# Forget every cached LLM answer: the next run asks the model again.
clean-cache:
	rm -rf data/llm_cache
