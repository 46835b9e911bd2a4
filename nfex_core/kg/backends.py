"""Where the triples live: an embedded Oxigraph store (a folder) or any SPARQL 1.1 server (a URL).

Both backends speak the same five operations, so everything above them (versions, transactions,
the rule engine) is written once, in SPARQL:

- ``select``/``ask``/``construct`` return rdflib terms;
- ``update`` runs one SPARQL 1.1 Update request, which both Oxigraph and SPARQL servers apply as one
  transaction (all or nothing);
- ``query_to`` writes a query's results, serialised in a requested format, to a sink (the HTTP endpoint);
- ``values`` reads a SELECT's rows as plain strings, for readers of many rows (no rdflib term per value).

The embedded store is RocksDB underneath: a committed update survives a crash, and a process killed
in the middle of an update leaves the last committed state (RocksDB's write-ahead log).
"""
from __future__ import annotations

import csv
import io
import json
import random
import re
import threading
import time
from abc import ABC, abstractmethod
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol
from urllib.parse import urlparse, urlunparse

import httpx
import pyoxigraph as ox
import rdflib
from rdflib.term import BNode, Literal, Node, URIRef

from ..config import Settings
from ..errors import BadInput, Conflict, ParseError, QueryLimitExceeded, StoreUnavailable
from .protocol import ServerAuth, dataset_params
from .terms import Triple, from_sparql_json, n3, oxigraph_triples, plain, term_converter, to_oxigraph

Row = dict[str, Node]
DEADLOCK_RETRIES = 8
_SERIALIZATION_FAILURE = re.compile(r"\b40001\b")


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
    commits then need no claims (kg/claims.py), only ``write_lock``."""

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
            return _csv_rows(out.getvalue())
        result = self.select(query)
        return [[_lexical(r.get(v)) for v in result.variables] for r in result.rows]

    def close(self) -> None:  # noqa: B027 - optional hook
        pass


def _csv_rows(data: bytes) -> list[list[str]]:
    """The rows of a CSV results document, its header line dropped (csv reads quoted line breaks in values)."""
    return list(csv.reader(io.StringIO(data.decode("utf-8"), newline="")))[1:]


def _lexical(term: Node | None) -> str:
    """A term as the CSV results format writes it."""
    if term is None:
        return ""
    return f"_:{term}" if isinstance(term, BNode) else str(term)


class EmbeddedBackend(Backend):
    """An Oxigraph store in a folder (RocksDB), or in memory when ``path`` is None."""

    @classmethod
    def of_store(cls, store: ox.Store) -> EmbeddedBackend:
        """An in-memory backend over an Oxigraph store already filled (e.g. a scoped copy)."""
        backend = cls(None)
        backend._store = store
        return backend

    exclusive = True

    def __init__(self, path: str | Path | None, *, graph: str | None = None) -> None:
        self.location = str(path) if path is not None else ":memory:"
        self.graph = graph
        self._dataset: dict[str, Any] = {"default_graph": ox.NamedNode(graph)} if graph else {}
        if path is not None:
            # Oxigraph creates the store folder but not its parents (~/.local/share on a fresh machine)
            try:
                Path(path).parent.mkdir(parents=True, exist_ok=True)
            except OSError as e:
                raise StoreUnavailable(f"cannot create the store folder's parent {Path(path).parent}: {e}") from e
        try:
            self._store = ox.Store(str(path)) if path is not None else ox.Store()
        except OSError as e:
            if "lock" in str(e).lower():
                raise StoreUnavailable(
                    f"the store folder {path} is in use by another process (an nFEX service or CLI); "
                    "stop it, or reach it over HTTP with NFEX_STORE=http://…"
                ) from e
            raise StoreUnavailable(f"cannot open the store folder {path}: {e}") from e

    def _run(self, query: str) -> Any:
        try:
            return self._store.query(query, **self._dataset)
        except SyntaxError as e:
            raise ParseError(f"invalid SPARQL query: {e}") from e

    def solutions(self, query: str) -> ox.QuerySolutions:
        """A SELECT's answer as Oxigraph gives it, terms unconverted: for a reader of many rows that needs a few
        strings of each (the rule engine's ``pruning.evaluate``), where ``select``'s rdflib terms cost most."""
        res = self._run(query)
        if not isinstance(res, ox.QuerySolutions):
            raise BadInput("expected a SELECT query")
        return res

    def select(self, query: str) -> SelectResult:
        res = self._run(query)
        if not isinstance(res, ox.QuerySolutions):
            raise BadInput("expected a SELECT query")
        names = [v.value for v in res.variables]
        rows: list[Row] = []
        convert = term_converter()  # a term repeats across rows (a rule's extractor and reason per context)
        for sol in res:
            row: Row = {}
            for name in names:
                term = sol[name]
                if term is not None:
                    row[name] = convert(term)
            rows.append(row)
        return SelectResult(names, rows)

    def ask(self, query: str) -> bool:
        res = self._run(query)
        if not isinstance(res, ox.QueryBoolean):
            raise BadInput("expected an ASK query")
        return bool(res)

    def triples(self, query: str) -> set[Triple]:
        res = self._run(query)
        if not isinstance(res, ox.QueryTriples):
            raise BadInput("expected a CONSTRUCT or DESCRIBE query")
        return set(oxigraph_triples(res))

    def present(self, triples: Iterable[Triple]) -> set[Triple]:
        """As ``Backend.present``, each triple looked up in Oxigraph's indexes: no query text to write and parse
        (a report batch's ~110 triples: 2.0 -> 0.8 ms in a probe). A term Oxigraph refuses (an IRI with a space)
        goes the query's way, which raises what a query raises."""
        graph = self._dataset.get("default_graph", ox.DefaultGraph())
        items = list(triples)
        quads: list[tuple[Triple, ox.Quad]] = []
        try:
            for t in items:
                s, p, o = to_oxigraph(t[0]), to_oxigraph(t[1]), to_oxigraph(t[2])
                if isinstance(s, ox.NamedNode) and isinstance(p, ox.NamedNode):  # else no store holds it
                    quads.append((t, ox.Quad(s, p, o, graph)))
        except ValueError:
            return super().present(items)
        store = self._store
        return {t for t, q in quads if q in store}

    def update(self, update: str) -> None:
        try:
            self._store.update(update)
        except SyntaxError as e:
            raise ParseError(f"invalid SPARQL update: {e}") from e

    def query_to(self, query: str, media: str, out: Sink, timeout_s: float | None = None) -> str:
        res = self._run(query)
        if isinstance(res, ox.QueryTriples):
            media = media if media in GRAPH_FORMATS else "text/turtle"
            res.serialize(out, format=GRAPH_FORMATS[media])  # type: ignore[arg-type]  # any object with write(bytes)
        else:
            media = media if media in RESULT_FORMATS else "application/sparql-results+json"
            res.serialize(out, format=RESULT_FORMATS[media])
        return media

    def values(self, query: str) -> list[list[str]]:
        """As ``Backend.values``, serialised by Oxigraph to one buffer: the query runs without the interpreter lock,
        so such reads proceed side by side on threads."""
        res = self._run(query)
        if not isinstance(res, ox.QuerySolutions):
            raise BadInput("expected a SELECT query")
        return _csv_rows(res.serialize(format=ox.QueryResultsFormat.CSV) or b"")

    def checkpoint(self, path: str | Path) -> None:
        """A consistent read-only copy of the store in the new folder ``path`` (RocksDB's checkpoint: hard links
        to the store's files, on the same file system), which another process may open while this one writes."""
        self._store.backup(str(path))

    def construct_to_file(self, query: str, path: str) -> None:
        """A CONSTRUCT's triples written as N-Triples to the file ``path`` by Oxigraph, without the interpreter lock
        (``query_to`` writes through a Python object, taking the lock for every chunk)."""
        res = self._run(query)
        if not isinstance(res, ox.QueryTriples):
            raise BadInput("expected a CONSTRUCT query")
        res.serialize(path, format=ox.RdfFormat.N_TRIPLES)

    def load(self, data: bytes, media: str = "application/n-triples") -> None:
        """Load serialised triples into the default graph in one transaction (scratch copies for
        what-if previews, nfex_core/impact.py)."""
        self._store.load(data, format=GRAPH_FORMATS[media])

    def bulk_load(self, data: bytes) -> None:
        """Load N-Quads with Oxigraph's bulk loader: faster than ``load``, and not atomic (kg/history.py
        ``bulk_write_first`` brackets it)."""
        self._store.bulk_load(data, format=ox.RdfFormat.N_QUADS)

    def flush(self) -> None:
        self._store.flush()

    def close(self) -> None:
        # RocksDB releases its lock when the store object is collected.
        self.__dict__.pop("_store", None)


class RemoteBackend(Backend):
    """A SPARQL 1.1 Protocol server: Oxigraph server, Fuseki, GraphDB, Virtuoso…

    ``url`` is the query endpoint. The update endpoint is ``update_url`` or, by convention, the query
    URL with its last path segment replaced by ``update`` (Oxigraph ``/query`` → ``/update``; Fuseki
    ``/ds/query`` → ``/ds/update``; a bare ``http://host:port`` gets ``/query`` and ``/update``); servers
    with one endpoint for both (Virtuoso's ``/sparql``) or another name (GraphDB's ``…/statements``) set it.
    Queries are POSTed URL-encoded (Protocol §2.1.2), the one form every server takes (Virtuoso 7.2 never
    answers a POST of ``application/sparql-query``); with ``graph`` set they name their dataset
    (``protocol.dataset_params``). ``user``/``password`` answer the server's Basic or Digest challenge.
    """

    # Virtuoso 7's SQL compiler stops at 10,000 lines: a DELETE/INSERT template of 1,000 triples in two graphs
    # fails, 500 passes; nFEX writes a change twice (the knowledge and the version's change set)
    max_inline_triples = 250

    def __init__(
        self,
        url: str,
        *,
        update_url: str | None = None,
        user: str | None = None,
        password: str | None = None,
        graph: str | None = None,
        timeout_s: float = 30.0,
    ) -> None:
        parsed = urlparse(url)
        path = parsed.path.rstrip("/")
        if not path:
            query_url = urlunparse(parsed._replace(path="/query"))
            default_update = urlunparse(parsed._replace(path="/update"))
        else:
            query_url = url
            default_update = urlunparse(parsed._replace(path=path.rsplit("/", 1)[0] + "/update"))
        self.location = query_url
        self.query_url = query_url
        self.update_url = update_url or default_update
        self.graph = graph
        auth = ServerAuth(user, password or "") if user else None
        self._client = httpx.Client(timeout=timeout_s, auth=auth)

    def _query_form(self, query: str) -> dict[str, str | list[str]]:
        return {"query": query, **dataset_params(query, self.graph)}

    def _post_query(self, query: str, accept: str) -> httpx.Response:
        try:
            r = self._client.post(self.query_url, data=self._query_form(query), headers={"Accept": accept})
        except httpx.TimeoutException as e:
            raise QueryLimitExceeded(f"the SPARQL server at {self.query_url} did not answer in time") from e
        except httpx.HTTPError as e:
            raise StoreUnavailable(f"cannot reach the SPARQL server at {self.query_url}: {e}") from e
        self._check(r, "query")
        return r

    def _check(self, r: httpx.Response, what: str) -> None:
        if r.status_code < 300:
            return
        text = r.text.strip()[:500]
        if r.status_code in (401, 403):
            raise StoreUnavailable(
                f"the SPARQL server refused the {what} ({r.status_code}): check NFEX_STORE_USER / NFEX_STORE_PASSWORD"
                + (f": {text}" if text else "")
            )
        if r.status_code == 400:
            raise ParseError(f"the SPARQL server rejected the {what}: {text}")
        raise StoreUnavailable(f"the SPARQL server answered {r.status_code} to a {what}: {text}")

    def select(self, query: str) -> SelectResult:
        data = self._post_query(query, "application/sparql-results+json").json()
        if "boolean" in data:
            raise BadInput("expected a SELECT query")
        names = list(data["head"].get("vars", []))
        rows = [{k: from_sparql_json(v) for k, v in b.items()} for b in data["results"]["bindings"]]
        return SelectResult(names, rows)

    def ask(self, query: str) -> bool:
        data = self._post_query(query, "application/sparql-results+json").json()
        if "boolean" not in data and data.get("head", {}).get("vars") == ["__ASK_RETVAL"]:
            # Virtuoso with CaseMode 1 answers an ASK as a SELECT of its return value (no row: false)
            return any(int(b["__ASK_RETVAL"]["value"]) for b in data["results"]["bindings"])
        if "boolean" not in data:
            raise BadInput("expected an ASK query")
        return bool(data["boolean"])

    def triples(self, query: str) -> set[Triple]:
        """The N-Triples answer parsed by Oxigraph (rdflib's parser took most of a commit's validation reads),
        each distinct term converted once, literals normalised as the embedded store's are."""
        r = self._post_query(query, "application/n-triples")
        try:
            # rename_blank_nodes: one answer's `_:b0` is not another's
            return set(oxigraph_triples(ox.parse(r.content, format=ox.RdfFormat.N_TRIPLES, rename_blank_nodes=True)))
        except SyntaxError as e:
            raise StoreUnavailable(f"the SPARQL server at {self.location} answered a CONSTRUCT with invalid N-Triples: {e}") from e

    def update(self, update: str) -> None:
        for attempt in range(DEADLOCK_RETRIES + 1):
            try:
                r = self._client.post(
                    self.update_url,
                    content=update.encode("utf-8"),
                    headers={"Content-Type": "application/sparql-update"},
                )
            except httpx.HTTPError as e:
                raise StoreUnavailable(f"cannot reach the SPARQL server at {self.update_url}: {e}") from e
            if r.status_code < 500 or not _SERIALIZATION_FAILURE.search(r.text[:300]):
                break
            # the server aborted the transaction to break a deadlock (SQLSTATE 40001; Virtuoso under concurrent
            # writers): nothing of it was applied, and every update nFEX sends is idempotent, so send it again
            time.sleep(random.uniform(0.01, 0.05) * (attempt + 1))
        else:
            raise Conflict(f"the SPARQL server at {self.update_url} kept aborting the update as deadlocked; retry")
        self._check(r, "update")

    def query_to(self, query: str, media: str, out: Sink, timeout_s: float | None = None) -> str:
        try:
            with self._client.stream(
                "POST",
                self.query_url,
                data=self._query_form(query),
                headers={"Accept": media},
                timeout=timeout_s if timeout_s is not None else httpx.USE_CLIENT_DEFAULT,
            ) as r:
                if r.status_code >= 300:
                    r.read()
                    self._check(r, "query")
                for chunk in r.iter_bytes():
                    out.write(chunk)
                return r.headers.get("content-type", media).split(";")[0].strip()
        except httpx.TimeoutException as e:
            raise QueryLimitExceeded(f"the SPARQL server at {self.query_url} did not answer in time", limit="time") from e
        except httpx.HTTPError as e:
            raise StoreUnavailable(f"cannot reach the SPARQL server at {self.query_url}: {e}") from e

    def close(self) -> None:
        self._client.close()


def open_backend(location: str, settings: Settings | None = None) -> Backend:
    """A backend for ``NFEX_STORE``: an http(s) URL, ``:memory:``, or a folder; ``settings`` supply the
    update endpoint, credentials and knowledge graph (``NFEX_STORE_UPDATE``, ``_USER``, ``_PASSWORD``, ``_GRAPH``)."""
    graph = settings.store_graph if settings else None
    if location.startswith(("http://", "https://")):
        if settings is None:
            return RemoteBackend(location)
        return RemoteBackend(location, update_url=settings.store_update, user=settings.store_user,
                             password=settings.store_password, graph=graph)
    if location == ":memory:":
        return EmbeddedBackend(None, graph=graph)
    return EmbeddedBackend(Path(location).expanduser(), graph=graph)


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


__all__ = ["Backend", "EmbeddedBackend", "RemoteBackend", "SelectResult", "open_backend", "json_bindings", "json"]
