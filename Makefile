# littledog_mlsim — one-command set-up and jobs. Every target creates .venv from the pinned
# requirements first if it is missing (or if the pins changed). Packages are byte-compiled as
# they are installed: where PYTHONDONTWRITEBYTECODE is set, Python never writes what it compiles
# on import, so every process would compile them again (benchmarks/ci_time/).
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed
CHROMIUM_STAMP := $(VENV)/.chromium-tried
DATA ?= bags/default
# `make run`: the demo's dataset and model (built by the demo if absent)
DEMO_DATA ?= bags/demo
DEMO_MODEL ?= bags/demo_lgpr
# Pin BLAS to one thread: OpenBLAS threading is 20-40x slower on 2 cores; we parallelise across processes.
export OPENBLAS_NUM_THREADS := 1
export OMP_NUM_THREADS := 1
export MKL_NUM_THREADS := 1

.PHONY: run live test venv dataset reproduce bench clean

venv: $(STAMP)

# The pins are installed by uv (pinned in constraints.txt), byte-compiled as pip would, in about
# 40 % of pip's time from an empty cache (benchmarks/ci_time/install_uv.txt). Where uv cannot be
# had or fails, pip installs them instead. uv reads its own settings (UV_INDEX_URL, ...), not
# pip's: with a pip index or no index set (PIP_INDEX_URL, PIP_NO_INDEX), or `make USE_UV=0`, pip
# installs them.
USE_UV ?= $(if $(PIP_INDEX_URL)$(PIP_NO_INDEX),0,1)
$(STAMP): requirements.txt constraints.txt setup.py setup.cfg package.xml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	([ "$(USE_UV)" = 1 ] && $(PY) -m pip install --quiet uv -c constraints.txt \
		&& $(VENV)/bin/uv pip install --quiet --python $(PY) --compile-bytecode -r requirements.txt -c constraints.txt) \
		|| (echo "installing the pins with pip" && $(PY) -m pip install --quiet -r requirements.txt -c constraints.txt)
	$(PY) -m pip install --quiet --no-deps --no-build-isolation -e .
	# setup.cfg puts console scripts in lib/littledog_mlsim (where `ros2 run` looks); link them into bin
	for f in $(VENV)/lib/littledog_mlsim/*; do ln -sf ../lib/littledog_mlsim/$$(basename $$f) $(VENV)/bin/; done
	touch $(STAMP)

# The main job (littledog_mlsim/apps/demo.py): record a small dataset and train an LGPR model if
# absent, then replay a TestPool move through sim_node and pybullet_node over ROS 2 and report
# the learned simulator's error against pybullet.
# `make run VIEW=1` also serves the browser view (docs/viewer.md) and keeps it up until Ctrl-C.
run: $(STAMP)
	$(PY) -m littledog_mlsim.apps.demo --data $(DEMO_DATA) --model $(DEMO_MODEL)$(if $(VIEW), --view)

# Record -> train -> swap live (littledog_mlsim/apps/live_demo.py): pybullet_node, trainer_node
# (live) and sim_node; a trot recorded and trained on, sim_node started on it, a second trot
# recorded and trained on, sim_node swapped to the new model without a restart.
live: $(STAMP)
	$(PY) -m littledog_mlsim.apps.live_demo

# The suite runs in TEST_WORKERS pytest-xdist worker processes (CI has 2 cores; 0: in this
# process), a test module at a time per worker (`--dist loadfile`: a module's fixtures and its
# leak check stay in one process).
# The package's own modules are byte-compiled first: the suite starts many Python processes (CLI,
# nodes, Dask workers), and where PYTHONDONTWRITEBYTECODE is set each would compile them again
# (benchmarks/ci_time/pyc/).
TEST_WORKERS ?= 2
test: $(STAMP) $(CHROMIUM_STAMP)
	$(PY) -m compileall -q littledog_mlsim
	$(PY) -m pytest -q --durations=15 -n $(TEST_WORKERS) --dist loadfile test

# Headless Chromium for the view's browser tests (test/viewer/test_viewer_browser.py), from Debian's
# packages, tried once (root with apt-get only); never fatal: without it those tests skip and say why.
$(CHROMIUM_STAMP): | $(STAMP)
	@if command -v chromium >/dev/null 2>&1; then :; \
	elif [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then \
		echo "installing chromium (Debian package) for the browser tests"; \
		(apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null) \
			|| echo "chromium could not be installed: the browser tests will skip"; \
	else echo "no chromium and no root apt-get: the browser tests will skip"; fi
	@touch $@

dataset: $(STAMP)
	$(VENV)/bin/littledog-mlsim record --out $(DATA)

# Paper-scale Table I, Fig. 4, Figs 5-7 and the animation (long: run by hand, not in CI).
reproduce: $(STAMP)
	test -f $(DATA)/dataset.yaml || $(VENV)/bin/littledog-mlsim record --out $(DATA)
	$(VENV)/bin/littledog-mlsim reproduce --data $(DATA) --out benchmarks/reproduce_paper --scale paper \
		--physics-config benchmarks/physics_baseline/nominal_tuned.json

bench: $(STAMP)
	$(PY) benchmarks/record_speed/record_speed.py

clean:
	rm -rf build install log *.egg-info .pytest_cache
