"""nFEX core library: the knowledge graph, the rule engine, vision, neural models and evaluation.

The service (``service/``) and the CLI (``cli/``) are thin layers beside this package, which imports neither
of them. Library modules never import FastAPI, typer, matplotlib or torch at module level (tests/test_imports.py;
pyproject.toml's import contracts).
"""
from __future__ import annotations

__version__ = "0.1.0"
