"""Change sets: what one write adds to and removes from the knowledge graph.

A change set is the unit of a transaction and of a graph version. Its algebra makes versions exact:
``inverse`` undoes a change, ``then`` composes two changes in order, so rolling back to version v is
the composition of the inverses of every later version (applied newest first).
"""
from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

import pyoxigraph as ox
import rdflib
from rdflib.namespace import PROV, RDF
from rdflib.term import Node, URIRef

from ..errors import BadInput, ParseError
from .backends import Backend
from .namespaces import NFEX
from .terms import Triple, n3, normalise, oxigraph_triples, skolemise

RDF_FORMATS = {
    ".ttl": "turtle",
    ".nt": "nt",
    ".n3": "n3",
    ".jsonld": "json-ld",
    ".json": "json-ld",
    ".rdf": "xml",
    ".owl": "xml",
    ".xml": "xml",
    ".trig": "trig",
}


@dataclass(frozen=True)
class ChangeSet:
    added: frozenset[Triple] = field(default_factory=frozenset)
    removed: frozenset[Triple] = field(default_factory=frozenset)

    @classmethod
    def adding(cls, triples: Iterable[Triple]) -> ChangeSet:
        return cls(added=frozenset(triples))

    @classmethod
    def removing(cls, triples: Iterable[Triple]) -> ChangeSet:
        return cls(removed=frozenset(triples))

    @classmethod
    def of(cls, added: Iterable[Triple] = (), removed: Iterable[Triple] = ()) -> ChangeSet:
        a, r = frozenset(added), frozenset(removed)
        return cls(added=a - r, removed=r - a)

    @property
    def empty(self) -> bool:
        return not self.added and not self.removed

    def __len__(self) -> int:
        return len(self.added) + len(self.removed)

    def inverse(self) -> ChangeSet:
        return ChangeSet(added=self.removed, removed=self.added)

    def then(self, later: ChangeSet) -> ChangeSet:
        """The net change of applying ``self`` and then ``later``.

        Exact when both are effective (each adds only absent triples and removes only present ones),
        which is what the store records.
        """
        added = (self.added - later.removed) | later.added
        removed = (self.removed - later.added) | later.removed
        return ChangeSet(added=frozenset(added - removed), removed=frozenset(removed - added))

    def subjects(self) -> set[Node]:
        return {t[0] for t in self.added} | {t[0] for t in self.removed}

    def nodes(self) -> set[Node]:
        return self.subjects() | {t[2] for t in self.added} | {t[2] for t in self.removed}

    def as_graph(self, which: str = "added") -> rdflib.Graph:
        g = rdflib.Graph()
        for t in self.added if which == "added" else self.removed:
            g.add(t)
        return g


# What a sweep or a client's report writes (sweeps/records.py, feedback.py): the Measurement and the nodes
# around it. Nothing that configures selection — the vocabulary, statements, shapes, rules, settings — has
# one of these types, and none of its readers reads a node of one (see ``evidence_only``).
EVIDENCE_CLASSES = frozenset({
    NFEX.Measurement, NFEX.MetricResult, NFEX.Configuration, NFEX.ParameterSetting, NFEX.Run, NFEX.Machine,
    NFEX.Sequence, NFEX.Dataset, NFEX.Corruption, NFEX.Reporter, PROV.Agent,
})


def evidence_only(backend: Backend, change: ChangeSet, later: ChangeSet | None = None) -> bool:
    """Whether ``change`` touches evidence and nothing else: every subject it adds or removes a triple of is
    an IRI typed, before or after the change, with ``EVIDENCE_CLASSES`` only (an untyped subject is not).

    ``backend`` holds the graph after the change, then ``later`` (the net change since, if any; the caller
    checks that no commit landed while the types were read). A subject's types after the change are those
    read, less the type triples ``later`` added, plus those it removed; its types before the change are those
    after, less the type triples the change added, plus those it removed — so the types after, with every
    type triple of the change, include both. What a compile derives from the graph's configuration alone
    (rules/setup.py) is then the same on both sides of the change, since its readers only read nodes of
    configuration classes and the nodes they link to, which a report never writes
    (tests/nfex_core/rules/test_setup.py compares with a full compile after random changes)."""
    subjects = change.subjects()
    if not subjects:
        return True
    if any(not isinstance(s, URIRef) for s in subjects):
        return False
    types: dict[Node, set[Node]] = {s: set() for s in subjects}
    items = sorted(subjects, key=str)
    for i in range(0, len(items), 500):
        values = " ".join(n3(x) for x in items[i : i + 500])
        for r in backend.select(f"SELECT ?s ?t WHERE {{ VALUES ?s {{ {values} }} ?s {n3(RDF.type)} ?t }}").rows:
            types[r["s"]].add(r["t"])
    if later is not None:
        for s, p, o in later.added:
            if p == RDF.type and s in types:
                types[s].discard(o)
        for s, p, o in later.removed:
            if p == RDF.type and s in types:
                types[s].add(o)
    for s, p, o in change.added | change.removed:
        if p == RDF.type:
            types[s].add(o)
    return all(t and t <= EVIDENCE_CLASSES for t in types.values())


def graph_triples(graph: Iterable[Triple]) -> frozenset[Triple]:
    """The triples of a parsed graph (an rdflib Graph or any triples), skolemised and normalised for the store."""
    return frozenset(normalise(skolemise(graph)))


def parse_rdf(data: str | bytes, *, format: str = "turtle", source: str = "<input>") -> rdflib.Graph:
    """Parse RDF text; a syntax error becomes a ParseError naming the source (and line where known)."""
    g = rdflib.Graph()
    try:
        g.parse(data=data, format=format)
    except Exception as e:  # rdflib raises several unrelated types for bad syntax
        line = getattr(e, "lines", None) or getattr(e, "lineno", None)
        raise ParseError(f"{source}: not valid {format}: {e}".strip(), line=line if isinstance(line, int) else None) from e
    return g


def read_turtle(path: Path) -> list[ox.Quad]:
    """A Turtle file as Oxigraph parses it, into the default graph (blank nodes as they are).

    About three times rdflib's speed on the shipped ontology, which the seed parses on every first start.
    A relative IRI resolves against the working directory, as rdflib's ``parse(data=...)`` resolves it
    (``seed_content.digest`` keys such a file by the directory); ``tests/nfex_core/kg/test_shipped.py``
    checks that both parsers give the shipped files the same triples.
    """
    try:
        data = path.read_bytes()
    except OSError as e:
        raise BadInput(f"{path}: cannot read: {e.strerror or e}") from e
    try:
        # rename_blank_nodes: `_:a` in two files (or two reads of one) is two nodes, as rdflib makes them
        return list(ox.parse(data, format=ox.RdfFormat.TURTLE, base_iri=Path.cwd().as_uri() + "/", rename_blank_nodes=True))
    except SyntaxError as e:
        raise ParseError(f"{path}: not valid turtle: {e.msg}", line=e.lineno) from e


def read_turtle_triples(path: Path) -> list[Triple]:
    """``read_turtle`` as rdflib terms, literals as written (``graph_triples`` skolemises and normalises)."""
    return list(oxigraph_triples(read_turtle(path), as_written=True))


def read_rdf_file(path: Path) -> rdflib.Graph:
    """An RDF file by its suffix; ``.gz`` after it (``x.nt.gz``, ``x.ttl.gz``) is read through gzip."""
    zipped = path.suffix.lower() == ".gz"
    suffix = Path(path.stem).suffix if zipped else path.suffix
    fmt = RDF_FORMATS.get(suffix.lower())
    if fmt is None:
        raise ParseError(f"{path}: unknown RDF file type {suffix!r}; use one of {', '.join(sorted(RDF_FORMATS))} (optionally .gz)")
    try:
        data = path.read_bytes()
        if zipped:
            import gzip

            data = gzip.decompress(data)
    except (OSError, EOFError) as e:
        raise BadInput(f"{path}: cannot read: {getattr(e, 'strerror', None) or e}") from e
    return parse_rdf(data, format=fmt, source=str(path))
