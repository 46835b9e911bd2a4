"""The repository's knowledge files as graphs: ``ontology/`` (with its generated measurements) and
``rules/shapes/``, and the vocabulary of the ontology alone (to check programs before they are seeded).

What a new store is seeded from — these and the rules' own sources — is listed in ``nfex_core.knowledge``.
"""
from __future__ import annotations

from pathlib import Path

import pyoxigraph as ox

from ..config import Settings
from ..errors import DataMissing
from .rdf.terms import Triple
from .storage.backends import EmbeddedBackend
from .storage.changes import read_turtle, read_turtle_triples
from .store import KnowledgeGraph
from .vocabulary.vocab import Vocabulary


def turtle_triples(paths: list[Path]) -> list[Triple]:
    """The files' triples as one graph, blank nodes not yet skolemised (each file's its own: ``read_turtle``)."""
    return [t for path in paths for t in read_turtle_triples(path)]


def ontology_files(settings: Settings) -> list[Path]:
    """ontology/*.ttl and the generated measurements under ontology/measurements/."""
    if not any(settings.ontology_dir.glob("*.ttl")):
        # a store seeded from nothing answers "unknown condition dimension … known: (none)" forever after
        raise DataMissing(
            f"no ontology to seed from: {settings.ontology_dir} holds no *.ttl; set NFEX_HOME to a folder "
            "holding ontology/ and rules/ (an installed nFEX ships its own)"
        )
    return sorted(settings.ontology_dir.rglob("*.ttl"))


def ontology_graph(settings: Settings) -> list[Triple]:
    """The triples of ``ontology_files``."""
    return turtle_triples(ontology_files(settings))


def shapes_graph(settings: Settings) -> list[Triple]:
    """rules/shapes/*.ttl: integrity, DSL and context shapes."""
    return turtle_triples(sorted((settings.rules_dir / "shapes").rglob("*.ttl")))


def ontology_vocabulary(settings: Settings) -> Vocabulary:
    """The Vocabulary of the repository's ontology files, read into an in-memory store.

    The files go in as Oxigraph parses them, blank nodes unskolemised: the vocabulary reads named nodes
    only (``tests/nfex_core/kg/test_shipped.py`` compares it with the seeded store's)."""
    store = ox.Store()
    for path in ontology_files(settings):
        store.extend(read_turtle(path))
    kg = KnowledgeGraph(EmbeddedBackend.of_store(store), settings)
    return Vocabulary.load(kg)
