# Two commands on a fresh Debian/Python machine (see README):
#   make demo    set up .venv and run the built-in simulated vessel end to end
#   make test    set up .venv and run the whole test suite
PYTHON ?= python3
VENV   ?= .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed

.PHONY: demo test bench setup clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -e '.[test,plot,fast]'
	touch $(STAMP)

setup: $(STAMP)

demo: $(STAMP)
	$(VENV)/bin/edged demo $(ARGS)

# -n auto: one worker per core (pytest-xdist); --dist loadfile keeps a module's
# tests, and the simulations its fixtures make once, on one worker.
test: $(STAMP)
	$(PY) -m pytest -n auto --dist loadfile -rs $(ARGS)

bench: $(STAMP)
	@for b in tests/bench/bench_*.py; do echo "== $$b"; $(PY) $$b || exit 1; done

clean:
	rm -rf $(VENV) build *.egg-info
