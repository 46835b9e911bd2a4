"""The repository's knowledge files as graphs: ``ontology/`` (with its generated measurements) and
``rules/shapes/``, and the vocabulary of the ontology alone (to check programs before they are seeded).

What a new store is seeded from — these and the rules' own sources — is listed in ``nfex_core.knowledge``.
"""
from __future__ import annotations

from pathlib import Path

import rdflib

from ..config import Settings
from .backends import EmbeddedBackend
from .changes import graph_triples, read_rdf_file
from .store import KnowledgeGraph
from .terms import triple_n3
from .vocab import Vocabulary


def turtle_files(folder: Path) -> rdflib.Graph:
    """Every ``*.ttl`` below ``folder`` as one graph."""
    g = rdflib.Graph()
    for path in sorted(folder.rglob("*.ttl")):
        g += read_rdf_file(path)
    return g


def ontology_graph(settings: Settings) -> rdflib.Graph:
    """ontology/*.ttl and the generated measurements under ontology/measurements/."""
    return turtle_files(settings.ontology_dir)


def shapes_graph(settings: Settings) -> rdflib.Graph:
    """rules/shapes/*.ttl: integrity, DSL and context shapes."""
    return turtle_files(settings.rules_dir / "shapes")


def ontology_vocabulary(settings: Settings) -> Vocabulary:
    """The Vocabulary of the repository's ontology files, read into an in-memory store."""
    kg = KnowledgeGraph(EmbeddedBackend(None), settings)
    triples = list(graph_triples(ontology_graph(settings)))
    for i in range(0, len(triples), 2000):
        kg.backend.update("INSERT DATA {\n" + "\n".join(triple_n3(t) for t in triples[i : i + 2000]) + "\n}")
    return Vocabulary.load(kg)
