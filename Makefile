# hydro-envs developer entry points. Every target creates .venv on first use.
#   make demo      - the main job (see README)
#   make test      - default test suite (excludes tests marked slow)
#   make test-all  - everything, including slow tests
#   make bench     - performance and accuracy benchmarks (print numbers)
#   make lint      - ruff check and mypy (make test runs them too, tests/test_lint.py)
#   make demo-diagnose - the diagnosis workflow finding hidden effects
PYTHON ?= python3
VENV ?= .venv
PY := $(VENV)/bin/python
# CPU-only torch first: an unpinned torch pulls several GB of CUDA packages.
TORCH_SPEC ?= torch==2.13.0
STAMP := $(VENV)/.installed

.PHONY: install demo demo-diagnose test test-all bench lint clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet $(TORCH_SPEC)
	$(PY) -m pip install --quiet -e ".[all]"
	$(VENV)/bin/hydro compile
	touch $(STAMP)

install: $(STAMP)

demo: $(STAMP)
	$(VENV)/bin/hydro demo --force

# hide Stribeck friction (servo) and the modified-IFAS dip (shaking table), find them
demo-diagnose: $(STAMP)
	$(PY) -m identification.diagnosis.demo --out runs/diagnosis-demo

test: $(STAMP)
	$(PY) -m pytest -q

test-all: $(STAMP)
	$(PY) -m pip install --quiet -e ".[all,zoo]"
	$(PY) -m pytest -q -m "slow or not slow"

bench: $(STAMP)
	$(PY) bench/step_rate.py

lint: $(STAMP)
	$(PY) -m ruff check .
	$(PY) -m mypy

clean:
	rm -rf $(VENV) build *.egg-info .pytest_cache .mypy_cache .ruff_cache
	find . -name __pycache__ -type d -prune -exec rm -rf {} +
