"""What every store backend is: the five operations (``Backend``), their results and the readers' protocol.

backends.py has the embedded Oxigraph store and ``open_backend``; remote.py the SPARQL 1.1 server over HTTP.
"""
from __future__ import annotations

import csv
import io
import re
import threading
from abc import ABC, abstractmethod
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any, Protocol

import pyoxigraph as ox
import rdflib
from rdflib.term import BNode, Literal, Node, URIRef

from ..rdf.terms import Triple, n3, plain

Row = dict[str, Node]
DEADLOCK_RETRIES = 8
SERIALIZATION_FAILURE = re.compile(r"\b40001\b")


class Sink(Protocol):
    """Where ``query_to`` writes serialised results (a file, or a writer enforcing limits)."""

    def write(self, data: bytes, /) -> int: ...


class GraphReader(Protocol):
    """What reading the knowledge needs: the graph version and SELECT (``KnowledgeGraph`` is one)."""

    @property
    def version(self) -> int: ...

    def select(self, query: str, *, prefixes: bool = True) -> SelectResult: ...


@dataclass(frozen=True)
class SelectResult:
    """Variables and rows of a SELECT; unbound variables are absent from a row."""

    variables: list[str]
    rows: list[Row]

    def __iter__(self):
        return iter(self.rows)

    def __len__(self) -> int:
        return len(self.rows)


# Result formats by media type, for SELECT/ASK and for CONSTRUCT/DESCRIBE.
RESULT_FORMATS: dict[str, ox.QueryResultsFormat] = {
    "application/sparql-results+json": ox.QueryResultsFormat.JSON,
    "application/sparql-results+xml": ox.QueryResultsFormat.XML,
    "text/csv": ox.QueryResultsFormat.CSV,
    "text/tab-separated-values": ox.QueryResultsFormat.TSV,
}
GRAPH_FORMATS: dict[str, ox.RdfFormat] = {
    "text/turtle": ox.RdfFormat.TURTLE,
    "application/n-triples": ox.RdfFormat.N_TRIPLES,
    "application/ld+json": ox.RdfFormat.JSON_LD,
    "application/rdf+xml": ox.RdfFormat.RDF_XML,
}


class Backend(ABC):
    """The five operations every store offers.

    ``graph`` is the named graph holding the knowledge (``NFEX_STORE_GRAPH``), or None for the store's
    default graph: queries see it as their default graph; writers put knowledge triples in it
    (``graph_block``)."""

    location: str
    graph: str | None = None
    max_inline_triples: int | None = None
    """The largest change written in one update request; a larger one is staged (``KnowledgeGraph._write_version``)."""

    def graph_block(self, triples: str) -> str:
        """Update-template text placing ``triples`` where the knowledge lives (none: nothing, as Virtuoso
        refuses an empty ``GRAPH`` block)."""
        return f"GRAPH <{self.graph}> {{\n{triples}\n}}" if self.graph and triples.strip() else triples

    exclusive: bool = False
    """True when this process alone writes the store (an embedded folder is locked by its process):
    commits then need no claims (kg/storage/claims.py), only ``write_lock``."""

    @property
    def write_lock(self) -> threading.Lock:
        """The lock this process's writers take turns on (one per backend, whatever wraps it)."""
        lock = self.__dict__.get("_write_lock")
        if lock is None:
            lock = self.__dict__.setdefault("_write_lock", threading.Lock())
        return lock

    @abstractmethod
    def select(self, query: str) -> SelectResult: ...

    @abstractmethod
    def ask(self, query: str) -> bool: ...

    def construct(self, query: str) -> rdflib.Graph:
        """A CONSTRUCT's triples as an rdflib Graph (``triples`` where a set will do: no Graph built)."""
        g = rdflib.Graph()
        for t in self.triples(query):
            g.add(t)
        return g

    @abstractmethod
    def triples(self, query: str) -> set[Triple]:
        """A CONSTRUCT's triples as a set, literals normalised (terms.plain)."""

    def present(self, triples: Iterable[Triple]) -> set[Triple]:
        """Those of ``triples`` the knowledge graph holds, as given (a literal in another lexical form of the same
        term, ``"x"^^xsd:string`` or ``"1.50"^^xsd:decimal``, comes back as given, not as the store writes it: a
        change's triples are subtracted from it); one VALUES query per 500."""
        found: set[Triple] = set()
        items = list(triples)
        for i in range(0, len(items), 500):
            values = " ".join(f"({n3(s)} {n3(p)} {n3(o)})" for s, p, o in items[i : i + 500])
            res = self.select(f"SELECT ?s ?p ?o WHERE {{ VALUES (?s ?p ?o) {{ {values} }} ?s ?p ?o }}")
            found.update((r["s"], r["p"], r["o"]) for r in res.rows)
        return {t for t in items if (t[0], t[1], plain(t[2]) if isinstance(t[2], Literal) else t[2]) in found}

    @abstractmethod
    def update(self, update: str) -> None: ...

    @abstractmethod
    def query_to(self, query: str, media: str, out: Sink, timeout_s: float | None = None) -> str:
        """Run any query and write its results as ``media`` to ``out`` while they are produced (the
        HTTP endpoint passes a writer that enforces its time and size limits); returns the media type
        written, ``media`` or the form's default when ``media`` does not fit the query's form."""

    def values(self, query: str) -> list[list[str]]:
        """A SELECT's rows, each value as the SPARQL 1.1 CSV results format writes it — an IRI bare, a literal its
        lexical form (no datatype or language), a blank node ``_:label``, ``""`` where unbound — in the order of
        the SELECT's variables. For readers of many rows that need the strings only: the server serialises and
        Python's csv module parses, no term object is made per value. A server that does not answer CSV is read
        through ``select``."""
        out = io.BytesIO()
        if self.query_to(query, "text/csv", out) == "text/csv":
            return csv_rows(out.getvalue())
        result = self.select(query)
        return [[_lexical(r.get(v)) for v in result.variables] for r in result.rows]

    def close(self) -> None:  # noqa: B027 - optional hook
        pass


def csv_rows(data: bytes) -> list[list[str]]:
    """The rows of a CSV results document, its header line dropped (csv reads quoted line breaks in values)."""
    return list(csv.reader(io.StringIO(data.decode("utf-8"), newline="")))[1:]


def _lexical(term: Node | None) -> str:
    """A term as the CSV results format writes it."""
    if term is None:
        return ""
    return f"_:{term}" if isinstance(term, BNode) else str(term)


def json_bindings(result: SelectResult) -> dict[str, Any]:
    """A SELECT result as SPARQL 1.1 JSON results (used by the CLI's --format json)."""

    def term(t: Node) -> dict[str, str]:
        if isinstance(t, URIRef):
            return {"type": "uri", "value": str(t)}
        if isinstance(t, BNode):
            return {"type": "bnode", "value": str(t)}
        assert isinstance(t, Literal)
        d = {"type": "literal", "value": str(t)}
        if t.language:
            d["xml:lang"] = t.language
        elif t.datatype:
            d["datatype"] = str(t.datatype)
        return d

    return {
        "head": {"vars": result.variables},
        "results": {"bindings": [{k: term(v) for k, v in row.items()} for row in result.rows]},
    }
