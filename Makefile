# Two entry points for a fresh clone: `make demo` and `make test`. Both create .venv and
# install what they need; the CPU build of torch is pinned first so nothing pulls CUDA.
VENV    ?= .venv
# The Python that builds .venv: this one when it is 3.10-3.12, else python3.12, python3.11 or
# python3.10 from PATH, else one line that says what to install (tools/pick_python.sh).
PYTHON  ?= python3
BIN     := $(VENV)/bin
# The pose model's package, installed without its declared dependencies (pyproject's
# `pose` extra lists the ones it needs; docs/decisions/pose-model.md says why).
MEDIAPIPE := mediapipe==0.10.14
# Where torch comes from, besides pip's own indexes: PyTorch's CPU-only index when it answers
# (tools/torch_index.py; PyPI's Linux build is CUDA's, several GB). `make TORCH_FROM=` skips it.
TORCH_FROM ?= $$($(BIN)/python tools/torch_index.py)
OUT     ?= demo_out
export MUJOCO_GL ?= egl

WHEEL   := build/wheel-check

.PHONY: setup demo test wheel-check lint bench clean python

setup: $(VENV)/.installed

# Which Python `make setup` would build .venv with (it installs nothing).
python:
	@$(SHELL) tools/pick_python.sh '$(PYTHON)'

$(VENV)/.installed: pyproject.toml Makefile
	python=$$($(SHELL) tools/pick_python.sh '$(PYTHON)') && "$$python" -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet torch==2.13.0 $(TORCH_FROM)
	$(BIN)/python -m pip install --quiet -e ".[dev,pose,ray,ik]"
	$(BIN)/python -m pip install --quiet --no-deps $(MEDIAPIPE)
	touch $@

demo: setup
	$(BIN)/imimic demo --out $(OUT)

test: setup
	$(BIN)/ruff check .
	$(BIN)/mypy imimic_gym
	$(BIN)/python -m pytest -q
	$(MAKE) wheel-check

# The wheel as a user installs it (not editable, in a venv of its own, run from another
# folder): its shipped weights must come with it.
wheel-check: setup
	rm -rf $(WHEEL) && mkdir -p $(WHEEL)
	$(BIN)/python -m pip wheel --quiet --no-deps -w $(WHEEL) .
	$(BIN)/python -m venv $(WHEEL)/venv
	$(WHEEL)/venv/bin/python -m pip install --quiet torch==2.13.0 $(TORCH_FROM)
	$(WHEEL)/venv/bin/python -m pip install --quiet $(WHEEL)/imimic_gym-*.whl
	cd $(WHEEL) && venv/bin/imimic demo --estimator cnn --scenario default --frames 30 \
		--out demo > demo.log && venv/bin/imimic eval --controller learned --episodes 1 \
		--frames 30 --out eval > eval.log
	@echo "wheel-check: the installed wheel ran demo --estimator cnn and eval --controller learned"

# The benchmarks also need the `mutation` extra (mutmut, for the mutation suite).
bench: setup $(VENV)/.mutation
	bash benchmarks/run_all.sh

$(VENV)/.mutation: $(VENV)/.installed
	$(BIN)/python -m pip install --quiet -e ".[mutation]"
	touch $@

clean:
	rm -rf $(VENV) $(OUT) .pytest_cache .ruff_cache
