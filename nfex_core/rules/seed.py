"""Imports the modules that register seed sources for rules (nfex_core.kg.seed loads this module).

- ``nfex_core.rules.pruning``: rules/pruning/*.rq and their thresholds;
- ``nfex_core.rules.dsl.seed``: rules/programs/*.nfex compiled to statements.
"""
from __future__ import annotations

import importlib

from . import pruning  # noqa: F401

try:
    importlib.import_module("nfex_core.rules.dsl.seed")
except ModuleNotFoundError as e:  # the DSL package is optional until it exists
    if e.name not in ("nfex_core.rules.dsl", "nfex_core.rules.dsl.seed"):
        raise
