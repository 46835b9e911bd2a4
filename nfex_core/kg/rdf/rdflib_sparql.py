"""rdflib's SPARQL parser, one caller at a time.

rdflib parses SPARQL with a pyparsing grammar that is shared and not thread-safe (RDFLib/rdflib#1282), and
nFEX parses from several threads: the commits' validation (pySHACL's SPARQL constraints), the footprints of
rules and shapes (kg/storage/footprint.py), the reach of an update (kg/storage/update_reach.py). Every parse holds this lock.
"""
from __future__ import annotations

import threading
from collections.abc import Mapping
from typing import Any

from rdflib.plugins.sparql import prepareQuery

RDFLIB_SPARQL_PARSER = threading.Lock()
"""Held while rdflib parses SPARQL."""


def prepare_query(query: str, init_ns: Mapping[str, Any] | None = None) -> Any:
    """rdflib's ``prepareQuery`` under ``RDFLIB_SPARQL_PARSER``."""
    with RDFLIB_SPARQL_PARSER:
        return prepareQuery(query, initNs=dict(init_ns or {}))
