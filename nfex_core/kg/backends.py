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

import json
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import pyoxigraph as ox

from ..config import Settings
from ..errors import BadInput, ParseError, StoreUnavailable
from .backend_api import (
    DEADLOCK_RETRIES,
    GRAPH_FORMATS,
    RESULT_FORMATS,
    Backend,
    GraphReader,
    Row,
    SelectResult,
    Sink,
    csv_rows,
    json_bindings,
)
from .remote import RemoteBackend
from .terms import Triple, oxigraph_triples, term_converter, to_oxigraph


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
        return csv_rows(res.serialize(format=ox.QueryResultsFormat.CSV) or b"")

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
        what-if previews, nfex_core/advisor/impact.py)."""
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


__all__ = ["DEADLOCK_RETRIES", "GRAPH_FORMATS", "RESULT_FORMATS", "Backend", "EmbeddedBackend", "GraphReader",
           "RemoteBackend", "Row", "SelectResult", "Sink", "json", "json_bindings", "open_backend"]
