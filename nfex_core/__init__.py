"""nFEX core library: the knowledge graph, the rule engine, vision, neural models and evaluation.

The service (``service/``) and the CLI (``nfex_core.cli``) are thin layers over this package. Library
modules never import FastAPI, typer, matplotlib or torch at module level (see tests/test_imports.py).
"""
from __future__ import annotations

__version__ = "0.1.0"
