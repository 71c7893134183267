# Two commands do all the set-up themselves, idempotently: `make test` and `make demo`.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed-stamp

.PHONY: setup vulkan test demo lint bench clean

setup: vulkan $(STAMP)

vulkan:
	@bash tools/ensure_vulkan.sh

# Reinstalled only when the package metadata changes; the install is editable, so source and
# shader edits need no reinstall.
$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -e '.[test]'
	touch $(STAMP)

test: setup
	$(PY) -m pytest -q

demo: setup
	$(PY) demo.py

lint: setup
	$(VENV)/bin/ruff check wgbragg tests tools demo.py

# The peers' column (tmm_fast on a pinned CPU torch) is optional: without it the table says
# "not installed" and every other column is still measured.
bench: setup
	$(PY) -m pip install -q -e '.[test,bench]' || echo "wgbragg: tmm_fast not installed, continuing"
	$(PY) tools/bench_reflectance.py
	$(PY) tools/bench_rgb.py
	$(PY) tools/bench_rough.py
	$(PY) tools/bench_layered.py
	$(PY) tools/bench_render.py

clean:
	rm -rf $(VENV) out build dist .pytest_cache .ruff_cache .hypothesis
