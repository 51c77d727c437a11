# rockdove: two commands do all the set-up on a fresh Debian machine with Python 3.11.
#   make asset   create .venv, install everything, build (and verify) the default asset into build/
#   make test    create .venv if needed, run the whole test suite
PYTHON ?= $(shell command -v python3.11 || command -v python3)
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
OUT    ?= build/pigeon

export PYOPENGL_PLATFORM ?= egl

.PHONY: asset test bench venv clean smoke-installed

venv: $(STAMP)

$(STAMP): pyproject.toml
	@test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test]'
	@touch $(STAMP)

asset: $(STAMP)
	$(BIN)/rockdove build --out $(OUT)
	@echo "asset written to $(OUT)/pigeon.usda"

test: $(STAMP)
	$(BIN)/python -m pytest -q

# CI: build the sdist and the wheel, pip install the wheel into a fresh venv, build/validate/verify a small asset
# from outside the checkout (.ci/smoke-installed).
smoke-installed: $(STAMP)
	.ci/smoke-installed $(PYTHON)

bench: $(STAMP)
	$(BIN)/rockdove bench

clean:
	rm -rf build verify .pytest_cache
