# rockdove: two commands do all the set-up on a fresh Debian machine with Python 3.11.
#   make asset   create .venv, install everything, build (and verify) the default asset into build/
#   make test    create .venv if needed, run the whole test suite
PYTHON ?= $(shell command -v python3.11 || command -v python3)
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
OUT    ?= build/pigeon

export PYOPENGL_PLATFORM ?= egl
# Shared libraries that bpy (Blender as a Python module, in the test extra) links and a minimal Debian lacks.
BPY_DEBS := libx11-6 libxrender1 libxfixes3 libxi6 libxkbcommon0 libxext6 libsm6 libice6 libgl1

.PHONY: asset test bench venv clean

venv: $(STAMP)

$(STAMP): pyproject.toml
	@test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	@dpkg -s $(BPY_DEBS) >/dev/null 2>&1 || ! command -v apt-get >/dev/null || \
		(apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends $(BPY_DEBS))
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test]'
	@touch $(STAMP)

asset: $(STAMP)
	$(BIN)/rockdove build --out $(OUT)
	@echo "asset written to $(OUT)/pigeon.usda"

test: $(STAMP)
	$(BIN)/python -m pytest -q

bench: $(STAMP)
	$(BIN)/rockdove bench

clean:
	rm -rf build verify .pytest_cache
