"""The candidate state a write would leave, read from the store around nodes, without writing it.

``CandidateView`` answers outgoing and incoming triples of nodes, and the class hierarchy, in the state
store − removed + added; ``Neighbourhood`` keeps what the store holds around nodes at its head across commits
(the commit's validation reads the same configurations, parameters and condition values batch after batch).
validation.py builds a change's focus nodes and their neighbourhood from these reads.
"""
from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator

from rdflib.namespace import RDF, RDFS
from rdflib.term import Node, URIRef

from ..rdf.terms import Triple, n3
from ..storage.backends import Backend
from ..storage.changes import ChangeSet

CHUNK = 400


def chunks(items: Iterable[Node], size: int = CHUNK) -> Iterator[list[Node]]:
    batch: list[Node] = []
    for it in items:
        batch.append(it)
        if len(batch) == size:
            yield batch
            batch = []
    if batch:
        yield batch


class Neighbourhood:
    """The store's triples around nodes at one graph version, as ``CandidateView`` reads them, carried from one
    commit to the next for the nodes the commit did not touch (``carry``): a fleet's reports read the same
    configurations, parameters and condition values batch after batch. Entries are a node's outgoing triples,
    its incoming ones per predicate filter, and the class hierarchy; a version other than the one carried to
    clears it, so a write that did not go through ``carry`` (another replica's, a rollback) costs a re-read,
    never a stale answer. Used under the store's write lock only (``KnowledgeGraph.commit``)."""

    MAX_NODES = 20_000  # past this many entries it starts again empty

    def __init__(self) -> None:
        self.version = -1
        self.outgoing: dict[Node, frozenset[Triple]] = {}
        self.incoming: dict[frozenset[URIRef] | None, dict[Node, frozenset[Triple]]] = {}  # per predicate filter
        self.axioms: frozenset[Triple] | None = None

    def at(self, version: int) -> Neighbourhood:
        """This cache, for reads of the store at ``version`` (emptied unless it holds that version)."""
        if version != self.version or len(self.outgoing) + sum(map(len, self.incoming.values())) > self.MAX_NODES:
            self.clear()
            self.version = version
        return self

    def clear(self) -> None:
        self.version = -1
        self.outgoing, self.incoming, self.axioms = {}, {}, None

    def carry(self, change: ChangeSet, version: int) -> None:
        """``change`` took the store from ``version`` to ``version + 1``: forget what it touched."""
        if version != self.version:
            self.clear()
            return
        for s, p, o in (*change.added, *change.removed):
            self.outgoing.pop(s, None)
            for kept in self.incoming.values():
                kept.pop(o, None)
            if p == RDFS.subClassOf:
                self.axioms = None
        self.version = version + 1


class CandidateView:
    """Reads of the state the store would have after ``change``, without writing it; ``cache``: what the store
    holds around nodes at its head, where the caller knows the head (``Neighbourhood``)."""

    def __init__(self, backend: Backend, change: ChangeSet, cache: Neighbourhood | None = None) -> None:
        self.backend = backend
        self.change = change
        self.cache = cache
        self._added_by_s: dict[Node, set[Triple]] = {}
        self._added_by_o: dict[Node, set[Triple]] = {}
        for t in change.added:
            self._added_by_s.setdefault(t[0], set()).add(t)
            self._added_by_o.setdefault(t[2], set()).add(t)

    def _stored(self, nodes: list[Node], kept: dict[Node, frozenset[Triple]] | None, side: int,
                query: Callable[[str], str]) -> set[Triple]:
        """The stored triples with ``nodes`` at position ``side`` (0: subject, 2: object), from ``kept`` where it
        has them, the rest read (``query(values)``) and kept."""
        missing = nodes if kept is None else [n for n in nodes if n not in kept]
        out: set[Triple] = set()
        for batch in chunks(missing):
            out |= self.backend.triples(query(" ".join(n3(n) for n in batch)))
        if kept is not None:
            per: dict[Node, set[Triple]] = {n: set() for n in missing}
            for t in out:
                if t[side] in per:
                    per[t[side]].add(t)
            kept.update((n, frozenset(ts)) for n, ts in per.items())
            for n in nodes:
                out |= kept[n]
        return out

    def outgoing(self, nodes: Iterable[Node]) -> set[Triple]:
        nodes = [n for n in nodes if isinstance(n, URIRef)]
        out = self._stored(nodes, self.cache.outgoing if self.cache is not None else None, 0,
                           lambda values: f"CONSTRUCT {{ ?s ?p ?o }} WHERE {{ VALUES ?s {{ {values} }} ?s ?p ?o }}")
        out -= self.change.removed
        for n in nodes:
            out |= self._added_by_s.get(n, set())
        return out

    def incoming(self, nodes: Iterable[Node], predicates: Iterable[URIRef] | None = None) -> set[Triple]:
        """Edges pointing at ``nodes``, except ``rdf:type`` (every instance points at its class)."""
        nodes = [n for n in nodes if isinstance(n, URIRef)]
        preds = frozenset(predicates) if predicates is not None else None
        if preds is not None and not preds:
            return set()
        pred_filter = (
            f"VALUES ?p {{ {' '.join(n3(p) for p in sorted(preds))} }}" if preds is not None else f"FILTER (?p != {n3(RDF.type)})"
        )
        out = self._stored(nodes, self.cache.incoming.setdefault(preds, {}) if self.cache is not None else None, 2,
                           lambda values: f"CONSTRUCT {{ ?s ?p ?o }} WHERE {{ VALUES ?o {{ {values} }} ?s ?p ?o . {pred_filter} }}")
        out -= self.change.removed
        for n in nodes:
            for t in self._added_by_o.get(n, set()):
                if t[1] != RDF.type and (preds is None or t[1] in preds):
                    out.add(t)
        return out

    def subclass_axioms(self) -> set[Triple]:
        stored = self.cache.axioms if self.cache is not None else None
        if stored is None:
            stored = frozenset(self.backend.triples(
                f"CONSTRUCT {{ ?a {n3(RDFS.subClassOf)} ?b }} WHERE {{ ?a {n3(RDFS.subClassOf)} ?b }}"))
            if self.cache is not None:
                self.cache.axioms = stored
        out = set(stored) - self.change.removed
        out |= {t for t in self.change.added if t[1] == RDFS.subClassOf}
        return out
