"""Seeding a new store from the repository: ``ontology/`` and ``rules/``.

The seed is the union of every registered source, committed as version 1 by ``nfex seed`` (or on
first open of an empty store). Sources are functions from the settings to an rdflib graph, so other
subsystems register theirs (SPARQL pruning rules, DSL programs) without this module knowing them.
"""
from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

import rdflib

from ..config import Settings
from ..errors import DataMissing
from .changes import ChangeSet, graph_triples, read_rdf_file

if TYPE_CHECKING:
    from .store import CommitResult, KnowledgeGraph

SEED_AUTHOR = "nfex seed"
SeedSource = Callable[[Settings], rdflib.Graph]
SEED_SOURCES: dict[str, SeedSource] = {}


def seed_source(name: str) -> Callable[[SeedSource], SeedSource]:
    def register(fn: SeedSource) -> SeedSource:
        SEED_SOURCES[name] = fn
        return fn

    return register


def _turtle_files(folder: Path) -> rdflib.Graph:
    g = rdflib.Graph()
    for path in sorted(folder.rglob("*.ttl")):
        g += read_rdf_file(path)
    return g


@seed_source("ontology")
def ontology(settings: Settings) -> rdflib.Graph:
    """ontology/*.ttl and the generated measurements under ontology/measurements/."""
    if not any(settings.ontology_dir.glob("*.ttl")):
        # a store seeded from nothing answers "unknown condition dimension … known: (none)" forever after
        raise DataMissing(
            f"no ontology to seed from: {settings.ontology_dir} holds no *.ttl; set NFEX_HOME to a folder "
            "holding ontology/ and rules/ (an installed nFEX ships its own)"
        )
    return _turtle_files(settings.ontology_dir)


@seed_source("shapes")
def shapes(settings: Settings) -> rdflib.Graph:
    return _turtle_files(settings.rules_dir / "shapes")


def _load_plugins() -> None:
    """Import the modules that register further seed sources (rules, programs)."""
    import importlib

    for module in ("nfex_core.rules.seed",):
        try:
            importlib.import_module(module)
        except ModuleNotFoundError as e:
            if e.name is None or not module.startswith(e.name):
                raise


def seed_graph(settings: Settings | None = None) -> rdflib.Graph:
    settings = settings or Settings.from_env()
    _load_plugins()
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
