# gloverec: `make demo` runs the main job with the emulated glove, `make test` runs the suite,
# `make bench` runs every benchmark in bench/ (each writes bench/results/<name>.json).
PYTHON ?= python3
VENV   ?= .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed
export HF_HUB_OFFLINE ?= 1
export MUJOCO_GL ?= egl

.PHONY: install demo test bench clean system

# Debian packages the live-view tests use (a virtual display, a key sender, a headless browser); installed when
# missing (CI runs as root with the package registries reachable).
SYSTEM_TOOLS    := Xvfb xdotool chromium chromedriver
SYSTEM_PACKAGES := xvfb xdotool chromium chromium-driver

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

system:
	@missing=$$(for t in $(SYSTEM_TOOLS); do command -v $$t >/dev/null || echo $$t; done); \
	if [ -n "$$missing" ]; then \
	  echo "installing $(SYSTEM_PACKAGES) (missing: $$missing)"; \
	  { apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $(SYSTEM_PACKAGES) >/dev/null; } \
	  || { echo "make: cannot install the Debian packages $(SYSTEM_PACKAGES): install them, then run make test again" >&2; exit 1; }; \
	fi

test: $(STAMP) system
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
