"""A SPARQL 1.1 server as the store (a URL): the five operations of ``Backend`` over the SPARQL 1.1 Protocol.

Updates are retried on a serialisation failure (``DEADLOCK_RETRIES``: Virtuoso answers concurrent updates with
SQLSTATE 40001); queries stream their results to a sink for the HTTP endpoint (``query_to``).
"""
from __future__ import annotations

import random
import time
from urllib.parse import urlparse, urlunparse

import httpx
import pyoxigraph as ox

from ...errors import BadInput, Conflict, ParseError, QueryLimitExceeded, StoreUnavailable
from ..rdf.terms import Triple, from_sparql_json, oxigraph_triples
from .backend_api import (
    DEADLOCK_RETRIES,
    SERIALIZATION_FAILURE,
    Backend,
    SelectResult,
    Sink,
)
from .protocol import ServerAuth, dataset_params


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
            if r.status_code < 500 or not SERIALIZATION_FAILURE.search(r.text[:300]):
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
