# agvnav: everything a new machine needs, from plain Python.
#   make run   - create .venv on first use, install agvnav, run the main job; run again, it replaces sim_out
#                (--force: sim_out holding the previous run is replaced whole; a sim_out of other files is
#                never touched, agvnav refuses it)
#   make test  - create .venv on first use, install agvnav with test tools, lint (ruff), type-check (mypy),
#                run the test suite
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: run test test-all browser broker bench clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test]'
	touch $(STAMP)

run: $(STAMP)
	$(BIN)/agvnav simulate --force

# The HTML report's test drives a real headless Chromium. Where it is missing and Debian's
# package manager can be used (root), install it; otherwise that one test skips and says why.
browser:
	@command -v chromium >/dev/null 2>&1 || { [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1 \
	  && (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null) \
	  || echo "chromium not installed: the browser test of the HTML report will be skipped"; }

# The VDA 5050 tests start Debian's mosquitto on a free local port themselves. Where it is missing and
# apt-get can be used (root), install it; the broker tests FAIL without it (they never skip, so a CI
# machine that lacks it shows red instead of silently testing less).
broker:
	@command -v mosquitto >/dev/null 2>&1 || [ -x /usr/sbin/mosquitto ] || { [ "$$(id -u)" = 0 ] \
	  && command -v apt-get >/dev/null 2>&1 \
	  && (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq mosquitto >/dev/null) \
	  || echo "mosquitto not installed: the VDA 5050 broker tests will fail (apt-get install mosquitto)"; }

test: $(STAMP) browser broker
	$(BIN)/ruff check src tests
	$(BIN)/mypy
	$(BIN)/python -m pytest -n 2 -q

test-all: $(STAMP) browser broker
	$(BIN)/python -m pytest -n 2 -q -m ''

clean:
	rm -rf $(VENV) build src/*.egg-info .pytest_cache .hypothesis
