# pushgrasp: `make test` and `make demo` are all a user types on a fresh Debian 12 machine (both run setup first).
SHELL := /bin/bash
.DEFAULT_GOAL := help
REPO := $(abspath .)
VENV := $(REPO)/.venv
PY := $(VENV)/bin/python
STAMP := .stamps
CATKIN_INPUTS := $(shell find catkin_ws/src -name package.xml -o -name CMakeLists.txt -o -name '*.msg' -o -name '*.srv' \
                   -o -name '*.action' -o -name '*.cpp' -o -name '*.h' -o -name setup.py 2>/dev/null)

.PHONY: help setup build test test-python test-cpp lint demo train urdf clean

help:
	@echo "make setup   Debian ROS packages, .venv (torch, pybullet, ...), catkin build (idempotent)"
	@echo "make build   catkin_make of catkin_ws (C++ nodes, messages)"
	@echo "make test    every test tier (runs setup first)"
	@echo "make demo    headless sim demo (runs setup first)"
	@echo "make train   train the lite model through the four stages and export it (hours; resumable)"
	@echo "make lint    ruff"
	@echo "make urdf    regenerate catkin_ws/src/pg_description/urdf/pushgrasp.urdf from the geometry config"

setup: $(STAMP)/apt $(STAMP)/venv $(STAMP)/build

$(STAMP)/apt: scripts/apt-packages.txt scripts/setup_apt.sh
	@scripts/setup_apt.sh
	@mkdir -p $(STAMP) && touch $@

$(STAMP)/venv: $(STAMP)/apt requirements.txt pyproject.toml
	@test -x $(PY) || /usr/bin/python3 -m venv --system-site-packages $(VENV)
	@echo "[setup] python requirements into $(VENV)"
	@$(PY) -m pip install -q --disable-pip-version-check -r requirements.txt 2>&1 | grep -v "is ignored: it is neither" || true
	@$(PY) -m pip install -q --disable-pip-version-check --no-deps --no-build-isolation -e . 2>&1 | grep -v "is ignored: it is neither" || true
	@$(PY) -c "import torch, pybullet, pg_policy, pg_sim, pg_learning" 2>/dev/null
	@touch $@

$(STAMP)/build: $(STAMP)/venv $(CATKIN_INPUTS)
	@scripts/catkin_build.sh
	@touch $@

build: $(STAMP)/venv
	@scripts/catkin_build.sh
	@touch $(STAMP)/build

lint: $(STAMP)/venv
	$(PY) -m ruff check .

urdf: $(STAMP)/venv
	$(PY) -m pg_sim.robot.urdf_builder --out catkin_ws/src/pg_description/urdf/pushgrasp.urdf

test: setup
	@scripts/run_tests.sh

demo: setup
	@scripts/demo.sh

train: setup
	@scripts/train_recipe.sh

clean:
	rm -rf catkin_ws/build catkin_ws/devel $(STAMP)
