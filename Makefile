# Two entry points, both self-contained on a fresh machine with Python 3.11:
#   make serve   install nFEX and run the service on the embedded store (seeded from ontology/ and rules/)
#   make test    install nFEX with its test extras (and, as root, Virtuoso) and run the whole suite
#   make docs    HTML documentation of the ontology (pyLODE) in out/docs/ontology/
PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
HOST   ?= 127.0.0.1
PORT   ?= 8000

.PHONY: install install-dev sparql-servers serve test docs bench lint typecheck clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

install: $(BIN)/python
	$(BIN)/pip install --quiet -e .

install-dev: $(BIN)/python
	$(BIN)/pip install --quiet -e '.[dev]'

serve: install
	$(BIN)/nfex serve --host $(HOST) --port $(PORT)

# The remote-store tests run on `oxigraph serve` (pip, dev extra) and on Virtuoso: Debian's binary package alone
# (no daemon started, no debconf); where it cannot be installed those tests skip and say why.
sparql-servers:
	@command -v virtuoso-t >/dev/null || { [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null \
	  && apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
	     virtuoso-opensource-7-bin >/dev/null; } \
	  || echo "virtuoso-t not installed: the Virtuoso store tests will skip (apt-get install virtuoso-opensource-7-bin)"

test: install-dev sparql-servers
	$(BIN)/python -m pytest -n 2 $(PYTEST_ARGS)

docs: $(BIN)/python
	$(BIN)/pip install --quiet -e '.[docs]'
	$(BIN)/python -m nfex_core.kg.docs out/docs/ontology

bench: install-dev
	for f in bench/bench_*.py; do echo "== $$f"; $(BIN)/python $$f || exit 1; done

lint: install-dev
	$(BIN)/ruff check nfex_core service clients tests bench
	$(BIN)/mypy

clean:
	rm -rf $(VENV) build *.egg-info
