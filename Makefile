# Two commands on a fresh Debian/Python machine (see README):
#   make demo    set up .venv and run the built-in simulated vessel end to end
#   make test    set up .venv and run the whole test suite
PYTHON ?= python3
VENV   ?= .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed

.PHONY: demo test bench setup clean signalk-server

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -e '.[test,plot,fast]'
	touch $(STAMP)

setup: $(STAMP)

# signalk-server, which tests/signalk starts to read the Signal K output, from npm
# into $(VENV)/signalk (about 270 MB, half a minute). Pinned: 2.23.0 is the newest
# that runs on Node 20. Without npm (or when the install fails) its test is skipped.
SIGNALK_VERSION := 2.23.0
SIGNALK_STAMP   := $(VENV)/signalk/.installed-$(SIGNALK_VERSION)

signalk-server: $(SIGNALK_STAMP)

$(SIGNALK_STAMP):
	@if command -v npm >/dev/null 2>&1; then \
	  echo "installing signalk-server $(SIGNALK_VERSION) with npm into $(VENV)/signalk"; \
	  npm install --prefix $(VENV)/signalk --no-audit --no-fund --ignore-scripts --omit=dev --loglevel=error \
	    signalk-server@$(SIGNALK_VERSION) && touch $@ \
	    || echo "note: npm could not install signalk-server: the Signal K server test will be skipped"; \
	else \
	  echo "note: npm not found: the Signal K server test (tests/signalk) will be skipped"; \
	fi

demo: $(STAMP)
	$(VENV)/bin/edged demo $(ARGS)

# -n auto: one worker per core (pytest-xdist); --dist loadfile keeps a module's
# tests, and the simulations its fixtures make once, on one worker.
test: $(STAMP) signalk-server
	$(PY) -m pytest -n auto --dist loadfile -rs $(ARGS)

bench: $(STAMP)
	@for b in tests/bench/bench_*.py; do echo "== $$b"; $(PY) $$b || exit 1; done

clean:
	rm -rf $(VENV) build *.egg-info
