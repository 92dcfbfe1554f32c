# gloverec: `make demo` runs the main job with the emulated glove, `make test` runs the suite (`make check`: the
# tests that start no process),
# `make bench` runs every benchmark in bench/ (each writes bench/results/<name>.json).
# Python 3.12 (LeRobot 0.6 needs >= 3.12): python3.12 on PATH if it runs (a pyenv shim may not), else the newest
# 3.12 under pyenv
PYTHON ?= $(shell for p in python3.12 $$(ls -d $(HOME)/.pyenv/versions/3.12*/bin/python3.12 2>/dev/null | sort -rV); do \
             $$p -c 'import sys; assert sys.version_info[:2] == (3, 12)' >/dev/null 2>&1 && { command -v $$p; break; }; \
           done)
VENV   ?= .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed
export HF_HUB_OFFLINE ?= 1
export MUJOCO_GL ?= egl

.PHONY: install demo test check bench clean system video firmware flash

# Debian packages a target needs are installed when missing (CI runs as root with the package registries
# reachable); when that fails, one line names them and make stops. $(1): a shell test that holds when they are
# there, $(2): the packages.
define need_packages
	@if ! { $(1); } >/dev/null 2>&1; then \
	  echo "installing $(2)"; \
	  { apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $(2) >/dev/null; } \
	  || { echo "make: cannot install the Debian packages $(2): install them, then run make again" >&2; exit 1; }; \
	fi
endef
have = $(foreach t,$(1),command -v $(t) &&) true

# the live-view tests: a virtual display, a key sender, a headless browser
SYSTEM_PACKAGES := xvfb xdotool chromium chromium-driver
# the firmware: cross compiler, newlib and its libstdc++ for the Cortex-M7, QEMU for an emulated M7
FIRMWARE_PACKAGES := cmake g++ gcc-arm-none-eabi libnewlib-arm-none-eabi libstdc++-arm-none-eabi-newlib \
                     qemu-system-arm
FIRMWARE_HAVE := $(call have,cmake g++ arm-none-eabi-g++ qemu-system-arm) && \
                 test -f "$$(arm-none-eabi-gcc -print-file-name=librdimon.a)" && \
                 test -f "$$(arm-none-eabi-gcc -print-file-name=libstdc++.a)"
FW_HOST   := build/firmware
FW_M7     := firmware/build/m7
FW_TEENSY := firmware/build/teensy40
TOOLCHAIN := $(CURDIR)/firmware/cmake/arm-none-eabi.cmake
IMAGE     ?= glove

install: $(STAMP)

PLUGINS := policies/plugin recorder/plugin envs/plugin   # LeRobot plugins: policy gloverec_bc, teleop gloverec_glove, robot gloverec_sim

$(STAMP): pyproject.toml $(addsuffix /pyproject.toml,$(PLUGINS))
	@test -n "$(PYTHON)" || { echo "make: no Python 3.12 found (python3.12 on PATH or under pyenv): install it, e.g. pyenv install 3.12, or pass PYTHON=/path/to/python3.12" >&2; exit 1; }
	@$(PY) -c 'import sys; sys.exit(sys.version_info[:2] != (3, 12))' 2>/dev/null || { rm -rf $(VENV) && $(PYTHON) -m venv $(VENV); }
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -e '.[test]'
	$(PY) -m pip install -q --no-deps $(addprefix -e ,$(PLUGINS))
	@touch $(STAMP)

demo: $(STAMP) video
	$(PY) -m recorder.demo

system:
	$(call need_packages,$(call have,Xvfb xdotool chromium chromedriver),$(SYSTEM_PACKAGES))

# LeRobot 0.6 decodes camera videos with torchcodec, which loads FFmpeg's shared libraries (libavdevice among
# them, which a bare Debian lacks); without them every dataset lerobot opens logs a 20-line warning and falls
# back to PyAV. Debian's ffmpeg brings that release's libraries.
video: $(STAMP)
	$(call need_packages,$(PY) -c 'import torchcodec.decoders',ffmpeg)

# The firmware for the real chip: the core's unit tests on the host and on an emulated Cortex-M7 (QEMU
# mps2-an500), the M7's output against the host's bit for bit, its instruction counts against
# firmware/m7_counts.json, and the Teensy 4.0 images (firmware/build/teensy40/*.hex) with their sizes.
firmware:
	$(call need_packages,$(FIRMWARE_HAVE),$(FIRMWARE_PACKAGES))
	@cmake -S firmware -B $(FW_HOST) -DCMAKE_BUILD_TYPE=Release >/dev/null
	cmake --build $(FW_HOST) -j 2
	ctest --test-dir $(FW_HOST) --output-on-failure -j 2
	@cmake -S firmware -B $(FW_M7) --toolchain $(TOOLCHAIN) -DGLOVE_TARGET=m7 \
	  -DGLOVE_HOST_BUILD=$(CURDIR)/$(FW_HOST) >/dev/null
	cmake --build $(FW_M7) -j 2
	ctest --test-dir $(FW_M7) --output-on-failure -j 2
	@cmake -S firmware -B $(FW_TEENSY) --toolchain $(TOOLCHAIN) -DGLOVE_TARGET=teensy40 >/dev/null
	cmake --build $(FW_TEENSY) -j 2
	@for i in glove glove_16imu glove_uart; do \
	  python3 firmware/tools/teensy_size.py $(FW_TEENSY)/$$i.elf --json $(FW_TEENSY)/$$i.size.json || exit 1; done

# Flash a Teensy 4.0 on USB with Debian's teensy-loader-cli: IMAGE=glove (default), glove_16imu or glove_uart.
flash: firmware
	$(call need_packages,$(call have,teensy_loader_cli),teensy-loader-cli)
	@grep -qsi '^16c0$$' /sys/bus/usb/devices/*/idVendor || { echo "make flash: no Teensy on USB (vendor \
	16c0): connect the glove's Teensy 4.0 with a data cable (press its button if it still does not show)" >&2; \
	exit 1; }
	teensy_loader_cli --mcu=TEENSY40 -w -v -s $(FW_TEENSY)/$(IMAGE).hex

# The suite: the tests on $(JOBS) xdist workers (more than the 2 cores: many tests wait on real time, an emulator
# or a child process), in one pass: no test depends on the machine being idle (each waits for a signal, never for
# a sleep to be long enough; speeds and latencies are measured in bench/), so the suite passes beside other
# CPU-heavy work too. `make check`: the tests that start no process, for a quick loop.
JOBS   ?= 3
PYTEST := $(PY) -m pytest -q --durations=20
test: $(STAMP) system video firmware
	$(VENV)/bin/ruff check .
	$(VENV)/bin/ruff format --check .
	$(VENV)/bin/lint-imports
	$(PYTEST) -n $(JOBS) --dist loadgroup

check: $(STAMP)
	$(PYTEST) -n 2 -m "not process"

# The benchmarks' extra brings diffusers (LeRobot's Diffusion Policy, bench/learning_visual.py). Once it is
# installed, every process that imports lerobot also loads it: 1-3 s more per gloverec or lerobot-* command
# here. `make test`'s times are for a .venv without it (`pip uninstall diffusers` gives them back).
bench: $(STAMP)
	$(PY) -m pip install -q -e '.[test,bench]'
	@mkdir -p bench/results
	@for b in bench/*.py; do echo "== $$b"; $(PY) $$b || exit 1; done

clean:
	rm -rf $(VENV) build firmware/build *.egg-info .pytest_cache
