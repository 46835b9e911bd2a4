"""Evidence scope: which measurements a reader of the graph may use.

In nFEX the measurements are rules in disguise: they prune extractors, choose Θ′, weigh the measured
accuracy A(α), fit the cost model and train the networks. An evaluation that lets the method under test
read the measurements of the very sequence it is evaluated on measures a leak, not a method. So every
reader takes an explicit ``EvidenceScope`` — measurements to leave out by sequence IRI
(``identity.sequence_iri``), by run (``prov:wasGeneratedBy``) and by source (``prov:wasAttributedTo``).

The scope is applied once, by construction: ``scoped_graph`` is a read-only, in-memory copy of the
knowledge without the excluded Measurements (and the nodes minted under them), so the SPARQL pruning
rules written by experts, the measured Θ′, the measured accuracy, the cost model and the dynamic
baselines all read the same admitted evidence without knowing that a scope exists. An empty scope is
the graph itself.
"""
from __future__ import annotations

import io
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any

import pyoxigraph as ox

from ..config import Settings
from ..errors import BadInput
from .backends import EmbeddedBackend
from .changes import ChangeSet
from .namespaces import NFEX
from .store import HEAD, META, CommitResult, KnowledgeGraph
from .terms import n3


@dataclass(frozen=True)
class EvidenceScope:
    exclude_sequences: frozenset[str] = frozenset()
    exclude_runs: frozenset[str] = frozenset()
    exclude_sources: frozenset[str] = frozenset()

    @classmethod
    def holding_out(cls, sequences: Iterable[str] = (), runs: Iterable[str] = (), sources: Iterable[str] = ()) -> EvidenceScope:
        return cls(frozenset(map(str, sequences)), frozenset(map(str, runs)), frozenset(map(str, sources)))

    @property
    def empty(self) -> bool:
        return not (self.exclude_sequences or self.exclude_runs or self.exclude_sources)

    def describe(self) -> str:
        parts = [f"{what} {', '.join(sorted(iris))}" for what, iris in (
            ("sequences", self.exclude_sequences), ("runs", self.exclude_runs), ("sources", self.exclude_sources)) if iris]
        return "all measurements" if not parts else "measurements except those of " + "; ".join(parts)

    def excluded_pattern(self, m: str = "?m") -> str:
        """A SPARQL group pattern that binds ``m`` to every excluded Measurement (a UNION per kind)."""
        branches = []
        for prop, iris in (("nfex:sequence", self.exclude_sequences), ("prov:wasGeneratedBy", self.exclude_runs),
                           ("prov:wasAttributedTo", self.exclude_sources)):
            if iris:
                values = " ".join(f"<{i}>" for i in sorted(iris))
                branches.append(f"{{ {m} a nfex:Measurement ; {prop} ?held . VALUES ?held {{ {values} }} }}")
        return " UNION ".join(branches) if branches else "{ FILTER (false) }"


def excluded_measurements(kg: KnowledgeGraph, scope: EvidenceScope) -> list[str]:
    """The Measurement IRIs ``scope`` leaves out of ``kg``."""
    if scope.empty:
        return []
    return sorted({str(r["m"]) for r in kg.select(f"SELECT DISTINCT ?m WHERE {{ {scope.excluded_pattern()} }}").rows})


def scoped_graph(kg: KnowledgeGraph, scope: EvidenceScope) -> KnowledgeGraph:
    """``kg`` itself for an empty scope, else a read-only in-memory copy of its knowledge (at the same
    version) without the Measurements ``scope`` excludes and the nodes minted under them (``<m>_…``)."""
    if scope.empty:
        return kg
    buffer = io.BytesIO()
    kg.backend.query_to("CONSTRUCT { ?s ?p ?o } WHERE { ?s ?p ?o }", "application/n-triples", buffer)
    store = ox.Store()
    store.bulk_load(buffer.getvalue(), format=ox.RdfFormat.N_TRIPLES)
    copy = ScopedGraph(EmbeddedBackend.of_store(store), kg.settings, scope, kg.version)
    for i in range(0, len(gone := excluded_measurements(kg, scope)), 200):
        values = " ".join(f"<{m}>" for m in gone[i:i + 200])
        store.update(f"""DELETE {{ ?x ?p ?o }} WHERE {{ VALUES ?m {{ {values} }}
            ?m ?q ?x . FILTER (isIRI(?x) && STRSTARTS(STR(?x), CONCAT(STR(?m), "_"))) ?x ?p ?o }} ;
            DELETE {{ ?m ?p ?o }} WHERE {{ VALUES ?m {{ {values} }} ?m ?p ?o }}""")
    return copy


class ScopedGraph(KnowledgeGraph):
    """A read-only copy of a graph under an evidence scope; its version is the source's."""

    def __init__(self, backend: EmbeddedBackend, settings: Settings, scope: EvidenceScope, version: int) -> None:
        backend.update(f"INSERT DATA {{ GRAPH {n3(META)} {{ {n3(HEAD)} {n3(NFEX.versionNumber)} {int(version)} }} }}")
        super().__init__(backend, settings)
        self.scope = scope

    def commit(self, change: ChangeSet | Callable[[], ChangeSet], **kwargs: Any) -> CommitResult:
        raise BadInput(f"this graph is a read-only view under an evidence scope ({self.scope.describe()})")
