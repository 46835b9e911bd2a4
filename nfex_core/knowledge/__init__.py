"""The knowledge nFEX ships, and how a store receives it.

A new store is seeded from the repository's files: the union of the sources listed below, committed as
one version (``nfex kg seed``, or on the first open of an empty store). The list is explicit, after
rdflib's ``plugin.py``: a subsystem with knowledge to ship adds its source function here.

An empty store receives the seed in bulk (``KnowledgeGraph.load_validated``): the shipped content is
validated whole with pySHACL in CI (``tests/nfex_core/kg/test_shipped_seed.py``), not at every first start,
and the seed itself is computed once per content (``seed_content``: a cache named by a digest of the files
and the code). A store that already holds knowledge receives the difference through the validated commit.

| source          | files                                   | function                          |
|-----------------|-----------------------------------------|-----------------------------------|
| ontology        | ontology/**/*.ttl (with measurements/)  | ``kg.shipped.ontology_graph``     |
| shapes          | rules/shapes/*.ttl                      | ``kg.shipped.shapes_graph``       |
| pruning-rules   | rules/pruning/*.rq and *.ttl            | ``rules.pruning.rules_graph``     |
| programs        | rules/programs/*.nfex                   | ``rules.dsl.programs.programs_graph`` |
"""
from __future__ import annotations

from collections.abc import Callable, Iterable

from ..config import Settings
from ..errors import Conflict, PreconditionFailed
from ..kg.changes import ChangeSet
from ..kg.shipped import ontology_graph, shapes_graph
from ..kg.store import CommitResult, KnowledgeGraph
from ..kg.terms import Triple
from ..rules.dsl.programs import programs_graph
from ..rules.pruning import rules_graph
from .seed_content import seed_content

SEED_AUTHOR = "nfex seed"
SEED_MESSAGE = "seed from ontology/ and rules/"
SeedSource = Callable[[Settings], Iterable[Triple]]  # a graph: an rdflib Graph or its triples
SEED_SOURCES: dict[str, SeedSource] = {
    "ontology": ontology_graph,
    "shapes": shapes_graph,
    "pruning-rules": rules_graph,
    "programs": programs_graph,
}


def seed_graph(settings: Settings) -> set[Triple]:
    """The union of every seed source for ``settings.home`` (blank nodes as parsed: each source's own)."""
    triples: set[Triple] = set()
    for source in SEED_SOURCES.values():
        triples.update(source(settings))
    return triples


def seed_triples(settings: Settings) -> frozenset[Triple]:
    """The seed's triples, skolemised and normalised as the store holds them (from the cache when it has them)."""
    return seed_content(settings, seed_graph).triples()


def seed(kg: KnowledgeGraph, *, author: str = SEED_AUTHOR) -> CommitResult:
    """Bring the graph in line with the repository's ontology/ and rules/ as one version.

    On an empty store this writes the whole seed, in bulk and without validating it again (module
    docstring). Later, it commits the difference between the files now and what earlier seeds wrote (so a
    triple deleted from a file is removed from the graph), leaving everything else — measurements, programs
    and edits made through the API — untouched; that commit is validated like any other.
    """
    content = seed_content(kg.settings, seed_graph)
    if kg.version == 0 and not kg.backend.ask("ASK { ?s ?p ?o }"):
        try:
            return kg.load_validated(content.text(), author=author, message=SEED_MESSAGE)
        except PreconditionFailed:  # written meanwhile: the difference, validated, as below
            pass
    current = content.triples()
    previous = ChangeSet()
    for v in sorted(kg.versions(), key=lambda v: v.number):
        if v.author == SEED_AUTHOR:
            previous = previous.then(kg.changes(v.number))
    stale = previous.added - current
    return kg.commit(ChangeSet.of(added=current, removed=stale), author=author, message=SEED_MESSAGE)


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
