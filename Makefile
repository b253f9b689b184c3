# manylights: `make demo` renders the bundled scene, `make test` runs every test. Both set up a bare
# Debian 12 machine first (system packages, .venv with pinned Python deps, a maturin release build).
SHELL := /bin/bash
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
export XDG_RUNTIME_DIR ?= /tmp/manylights-runtime
export HOME ?= /root

.PHONY: all setup system venv build demo test test-rust test-python bench clean

all: build

system:
	@mkdir -p $(XDG_RUNTIME_DIR)
	@bash scripts/setup_system.sh

$(VENV)/.deps: requirements-dev.txt
	@test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -r requirements-dev.txt
	@touch $@

venv: $(VENV)/.deps

setup: system venv

# One release build serves the extension, cargo test and the benchmarks (wgpu is compiled once).
build: setup
	$(VENV)/bin/maturin develop --release -q
	@$(PY) -c "import manylights; print('manylights', manylights.__version__, 'built')"

demo: build
	$(PY) -m manylights demo

test-rust: setup
	cargo test --release

test-python: build
	$(PY) -m pytest -q tests

test: build test-rust test-python

bench: build
	$(PY) -m manylights.bench --help

clean:
	rm -rf target $(VENV)
