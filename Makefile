# Two commands do all the set-up themselves, idempotently: `make test` and `make demo`.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed-stamp

.PHONY: setup vulkan xvfb test demo lint bench clean

setup: vulkan $(STAMP)

vulkan:
	@bash tools/ensure_vulkan.sh

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
	$(PY) -m benchmarks.viewer

clean:
	rm -rf $(VENV) out build dist .pytest_cache .ruff_cache .hypothesis
