"""Seed source ``programs``: rules/programs/*.nfex, checked and compiled into the first graph version.

Names are checked against the vocabulary of the ontology being seeded (read from ``ontology/`` into
an in-memory store), so a program with a typo stops ``nfex seed`` with its line and column.
"""
from __future__ import annotations

import rdflib

from ...config import Settings
from ...kg.backends import EmbeddedBackend
from ...kg.changes import graph_triples
from ...kg.seed import ontology, seed_source
from ...kg.terms import triple_n3
from ...kg.vocab import Vocabulary
from .programs import load


def ontology_vocabulary(settings: Settings) -> Vocabulary:
    """The Vocabulary of the repository's ontology files, without a store."""
    from ...kg.store import KnowledgeGraph

    kg = KnowledgeGraph(EmbeddedBackend(None), settings)
    triples = list(graph_triples(ontology(settings)))
    for i in range(0, len(triples), 2000):
        kg.backend.update("INSERT DATA {\n" + "\n".join(triple_n3(t) for t in triples[i : i + 2000]) + "\n}")
    return Vocabulary.load(kg)


@seed_source("programs")
def seed_programs(settings: Settings) -> rdflib.Graph:
    g = rdflib.Graph()
    paths = sorted((settings.rules_dir / "programs").glob("*.nfex"))
    if not paths:
        return g
    vocab = ontology_vocabulary(settings)
    for path in paths:
        g += load(path, vocab, settings)[1]
    return g
