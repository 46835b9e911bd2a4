# Two entry points, both self-contained on a fresh machine with Python 3.11:
#   make serve   install nFEX and run the service on the embedded store (seeded from ontology/ and rules/)
#   make test    install nFEX with its test extras and run the whole suite
PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
HOST   ?= 127.0.0.1
PORT   ?= 8000

.PHONY: install install-dev serve test browser ui-screenshots bench lint typecheck clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

install: $(BIN)/python
	$(BIN)/pip install --quiet -e .

install-dev: $(BIN)/python
	$(BIN)/pip install --quiet -e '.[dev]'

serve: install
	$(BIN)/nfex serve --host $(HOST) --port $(PORT)

test: install-dev browser
	$(BIN)/python -m pytest -n 2 $(PYTEST_ARGS)

# Debian's chromium for the workbench's browser tests (tests/service/test_ui.py, driven by Playwright without a
# browser download). Installed only where it is missing and apt-get can run as root; elsewhere those tests skip.
browser:
	@if ! command -v chromium >/dev/null 2>&1 && [ ! -x /usr/bin/chromium ]; then \
	  if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then \
	    echo "installing chromium for the browser tests"; \
	    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends chromium >/dev/null; \
	  else echo "chromium is missing and cannot be installed here (needs root and apt-get): the browser tests will skip"; fi; \
	fi

# The screenshots in docs/ui.md, taken by the browser tests
ui-screenshots: install-dev browser
	NFEX_UI_SCREENSHOTS=1 $(BIN)/python -m pytest -p no:xdist tests/service/test_ui.py

bench: install-dev
	for f in bench/bench_*.py; do echo "== $$f"; $(BIN)/python $$f || exit 1; done

lint: install-dev
	$(BIN)/ruff check nfex_core service clients tests bench
	$(BIN)/mypy

clean:
	rm -rf $(VENV) build *.egg-info
