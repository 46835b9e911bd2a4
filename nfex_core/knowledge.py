"""The knowledge nFEX ships, and how a store receives it.

A new store is seeded from the repository's files: the union of the sources listed below, committed as
one version (``nfex kg seed``, or on the first open of an empty store). The list is explicit, after
rdflib's ``plugin.py``: a subsystem with knowledge to ship adds its source function here.

| source          | files                                   | function                          |
|-----------------|-----------------------------------------|-----------------------------------|
| ontology        | ontology/**/*.ttl (with measurements/)  | ``kg.shipped.ontology_graph``     |
| shapes          | rules/shapes/*.ttl                      | ``kg.shipped.shapes_graph``       |
| pruning-rules   | rules/pruning/*.rq and *.ttl            | ``rules.pruning.rules_graph``     |
| programs        | rules/programs/*.nfex                   | ``rules.dsl.programs.programs_graph`` |
"""
from __future__ import annotations

from collections.abc import Callable

import rdflib

from .config import Settings
from .errors import Conflict
from .kg.changes import ChangeSet, graph_triples
from .kg.shipped import ontology_graph, shapes_graph
from .kg.store import CommitResult, KnowledgeGraph
from .rules.dsl.programs import programs_graph
from .rules.pruning import rules_graph

SEED_AUTHOR = "nfex seed"
SeedSource = Callable[[Settings], rdflib.Graph]
SEED_SOURCES: dict[str, SeedSource] = {
    "ontology": ontology_graph,
    "shapes": shapes_graph,
    "pruning-rules": rules_graph,
    "programs": programs_graph,
}


def seed_graph(settings: Settings) -> rdflib.Graph:
    """The union of every seed source for ``settings.home``."""
    g = rdflib.Graph()
    for source in SEED_SOURCES.values():
        g += source(settings)
    return g


def seed(kg: KnowledgeGraph, *, author: str = SEED_AUTHOR) -> CommitResult:
    """Bring the graph in line with the repository's ontology/ and rules/ as one version.

    On an empty store this commits the whole seed. Later, it commits the difference between the
    files now and what earlier seeds wrote (so a triple deleted from a file is removed from the graph),
    leaving everything else — measurements, programs and edits made through the API — untouched.
    """
    current = graph_triples(seed_graph(kg.settings))
    previous = ChangeSet()
    for v in sorted(kg.versions(), key=lambda v: v.number):
        if v.author == SEED_AUTHOR:
            previous = previous.then(kg.changes(v.number))
    stale = previous.added - current
    return kg.commit(ChangeSet.of(added=current, removed=stale), author=author, message="seed from ontology/ and rules/")


def open_graph(location: str | None = None, *, settings: Settings | None = None, seed_empty: bool = True) -> KnowledgeGraph:
    """Open ``location`` (default: the settings' store) and, unless told not to, seed it if it is empty."""
    settings = settings or Settings.from_env()
    kg = KnowledgeGraph.open(location or settings.store, settings=settings)
    if seed_empty and kg.version == 0:
        try:
            seed(kg)
        except Conflict:  # another node seeded the shared store at the same moment
            if kg.version == 0:
                raise
    return kg
