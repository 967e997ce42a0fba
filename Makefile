# Two entry points for a fresh clone: `make demo` and `make test`. Both create .venv and
# install what they need; the CPU build of torch is pinned first so nothing pulls CUDA.
VENV    ?= .venv
PYTHON  ?= python3
BIN     := $(VENV)/bin
OUT     ?= demo_out
export MUJOCO_GL ?= egl

.PHONY: setup demo test lint bench clean

setup: $(VENV)/.installed

$(VENV)/.installed: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet torch==2.13.0
	$(BIN)/python -m pip install --quiet -e ".[dev]"
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
