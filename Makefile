# Two entry points for a fresh clone: `make demo` and `make test`. Both create .venv and
# install what they need; the CPU build of torch is pinned first so nothing pulls CUDA.
VENV    ?= .venv
PYTHON  ?= python3
BIN     := $(VENV)/bin
# The pose model's package, installed without its declared dependencies (pyproject's
# `pose` extra lists the ones it needs; docs/decisions/pose-model.md says why).
MEDIAPIPE := mediapipe==0.10.14
OUT     ?= demo_out
export MUJOCO_GL ?= egl

.PHONY: setup demo test lint bench clean

setup: $(VENV)/.installed

$(VENV)/.installed: pyproject.toml Makefile
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet torch==2.13.0
	$(BIN)/python -m pip install --quiet -e ".[dev,pose]"
	$(BIN)/python -m pip install --quiet --no-deps $(MEDIAPIPE)
	touch $@

demo: setup
	$(BIN)/imimic demo --out $(OUT)

test: setup
	$(BIN)/ruff check .
	$(BIN)/python -m pytest -q

bench: setup
	bash benchmarks/run_all.sh

clean:
	rm -rf $(VENV) $(OUT) .pytest_cache .ruff_cache
