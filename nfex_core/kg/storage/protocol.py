"""What talking to other SPARQL servers over HTTP needs beyond the SPARQL 1.1 Protocol's happy path.

- **Credentials.** Servers that guard updates ask for HTTP Basic (GraphDB, Fuseki) or Digest (Virtuoso's
  ``/sparql-auth``). ``ServerAuth`` answers whichever scheme the server's ``WWW-Authenticate`` challenge
  names, and sends it up front from then on, so a password is never sent to a server that did not ask.
- **The knowledge in a named graph.** On servers whose default graph is the union of all named graphs
  (GraphDB, Virtuoso by default), nFEX's version history — itself kept in named graphs — would show up
  as knowledge, every triple twice. With ``NFEX_STORE_GRAPH`` set the knowledge lives in that named graph
  and each query names its dataset in the request (SPARQL 1.1 Protocol §2.1.4): ``default-graph-uri`` the
  knowledge graph and, because a request that gives a default graph gives all named graphs it may use,
  ``named-graph-uri`` each graph the query names in a ``GRAPH <iri>`` pattern (the version history's).
  A pattern ``GRAPH ?g`` therefore ranges over those graphs only.
"""
from __future__ import annotations

import re
from collections.abc import Generator

import httpx

from .sparql_query import strip_comments

_GRAPH_IRI = re.compile(r"\bGRAPH\s*<([^>\s]*)>", re.IGNORECASE)


def dataset_params(query: str, graph: str | None) -> dict[str, str | list[str]]:
    """The protocol's dataset parameters for ``query`` on a store keeping its knowledge in ``graph``
    (none when the knowledge is in the server's default graph)."""
    if not graph:
        return {}
    named = sorted(set(_GRAPH_IRI.findall(strip_comments(query))))
    params: dict[str, str | list[str]] = {"default-graph-uri": graph}
    if named:
        params["named-graph-uri"] = named
    return params


class ServerAuth(httpx.Auth):
    """HTTP Basic or Digest (RFC 7617, RFC 7616), whichever the server's challenge asks for."""

    requires_request_body = True

    def __init__(self, user: str, password: str) -> None:
        self._schemes: dict[str, httpx.Auth] = {
            "basic": httpx.BasicAuth(user, password), "digest": httpx.DigestAuth(user, password)}
        self._scheme: str | None = None

    @property
    def scheme(self) -> str | None:
        """The scheme the server asked for, once it has (``basic`` or ``digest``)."""
        return self._scheme

    def auth_flow(self, request: httpx.Request) -> Generator[httpx.Request, httpx.Response, None]:
        if self._scheme is not None:
            yield from self._schemes[self._scheme].auth_flow(request)
            return
        response = yield request
        challenge = response.headers.get("www-authenticate", "").split(" ", 1)[0].lower()
        if response.status_code != 401 or challenge not in self._schemes:
            return
        self._scheme = challenge
        flow = self._schemes[challenge].auth_flow(request)
        if challenge == "digest":
            # Digest's flow first sends the request bare to read the challenge: hand it the one we have
            next(flow)
            sent = flow.send(response)
        else:
            sent = next(flow)
        while True:
            reply = yield sent
            try:
                sent = flow.send(reply)
            except StopIteration:
                return
