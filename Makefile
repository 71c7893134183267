# Two commands do all the set-up themselves, idempotently: `make test` and `make demo`.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed-stamp

.PHONY: setup vulkan driver xvfb test test-old-driver fuzz demo lint bench bench-peer clean

setup: vulkan $(STAMP) driver

vulkan:
	@bash tools/ensure_vulkan.sh

# A current lavapipe (Mesa >= 24) where the system's is older: fetched from the distribution's
# backports suite into .cache/mesa, installing no system package (wgbragg.gpu.driver_fetch).
# Says in one line what it did; where none can be had, the system driver serves.
driver: $(STAMP)
	@$(VENV)/bin/wgbragg info --fetch-driver >/dev/null || true

# The demo window's tests open a real glfw window on a virtual X server.
xvfb:
	@WGBRAGG_NEED_XVFB=1 bash tools/ensure_vulkan.sh

# Reinstalled only when the package metadata changes; the install is editable, so source and
# shader edits need no reinstall.
$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -e '.[test]'
	touch $(STAMP)

test: setup xvfb
	$(PY) -m pytest -q

# The kernels' float32-against-float64 twin tests, the float32 domain and the GPU harness
# (loop budget included) on the system's own lavapipe, where `make test` ran on a fetched
# current one: the numerics must hold on both drivers.
test-old-driver: setup
	@icd="$$($(PY) -c 'from wgbragg.gpu.driver import system_lavapipe as s; f = s(); print(f[0] if f else "")')"; \
	if [ -z "$$icd" ]; then echo "wgbragg: no system lavapipe: nothing to test on it"; exit 0; fi; \
	echo "VK_DRIVER_FILES=$$icd"; \
	VK_DRIVER_FILES="$$icd" $(PY) -m pytest -q tests/test_float32_domain.py \
		tests/test_gpu_harness.py $$($(PY) tools/twin_tests.py)

# The float32 kernels against their float64 twins over the whole documented domain
# (tests/test_float32_domain.py): the suite runs its property tests with 300 examples each,
# this with FUZZ_EXAMPLES of them; FUZZ_SEED=n explores other cases than the fixed seed's.
FUZZ_EXAMPLES ?= 20000
fuzz: setup
	WGBRAGG_FUZZ_EXAMPLES=$(FUZZ_EXAMPLES) $(if $(FUZZ_SEED),WGBRAGG_FUZZ_SEED=$(FUZZ_SEED)) \
		$(PY) -m pytest -q tests/test_float32_domain.py -k over_the_domain

# The window where there is a display; otherwise the same window rendered offscreen as a PNG.
demo: setup
	@if [ -n "$$DISPLAY$$WAYLAND_DISPLAY" ]; then $(PY) demo.py; \
	else $(PY) demo.py --offscreen --spp 64 -o out/demo.png; fi

# ruff, then the architecture: layers import only downward (import-linter contracts in
# pyproject.toml); tests/test_architecture.py checks the rules import-linter cannot see.
lint: setup
	$(VENV)/bin/ruff check wgbragg tests benchmarks tools demo.py
	$(VENV)/bin/lint-imports --no-cache

# The peers' column (tmm_fast on a pinned CPU torch) is optional: without it the table says
# "not installed" and every other column is still measured.
bench: setup
	$(PY) -m pip install -q -e '.[test,bench]' || echo "wgbragg: tmm_fast not installed, continuing"
	$(PY) -m benchmarks.reflectance
	$(PY) -m benchmarks.rgb
	$(PY) -m benchmarks.film
	$(PY) -m benchmarks.rough
	$(PY) -m benchmarks.layered
	$(PY) -m benchmarks.render
	$(PY) -m benchmarks.ibl
	$(PY) -m benchmarks.rasterizer
	$(PY) -m benchmarks.viewer
	$(PY) -m benchmarks.cli
	$(PY) -m benchmarks.denoise
	$(PY) -m benchmarks.memory
	$(PY) -m benchmarks.sweep
	$(PY) -m benchmarks.design
	$(PY) -m benchmarks.design_baseline

# Mitsuba 3 as a peer (benchmarks/mitsuba_peer.py): scalar_rgb, and llvm_ad_rgb on a libLLVM
# that its drjit can use. The system's LLVM 15 (lavapipe's) makes drjit 1.5 abort, so Debian's
# libllvm19 is unpacked into .cache/llvm (apt-get download + dpkg -x: no system install) and
# DRJIT_LIBLLVM_PATH points at it; without it llvm_ad_rgb is tried on drjit's own search and,
# where that fails, its rows say why (scalar_rgb is measured either way).
LLVM_CACHE := .cache/llvm

bench-peer: setup
	$(PY) -m pip install -q -e '.[test,bench]' || $(PY) -m pip install -q 'mitsuba>=3.6' \
		|| echo "wgbragg: mitsuba not installed, continuing"
	@mkdir -p $(LLVM_CACHE)
	@if [ -z "$$(find $(LLVM_CACHE) -name 'libLLVM.so.19*' -print -quit)" ]; then \
		(cd $(LLVM_CACHE) && rm -f libllvm19_*.deb && apt-get download libllvm19 \
			&& dpkg -x libllvm19_*.deb .) \
		|| echo "wgbragg: libllvm19 not fetched: llvm_ad_rgb only if drjit finds a usable LLVM"; \
	fi
	@lib="$$(find $(CURDIR)/$(LLVM_CACHE) -name 'libLLVM.so.19*' -print -quit)"; \
	echo "DRJIT_LIBLLVM_PATH=$$lib $(PY) -m benchmarks.mitsuba_peer"; \
	DRJIT_LIBLLVM_PATH="$$lib" $(PY) -m benchmarks.mitsuba_peer

clean:
	rm -rf $(VENV) out build dist .pytest_cache .ruff_cache .hypothesis .cache/mesa
