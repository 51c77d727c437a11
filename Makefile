# rockdove: two commands do all the set-up on a fresh Debian machine with Python 3.11.
#   make asset   create .venv, install everything, build (and verify) the default asset into build/
#   make test    create .venv if needed, run the whole test suite
PYTHON ?= $(shell command -v python3.11 || command -v python3)
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
OUT    ?= build/pigeon

export PYOPENGL_PLATFORM ?= egl
# Blender as a Python module (bpy, cp311) for the blender host: it pins numpy < 2, which rockdove's own
# dependencies have outgrown, so it gets a venv of its own; the host finds it beside .venv (or through
# $ROCKDOVE_BPY_PYTHON). bpy 4.2 LTS and 4.4 (the first with the USD import's prim map) get venvs too: the add-on's
# tests run the README's Blender steps on each (tests/test_blender_addon.py). ~0.9-1 GB and 4-6 min each. They
# were built on numpy 1.x (as their Blender bundles: 4.3 and 4.4 print a numpy traceback on `import bpy` with numpy 2).
# BPY_DEBS: shared libraries bpy links and a minimal Debian lacks.
BPY_VENV  := .venv-bpy
BPY_STAMP := $(BPY_VENV)/.installed
BPY_PIN_4.2 := 4.2.23
BPY_PIN_4.4 := 4.4.0
BPY_OLD   := $(foreach v,4.2 4.4,$(BPY_VENV)-$(v)/.installed)
BPY_DEBS  := libx11-6 libxrender1 libxfixes3 libxi6 libxkbcommon0 libxext6 libsm6 libice6 libgl1

.PHONY: asset test bench venv web bpy clean smoke-installed

venv: $(STAMP)

# The web viewer copies three.js from npm beside verify/viewer.html; the tests validate pigeon.glb with the
# Khronos glTF-Validator (npm) and drive Debian's chromium. Each install runs only when missing (stamps).
WEB          := materials/web
NPM_STAMP    := $(WEB)/node_modules/.installed
BROWSER_STAMP := $(VENV)/.chromium

web: $(NPM_STAMP) $(BROWSER_STAMP)

$(NPM_STAMP): $(WEB)/package.json $(WEB)/package-lock.json
	@command -v npm >/dev/null || (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq nodejs npm)
	cd $(WEB) && npm ci --no-audit --no-fund --ignore-scripts --loglevel=error
	@touch $(NPM_STAMP)

$(BROWSER_STAMP): $(STAMP)
	@command -v chromium >/dev/null || (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium)
	@touch $(BROWSER_STAMP)

$(STAMP): pyproject.toml
	@test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test]'
	@# An editable install is not byte-compiled (a wheel's is, by pip); with PYTHONDONTWRITEBYTECODE set, every
	@# rockdove process would compile the package again (~0.2 s). Changed files are recompiled as usual.
	$(BIN)/python -m compileall -q pipeline/rockdove
	@touch $(STAMP)

$(BPY_STAMP):
	@dpkg -s $(BPY_DEBS) >/dev/null 2>&1 || ! command -v apt-get >/dev/null || \
		(apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends $(BPY_DEBS))
	@test -x $(BPY_VENV)/bin/python || $(PYTHON) -m venv $(BPY_VENV)
	$(BPY_VENV)/bin/python -m pip install --quiet 'bpy==5.0.1'
	@touch $(BPY_STAMP)

bpy: $(BPY_STAMP) $(BPY_OLD)

$(BPY_VENV)-%/.installed: $(BPY_STAMP)
	@test -x $(BPY_VENV)-$*/bin/python || $(PYTHON) -m venv $(BPY_VENV)-$*
	$(BPY_VENV)-$*/bin/python -m pip install --quiet 'bpy==$(BPY_PIN_$*)' 'numpy<2'
	@touch $@

asset: $(STAMP) $(NPM_STAMP)
	$(BIN)/rockdove build --out $(OUT)
	@echo "asset written to $(OUT)/pigeon.usda"

# Reference files the tests check against, from PyPI packages (tests/fetched.py): OpenUSD's ARKit compliance
# checkers of v23.11 and v24.08 (usd-core wheels) and the JUnit schema CI tools read (pytest's sdist).
FETCH_STAMP := $(VENV)/fetched/.installed

$(FETCH_STAMP): $(STAMP) tests/fetched.py
	$(BIN)/python tests/fetched.py $(FETCH_STAMP)

# The linter and the type checker first (settings in pyproject.toml; .pre-commit-config.yaml runs the same), then
# the suite, a worker per core (at most 4: each builds the session's small assets once), whole files per worker
# (their module fixtures are built once).
test: $(STAMP) $(NPM_STAMP) $(BROWSER_STAMP) $(BPY_STAMP) $(BPY_OLD) $(FETCH_STAMP)
	$(BIN)/ruff check .
	$(BIN)/mypy
	$(BIN)/python -m pytest -q --numprocesses auto --maxprocesses 4 --dist loadfile

# CI: build the sdist and the wheel, pip install the wheel into a fresh venv, build/validate/verify a small asset
# from outside the checkout (.ci/smoke-installed).
smoke-installed: $(STAMP)
	.ci/smoke-installed $(PYTHON)

bench: $(STAMP)
	$(BIN)/rockdove bench

clean:
	rm -rf build verify .pytest_cache
