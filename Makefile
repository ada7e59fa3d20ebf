# README's two commands: `make demo` sets up for the demo and runs it, `make test` sets up for the
# tests and runs them. Each set-up step first checks whether it is done (dpkg for Debian packages,
# a stamp in the venv holding the sha256 of the files the step was run for, an import for torch)
# and says "skipped" when it is, so a second run installs nothing.
SHELL := /bin/bash
.SHELLFLAGS := -euo pipefail -c
.ONESHELL:
.NOTPARALLEL:
.DEFAULT_GOAL := help

PYTHON ?= python3
VENV ?= .venv
VENV_ROS2 ?= .venv-ros2
VENV_CLIENTS ?= .venv-clients
# RL libraries tested in a venv of their own (not dependencies: they pin their own ranges).
# Tianshou 2.0.1's high-level API imports its [eval] extra's modules (joblib, scipy).
# ray[rllib] 2.60 pins gymnasium 1.2.2, the lowest the project supports: the core's tests run on
# it here too.
CLIENT_PACKAGES := "tianshou[eval]==2.0.1" "ray[rllib]==2.60.0"
CLIENT_TESTS := tests/test_clients_tianshou.py tests/ray/test_rllib.py tests/ray/test_rllib_multi.py
LOWEST_GYMNASIUM_TESTS := tests/test_env.py tests/test_vector_env.py tests/test_determinism.py \
	tests/test_policies.py tests/test_sb3_vec_env.py
PYTEST_ARGS ?=
DEMO_ARGS ?=
TORCH_CPU_INDEX ?= https://download.pytorch.org/whl/cpu
# Where the CPU index is not reachable: the release that the project's machines hold as a CPU
# wheel on local disk (pip's find-links). Elsewhere PyPI's torch is a CUDA build of several GB.
TORCH_FALLBACK ?= 2.13.0
# Not root: apt-get through sudo.
SUDO := $(if $(filter 0,$(shell id -u)),,sudo)

DEMO_DEBS := libegl1 libegl-mesa0 libgl1-mesa-dri ffmpeg
TEST_DEBS := xvfb xauth tmux python3-rosbag python3-rospy python3-rosmaster python3-rostopic python3-roslaunch python3-std-msgs python3-rosgraph-msgs python3-geometry-msgs python3-sensor-msgs python3-nav-msgs python3-tf2-msgs
# What each step's stamp is the sha256 of: when one changes, the step runs again.
PIP_INPUTS := pyproject.toml
TF2_INPUTS := pyproject.toml bubblerob_env/ros/live/ros2_msgs/__init__.py bubblerob_env/ros/live/ros2_msgs/__main__.py bubblerob_cli/ros2_msgs.py bubblerob_env/ros/messages/msg/tf2_msgs/TFMessage.msg $(wildcard bubblerob_env/ros/messages/msg/vision_msgs/*.msg)
TORCH_REPORT := $(VENV)/.torch-install-report.json

.PHONY: help demo test demo-setup test-setup debs-demo debs-test venv venv-demo kernel venv-all torch \
	warp-kernels warp-kernels-ready \
	venv-ros2 tf2-msgs test-clients node-client

help:
	@echo "make demo        set up for the demo (Debian packages, $(VENV) with .[demo]), run it"
	echo "                 (DEMO_ARGS=... are passed to bubblerob demo)"
	echo "make test        set up for the tests (+ test packages, torch CPU, $(VENV) with .[all],"
	echo "                 $(VENV_ROS2) with .[ros2] and tf2_msgs, Foxglove's Node client), run"
	echo "                 pytest (PYTEST_ARGS=...)"
	echo "make demo-setup, make test-setup: the set-up alone"
	echo "make test-clients: Tianshou's and RLlib's tests in $(VENV_CLIENTS) (make test skips them)"
	echo "A second run skips what is installed, and says so."

# --overwrite: a second `make demo` replaces the first one's bag and video (bubblerob demo alone
# refuses to).
demo: demo-setup
	@echo "run: bubblerob demo --overwrite $(DEMO_ARGS)"
	source $(VENV)/bin/activate
	bubblerob demo --overwrite $(DEMO_ARGS)

test: test-setup
	@echo "run: python -m pytest $(PYTEST_ARGS)"
	source $(VENV)/bin/activate
	python -m pytest $(PYTEST_ARGS)

demo-setup: debs-demo venv venv-demo kernel
test-setup: demo-setup debs-test torch venv-all warp-kernels node-client venv-ros2 tf2-msgs \
	warp-kernels-ready

# The client libraries' tests skip in make test (not installed there): here they run, in their
# own venv with CPU torch, the project and those libraries.
test-clients: demo-setup
	@if [ ! -x $(VENV_CLIENTS)/bin/python ]; then $(PYTHON) -m venv $(VENV_CLIENTS); fi
	if $(VENV_CLIENTS)/bin/python -c "import torch, tianshou, ray.rllib" 2>/dev/null; then
	  echo "setup: torch and the clients are in $(VENV_CLIENTS): skipped"
	else
	  $(VENV_CLIENTS)/bin/pip install torch --index-url $(TORCH_CPU_INDEX) --timeout 20 \
	    --retries 1 || $(VENV_CLIENTS)/bin/pip install torch==$(TORCH_FALLBACK)
	  $(VENV_CLIENTS)/bin/pip install -e ".[dev]" $(CLIENT_PACKAGES)
	fi
	echo "run: $(VENV_CLIENTS)/bin/python -m pytest $(LOWEST_GYMNASIUM_TESTS) $(CLIENT_TESTS)"
	$(VENV_CLIENTS)/bin/python -m pytest $(LOWEST_GYMNASIUM_TESTS) $(CLIENT_TESTS)

# $(call apt_install,WHAT,PACKAGES): apt-get installs those of PACKAGES that are not installed.
define apt_install
missing=""
for package in $(2); do
  status=$$(dpkg-query -W -f='$${Status}' "$$package" 2>/dev/null || true)
  [ "$$status" = "install ok installed" ] || missing="$$missing $$package"
done
if [ -z "$$missing" ]; then
  echo "setup: Debian packages for $(1) are installed: skipped"
elif ! command -v apt-get >/dev/null; then
  echo "setup: no apt-get here; install$$missing (Debian's names) by hand, then run make again" >&2
  exit 1
else
  echo "setup: installing Debian packages for $(1):$$missing"
  $(SUDO) apt-get update && $(SUDO) env DEBIAN_FRONTEND=noninteractive apt-get install -y $$missing
fi
endef

debs-demo:
	@$(call apt_install,rendering and videos,$(DEMO_DEBS))

debs-test:
	@$(call apt_install,the tests,$(TEST_DEBS))

venv:
	@if [ -x $(VENV)/bin/python ]; then
	  echo "setup: $(VENV) exists: skipped"
	else
	  echo "setup: creating $(VENV)"
	  $(PYTHON) -m venv $(VENV)
	fi

# The numba kernels compile on their first call and are cached on disk: compile them here, once,
# so that the demo's first step and a node's first localisation do not wait (a second run loads
# them from the cache).
kernel: venv-demo
	@if compgen -G "bubblerob_env/core/__pycache__/kernel.step_robots*.nbi" >/dev/null \
	  && compgen -G "bubblerob_env/localisation/__pycache__/field.squared*.nbi" >/dev/null; then
	  echo "setup: the numba kernels are compiled (numba cache): skipped"
	else
	  echo "setup: compiling the numba kernels (once; cached in bubblerob_env/*/__pycache__)"
	  $(VENV)/bin/python -m bubblerob_env.core
	fi

# .[all] includes .[demo]: either stamp will do.
venv-demo: venv
	@if sha256sum --check --status $(VENV)/.stamp-demo 2>/dev/null \
	    || sha256sum --check --status $(VENV)/.stamp-all 2>/dev/null; then
	  echo "setup: $(VENV) has .[demo] for this $(PIP_INPUTS): skipped"
	else
	  echo "setup: installing .[demo] into $(VENV)"
	  $(VENV)/bin/pip install -e ".[demo]"
	  sha256sum $(PIP_INPUTS) > $(VENV)/.stamp-demo
	fi

venv-all: venv torch
	@if sha256sum --check --status $(VENV)/.stamp-all 2>/dev/null; then
	  echo "setup: $(VENV) has .[all] for this $(PIP_INPUTS): skipped"
	else
	  echo "setup: installing .[all] into $(VENV)"
	  $(VENV)/bin/pip install -e ".[all]"
	  sha256sum $(PIP_INPUTS) > $(VENV)/.stamp-all
	fi

# MuJoCo Warp (in .[all]) compiles its kernels on first use, about 90 s on two cores, and keeps them
# in Warp's kernel cache: compile them here, once, for the CPU device the tests use. The compile
# runs in the background while the ROS 2 venv is set up; warp-kernels-ready waits for it (its log
# says "ready" when it succeeded) before the tests start.
WARP_INPUTS := pyproject.toml bubblerob_env/mjwarp/kernels.py
WARP_LOG := $(VENV)/warp-kernels.log
WARP_PID := $(VENV)/warp-kernels.pid
warp-kernels: venv-all
	@if sha256sum --check --status $(VENV)/.stamp-warp-kernels 2>/dev/null \
	  && [ -d "$${HOME}/.cache/warp" ]; then
	  echo "setup: MuJoCo Warp's kernels are compiled (Warp's kernel cache): skipped"
	else
	  echo "setup: compiling MuJoCo Warp's kernels for the CPU device in the background (once;" \
	    "Warp's kernel cache; log: $(WARP_LOG))"
	  nohup $(VENV)/bin/python -m bubblerob_env.mjwarp cpu > $(WARP_LOG) 2>&1 &
	  echo $$! > $(WARP_PID)
	fi

warp-kernels-ready: warp-kernels
	@if [ ! -f $(WARP_PID) ]; then exit 0; fi
	while kill -0 "$$(cat $(WARP_PID))" 2>/dev/null; do sleep 1; done
	rm -f $(WARP_PID)
	if grep -q "MuJoCo Warp kernels ready" $(WARP_LOG); then
	  echo "setup: $$(grep "MuJoCo Warp kernels ready" $(WARP_LOG))"
	  sha256sum $(WARP_INPUTS) > $(VENV)/.stamp-warp-kernels
	else
	  echo "setup: compiling MuJoCo Warp's kernels failed; $(WARP_LOG) says:" >&2
	  tail -20 $(WARP_LOG) >&2
	  exit 1
	fi

# Prints which torch is in the venv, which build, and where pip took it from (the report that
# `pip install --report` wrote, argv[1]); fails where torch does not import.
define TORCH_SAYS
import json, os, sys, urllib.parse
import torch
build = f"CUDA {torch.version.cuda} build" if torch.version.cuda else "CPU-only build"
origin = "no pip report: installed before make"
if os.path.exists(sys.argv[1]):
    with open(sys.argv[1]) as report:
        for item in json.load(report)["install"]:
            if item["metadata"]["name"] == "torch":
                origin = "from " + urllib.parse.unquote(item["download_info"]["url"])
print(f"torch {torch.__version__} ({build}, {origin})")
endef
export TORCH_SAYS
torch_says := $(VENV)/bin/python -c "$$TORCH_SAYS" $(TORCH_REPORT)

# PyTorch's CPU index first; pip's configured indexes and find-links still count (here they hold
# the CPU wheel, so pip may take it from there even when that index is not reachable). What it
# installed, and from where, is printed from pip's report either way.
torch: venv
	@if said=$$($(torch_says) 2>/dev/null); then
	  echo "setup: $$said is in $(VENV): skipped"
	  exit 0
	fi
	echo "setup: installing torch into $(VENV), first from PyTorch's CPU index, $(TORCH_CPU_INDEX)"
	if ! $(VENV)/bin/pip install torch --index-url $(TORCH_CPU_INDEX) \
	    --timeout 20 --retries 1 --report $(TORCH_REPORT); then
	  echo "setup: no torch through PyTorch's CPU index (not reachable from here?); falling back" \
	    "to pip install torch==$(TORCH_FALLBACK) from pip's configured indexes and find-links"
	  $(VENV)/bin/pip install torch==$(TORCH_FALLBACK) --report $(TORCH_REPORT)
	fi
	echo "setup: installed $$($(torch_says))"

venv-ros2:
	@if [ -x $(VENV_ROS2)/bin/python ]; then
	  echo "setup: $(VENV_ROS2) exists: skipped"
	else
	  echo "setup: creating $(VENV_ROS2)"
	  $(PYTHON) -m venv $(VENV_ROS2)
	fi
	if sha256sum --check --status $(VENV_ROS2)/.stamp-ros2 2>/dev/null; then
	  echo "setup: $(VENV_ROS2) has .[ros2] for this $(PIP_INPUTS): skipped"
	else
	  echo "setup: installing .[ros2] into $(VENV_ROS2)"
	  $(VENV_ROS2)/bin/pip install -e ".[ros2]"
	  sha256sum $(PIP_INPUTS) > $(VENV_ROS2)/.stamp-ros2
	fi

tf2-msgs: venv-ros2
	@if sha256sum --check --status $(VENV_ROS2)/.stamp-tf2-msgs 2>/dev/null; then
	  echo "setup: $(VENV_ROS2) has tf2_msgs and vision_msgs, built from these $(TF2_INPUTS): skipped"
	else
	  echo "setup: building tf2_msgs and vision_msgs into $(VENV_ROS2)"
	  $(VENV_ROS2)/bin/python -m bubblerob_env.ros.live.ros2_msgs
	  sha256sum $(TF2_INPUTS) > $(VENV_ROS2)/.stamp-tf2-msgs
	fi

# Foxglove's own WebSocket client (@foxglove/ws-protocol, on Node.js) for tests/foxglove: npm ci
# installs exactly what $(NODE_CLIENT)/package-lock.json pins. Node.js itself is Debian's nodejs
# (with npm) where it is missing. The stamp in node_modules holds the lockfile's sha256.
NODE_CLIENT := tests/foxglove
node-client:
	@if command -v npm >/dev/null; then
	  echo "setup: Node.js $$(node --version) and npm are installed: skipped"
	else
	  $(call apt_install,Foxglove's Node client,nodejs npm)
	fi
	if sha256sum --check --status $(NODE_CLIENT)/node_modules/.stamp-npm 2>/dev/null; then
	  echo "setup: $(NODE_CLIENT)/node_modules has this package-lock.json: skipped"
	else
	  echo "setup: npm ci in $(NODE_CLIENT) (@foxglove/ws-protocol, for tests/foxglove)"
	  npm ci --prefix $(NODE_CLIENT) --no-audit --no-fund
	  sha256sum $(NODE_CLIENT)/package-lock.json > $(NODE_CLIENT)/node_modules/.stamp-npm
	fi
