# gloverec: `make demo` runs the main job with the emulated glove, `make test` runs the suite,
# `make bench` runs every benchmark in bench/ (each writes bench/results/<name>.json).
PYTHON ?= python3
VENV   ?= .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed
export HF_HUB_OFFLINE ?= 1
export MUJOCO_GL ?= egl

.PHONY: install demo test bench clean

install: $(STAMP)

PLUGINS := policies/plugin recorder/plugin envs/plugin   # LeRobot plugins: policy gloverec_bc, teleop gloverec_glove, robot gloverec_sim

$(STAMP): pyproject.toml $(addsuffix /pyproject.toml,$(PLUGINS))
	@test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -e '.[test]'
	$(PY) -m pip install -q --no-deps $(addprefix -e ,$(PLUGINS))
	@touch $(STAMP)

demo: $(STAMP)
	$(PY) -m recorder.demo

test: $(STAMP)
	$(VENV)/bin/ruff check .
	$(VENV)/bin/ruff format --check .
	$(VENV)/bin/lint-imports
	$(PY) -m pytest -q

bench: $(STAMP)
	$(PY) -m pip install -q -e '.[test,bench]'
	@mkdir -p bench/results
	@for b in bench/*.py; do echo "== $$b"; $(PY) $$b || exit 1; done

clean:
	rm -rf $(VENV) build *.egg-info .pytest_cache
