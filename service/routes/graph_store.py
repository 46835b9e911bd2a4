"""SPARQL 1.1 Graph Store HTTP Protocol at ``/sparql/graph`` (indirect graph identification, §4.2).

- ``?default`` is the knowledge (the default graph). ``GET`` (and ``HEAD``) serialises it in Turtle,
  N-Triples, JSON-LD or RDF/XML by ``Accept`` (§5.2), with ``ETag: "<graph version>"``. With an editor
  token, ``PUT`` replaces it with the body (§5.3), ``POST`` merges the body into it (§5.5) and ``DELETE``
  empties it (§5.4) — each one transaction through ``KnowledgeGraph.commit``, like every other write: the
  change set is computed, SHACL-checked on the nodes it touches and committed as a new graph version, or
  refused (422 with the report) leaving the graph unchanged; ``If-Match`` pins the version.
- ``?graph=<iri>`` names a named graph: the version history (``urn:nfex:meta``,
  ``urn:nfex:version:N:added|removed``), written only by commits, so ``GET``/``HEAD`` only (404 for a
  graph that holds nothing; writes 405).

A read is the whole graph, as ``nfex kg export`` gives it: the time limit of SPARQL queries applies, their
result-size limit does not (it bounds ad-hoc queries, not the graph the service holds).
"""
from __future__ import annotations

import sys
from typing import Annotated
from urllib.parse import parse_qs, urlparse

from fastapi import APIRouter, Header, Request, Response
from fastapi.concurrency import run_in_threadpool
from rdflib.term import URIRef

from nfex_core.errors import BadInput, NfexError, NotFound, PreconditionFailed
from nfex_core.kg import ChangeSet, CommitResult, KnowledgeGraph, graph_triples
from nfex_core.kg.rdf.terms import Triple, n3
from nfex_core.kg.storage.backends import GRAPH_FORMATS

from ..deps import EditorDep, IfMatchDep, KGDep
from ..editing import RDF_BODY, rdf_body
from ..negotiation import negotiate
from ..schemas import PROBLEM_RESPONSES, WriteResult, problems

router = APIRouter(prefix="/sparql/graph", tags=["sparql"])
TARGET = [
    {"name": "default", "in": "query", "required": False, "allowEmptyValue": True, "schema": {"type": "string"},
     "description": "The default graph (the knowledge): give `?default` or `graph`, not both"},
    {"name": "graph", "in": "query", "required": False, "schema": {"type": "string", "format": "iri"},
     "description": "A named graph's IRI (the version history; read-only)"},
]
RDF_CONTENT = {m: {"schema": {"type": "string"}} for m in GRAPH_FORMATS}
WRITE_BODY = {"requestBody": {"required": True, "content": {m: {"schema": {"type": "string"}} for m in RDF_BODY}}}
ATTEMPTS = 3


class ReadOnlyGraph(NfexError):
    status = 405
    type = "read-only-graph"
    title = "Method not allowed"
    exit_code = 2
    headers = {"Allow": "GET, HEAD, OPTIONS"}


def target(request: Request) -> URIRef | None:
    """The graph the request names: None for ``?default``, else the ``graph`` IRI (§4.2)."""
    params = parse_qs(request.url.query, keep_blank_values=True)
    graphs = params.get("graph", [])
    if ("default" in params) == bool(graphs) or len(graphs) > 1:
        raise BadInput("name one graph: ?default, or ?graph=<iri>")
    if not graphs:
        return None
    iri = graphs[0]
    if not urlparse(iri).scheme or any(c in iri for c in ' <>"{}|\\^`'):
        raise BadInput(f"graph must be an absolute IRI, not {iri!r}")
    return URIRef(iri)


def _default_only(request: Request) -> None:
    if target(request) is not None:
        raise ReadOnlyGraph("named graphs hold the version history and change only by commits; write to ?default")


@router.get("", summary="Read the default graph (?default) or a named graph (?graph=<iri>)",
            openapi_extra={"parameters": TARGET}, responses={200: {"content": RDF_CONTENT}, **PROBLEM_RESPONSES, **problems(406)},
            response_class=Response)
async def read(request: Request, kg: KGDep, accept: Annotated[str | None, Header()] = None) -> Response:
    graph = target(request)
    media = negotiate(accept, "construct")
    if graph is None:
        query = "CONSTRUCT { ?s ?p ?o } WHERE { ?s ?p ?o }"
    else:
        if not await run_in_threadpool(kg.backend.ask, f"ASK {{ GRAPH {n3(graph)} {{ ?s ?p ?o }} }}"):
            raise NotFound(f"no graph {graph} in the store; the service description lists the named graphs")
        query = f"CONSTRUCT {{ ?s ?p ?o }} WHERE {{ GRAPH {n3(graph)} {{ ?s ?p ?o }} }}"
    version = kg.version
    outcome = await request.app.state.queries.run(query, media, max_bytes=sys.maxsize)
    return Response(outcome.body, media_type=outcome.media, headers={"ETag": f'"{version}"'})


def _replace(kg: KnowledgeGraph, new: frozenset[Triple], author: str, message: str, expected: int | None) -> CommitResult:
    """Replace the default graph's triples by ``new``, diffed against the version read (retried if it moved)."""
    for attempt in range(ATTEMPTS):
        head = kg.version
        old = graph_triples(kg.data_graph())
        if kg.version != head:
            continue
        try:
            return kg.commit(ChangeSet.of(added=new - old, removed=old - new), author=author, message=message,
                             expected_version=head if expected is None else expected)
        except PreconditionFailed:
            if expected is not None or attempt == ATTEMPTS - 1:
                raise
    raise PreconditionFailed("the graph kept changing while it was read; retry", current_version=kg.version)


@router.put("", summary="Replace the default graph with the body (editor)", response_model=WriteResult,
            openapi_extra={"parameters": TARGET, **WRITE_BODY}, responses={**PROBLEM_RESPONSES, **problems(405, 409, 412, 415)})
async def put(request: Request, kg: KGDep, token: EditorDep, expected: IfMatchDep) -> Response:
    _default_only(request)
    new = graph_triples(await rdf_body(request))
    if not new:
        raise BadInput("the body holds no triples; DELETE /sparql/graph?default empties the graph")
    result = await run_in_threadpool(_replace, kg, new, token.name, "graph store: PUT default graph", expected)
    return WriteResult.of(result).response()


@router.post("", summary="Merge the body into the default graph (editor)", response_model=WriteResult,
             openapi_extra={"parameters": TARGET, **WRITE_BODY}, responses={**PROBLEM_RESPONSES, **problems(405, 409, 412, 415)})
async def post(request: Request, kg: KGDep, token: EditorDep, expected: IfMatchDep) -> Response:
    _default_only(request)
    added = graph_triples(await rdf_body(request))
    result = await run_in_threadpool(kg.commit, ChangeSet.adding(added), author=token.name,
                                     message="graph store: POST to default graph", expected_version=expected)
    return WriteResult.of(result).response()


@router.delete("", summary="Empty the default graph (editor; a new version, undone by a rollback)", response_model=WriteResult,
               openapi_extra={"parameters": TARGET}, responses={**PROBLEM_RESPONSES, **problems(405, 409, 412)})
async def delete(request: Request, kg: KGDep, token: EditorDep, expected: IfMatchDep) -> Response:
    _default_only(request)
    result = await run_in_threadpool(_replace, kg, frozenset(), token.name, "graph store: DELETE default graph", expected)
    return WriteResult.of(result).response()
