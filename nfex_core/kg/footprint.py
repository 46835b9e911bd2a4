"""What a SPARQL query can read: its *footprint*, the (predicate, object) pairs of the triples it can match.

Every triple pattern of a SPARQL query has a predicate, or a property path of predicates; a pattern whose
predicate is a constant p matches triples with predicate p only (and, for ``?x a C``, object C only). So the
answer of a query with a footprint is a function of the graph's triples that match it, and a change that adds
or removes none of those leaves the answer as it was. The rule engine keeps a SPARQL rule's last hits on that
ground (rules/engine.py), and the observation index reads nothing again for a change that misses the
observations' queries (evidence/index.py).
"""
from __future__ import annotations

import functools
from collections.abc import Collection, Iterable
from typing import Any

from rdflib.namespace import RDF
from rdflib.paths import AlternativePath, InvPath, MulPath, SequencePath
from rdflib.plugins.sparql.algebra import translateGroupGraphPattern, traverse
from rdflib.term import URIRef

from .backends import GraphReader, SelectResult
from .history import prefix_block
from .rdflib_sparql import prepare_query
from .terms import Triple

Footprint = frozenset[tuple[str, str | None]]  # (predicate, object or None: any)
_OPAQUE = {"TriplesBlock", "ServiceGraphPattern", "Graph"}  # patterns not in algebra form, or not of the default graph


@functools.lru_cache(maxsize=256)
def footprint(query: str) -> Footprint | None:
    """The triples ``query`` can read, as (predicate, object) pairs — the object only for ``rdf:type`` with a
    constant class, else None (any) — or None where that cannot be told (a variable predicate, a negated
    property set, a pattern rdflib's algebra leaves unparsed, a query rdflib cannot parse)."""
    try:
        algebra = prepare_query(query).algebra
    except Exception:
        return None
    found: set[tuple[str, str | None]] = set()
    opaque = False

    def predicates(path: object) -> bool:
        if isinstance(path, URIRef):
            found.add((str(path), None))
            return True
        if isinstance(path, SequencePath | AlternativePath):
            return all(predicates(a) for a in path.args)
        if isinstance(path, InvPath):
            return predicates(path.arg)
        if isinstance(path, MulPath):
            return predicates(path.path)
        return False  # a variable, a negated property set

    def visit(node: Any) -> Any:
        nonlocal opaque
        name = getattr(node, "name", None)
        if name == "GroupGraphPatternSub":  # an EXISTS pattern, which rdflib leaves as parsed: translated here
            try:
                inner = translateGroupGraphPattern(node)
            except Exception:
                opaque = True
                return node
            traverse(inner, visitPre=visit)
            return inner  # not None: traverse does not descend into the parsed form
        if name in _OPAQUE:
            opaque = True
        elif name == "BGP":
            for _, p, o in node.triples:
                if p == RDF.type and isinstance(o, URIRef):
                    found.add((str(p), str(o)))
                elif not predicates(p):
                    opaque = True
        return None

    traverse(algebra, visitPre=visit)
    return None if opaque else frozenset(found)


def pairs(triples: Iterable[Triple]) -> frozenset[tuple[str, str]]:
    """The (predicate, object) pairs of ``triples``: what ``reads`` compares with a footprint."""
    return frozenset((str(p), str(o)) for _, p, o in triples)


def reads(footprint: Footprint | None, touched: Collection[tuple[str, str]] | None) -> bool:
    """Whether a change of the (predicate, object) pairs ``touched`` (None: unknown) can change the answer of a
    query with ``footprint`` (``footprint``)."""
    if footprint is None or touched is None:
        return True
    return any((p, None) in footprint or (p, o) in footprint for p, o in touched)


class Recorder:
    """A ``GraphReader`` over ``reader`` that notes every query it passes on, so that what a loader read can be
    told afterwards: ``footprint()`` is the union of its queries' footprints (None when any has none, or when
    it asked nothing). ``KnowledgeGraph`` learns the vocabulary's this way and carries the vocabulary over a
    change that misses it — without a list of the loader's queries to keep in step with the loader."""

    def __init__(self, reader: GraphReader) -> None:
        self._reader = reader
        self.queries: list[str] = []

    @property
    def version(self) -> int:
        return self._reader.version

    def select(self, query: str, *, prefixes: bool = True) -> SelectResult:
        self.queries.append((prefix_block() if prefixes else "") + query)
        return self._reader.select(query, prefixes=prefixes)

    def footprint(self) -> Footprint | None:
        found: set[tuple[str, str | None]] = set()
        for query in self.queries:
            fp = footprint(query)
            if fp is None:
                return None
            found |= fp
        return frozenset(found) if self.queries else None
