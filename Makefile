# usvid: two commands on a fresh machine with Python 3.11+ and make:
#   make demo   - set up .venv, install, run the main job on the bundled example data
#   make test   - set up .venv with the test and log-format extras, run the whole test suite
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
TSTAMP := $(VENV)/.installed-test

.PHONY: demo test fuzz bench lint clean browser

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

$(STAMP): pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e .
	touch $@

$(TSTAMP): pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e ".[test,all]"
	touch $(STAMP) $@

demo: $(STAMP)
	$(BIN)/usvid demo --out demo-out

# the suite runs on every core (pytest-xdist; one test file per worker keeps module fixtures whole).
# It writes Python's bytecode caches even where PYTHONDONTWRITEBYTECODE is set (an empty value
# unsets it): without them every worker rewrites and compiles each test module's assertions again
# (~8 s CPU per worker) and every command the tests start compiles usvid again.
test: $(TSTAMP) browser
	PYTHONDONTWRITEBYTECODE= $(BIN)/python -m pytest -n auto --dist loadfile

# the loaders' fuzzing alone: 10,000 seeded examples per loader and per message-log format
# (make test runs the first 2,000 of each; see tests/fuzzing.py and tests/test_fuzz_messages.py)
fuzz: $(TSTAMP)
	PYTHONDONTWRITEBYTECODE= USVID_FUZZ_EXAMPLES=10000 $(BIN)/python -m pytest -n auto -m fuzz

# Headless Chromium (Debian's package) for the report's browser test; best effort: where it cannot
# be installed (not root, no apt) the browser test is skipped with the reason.
browser:
	@command -v chromium >/dev/null 2>&1 || { \
	  if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then \
	    echo "installing Debian's chromium for the report browser test..."; \
	    (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium \
	      >/dev/null) || echo "chromium could not be installed: browser test will be skipped"; \
	  else echo "chromium absent and not installable here: browser test will be skipped"; fi; }

bench: $(STAMP)
	$(BIN)/python benchmarks/run_all.py

lint: $(TSTAMP)
	$(BIN)/ruff check src tests benchmarks examples

clean:
	rm -rf $(VENV) demo-out .pytest_cache
