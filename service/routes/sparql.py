"""The SPARQL 1.1 Protocol endpoint (read-only) and SPARQL 1.1 Update behind an editor token.

Query by ``GET /sparql?query=…``, by form ``POST`` (``query=…``) or by ``POST`` with
``Content-Type: application/sparql-query``. SELECT/ASK answer in JSON, XML, CSV or TSV and
CONSTRUCT/DESCRIBE in Turtle, N-Triples, JSON-LD or RDF/XML, by ``Accept`` (or ``?format=``).
nFEX's prefixes (nfex:, sosa:, prov:, …) are predeclared. ``GET /sparql`` without a query returns the
service description (SPARQL 1.1 Service Description, Turtle or JSON-LD).
"""
from __future__ import annotations

from typing import Annotated
from urllib.parse import parse_qs

import rdflib
from fastapi import APIRouter, Header, Request
from fastapi.concurrency import run_in_threadpool
from fastapi.responses import Response
from rdflib.namespace import RDF

from nfex_core.errors import BadInput
from nfex_core.kg.backends import GRAPH_FORMATS, RESULT_FORMATS
from nfex_core.kg.sparql_guard import refuse_unsafe_query
from nfex_core.kg.sparql_query import classify, with_prefixes

from ..bodies import media_type, utf8_text
from ..deps import EditorDep, IfMatchDep, KGDep
from ..images import UnsupportedMediaType
from ..schemas import WriteResult
from ..sparql_exec import FORMAT_PARAM, negotiate

router = APIRouter(tags=["sparql"])
SD = rdflib.Namespace("http://www.w3.org/ns/sparql-service-description#")
FORMAT_IRIS = {
    "application/sparql-results+json": "http://www.w3.org/ns/formats/SPARQL_Results_JSON",
    "application/sparql-results+xml": "http://www.w3.org/ns/formats/SPARQL_Results_XML",
    "text/csv": "http://www.w3.org/ns/formats/SPARQL_Results_CSV",
    "text/tab-separated-values": "http://www.w3.org/ns/formats/SPARQL_Results_TSV",
    "text/turtle": "http://www.w3.org/ns/formats/Turtle",
    "application/n-triples": "http://www.w3.org/ns/formats/N-Triples",
    "application/ld+json": "http://www.w3.org/ns/formats/JSON-LD",
    "application/rdf+xml": "http://www.w3.org/ns/formats/RDF_XML",
}
QUERY_EXAMPLES = {
    "parameters": {"summary": "every parameter and its role", "value": "SELECT ?p ?role WHERE { ?p a nfex:Parameter ; nfex:role/nfex:token ?role }"}
}


def service_description(request: Request, accept: str | None) -> Response:
    g = rdflib.Graph()
    g.bind("sd", SD)
    s = rdflib.URIRef(str(request.url_for("sparql_get")))
    g.add((s, RDF.type, SD.Service))
    g.add((s, SD.endpoint, s))
    g.add((s, SD.supportedLanguage, SD.SPARQL11Query))
    for media in list(RESULT_FORMATS) + list(GRAPH_FORMATS):
        g.add((s, SD.resultFormat, rdflib.URIRef(FORMAT_IRIS[media])))
    ds = rdflib.URIRef(str(s) + "#dataset")
    g.add((s, SD.defaultDataset, ds))
    g.add((ds, RDF.type, SD.Dataset))
    g.add((ds, rdflib.namespace.RDFS.comment, rdflib.Literal(
        "The default graph holds nFEX's knowledge; named graphs urn:nfex:meta and urn:nfex:version:N:added|removed hold the version history. Read-only; updates go to /sparql/update with an editor token."
    )))
    media = negotiate(accept, "describe") if accept and "json" in accept else "text/turtle"
    fmt = {"text/turtle": "turtle", "application/n-triples": "nt", "application/ld+json": "json-ld", "application/rdf+xml": "xml"}[media]
    return Response(g.serialize(format=fmt), media_type=media)


async def _answer(request: Request, query: str | None, accept: str | None, fmt: str | None, params: dict[str, list[str]]) -> Response:
    if query is None:
        return service_description(request, accept)
    if params.get("default-graph-uri") or params.get("named-graph-uri"):
        raise BadInput("default-graph-uri / named-graph-uri are not supported: the dataset is fixed (see the service description)")
    if not query.strip():
        raise BadInput("the query is empty")
    form = classify(query)
    refuse_unsafe_query(query)
    if fmt is not None:
        if fmt not in FORMAT_PARAM:
            raise BadInput(f"unknown format {fmt!r}; known: {', '.join(FORMAT_PARAM)}")
        accept = FORMAT_PARAM[fmt]
    media = negotiate(accept, form)
    outcome = await request.app.state.queries.run(with_prefixes(query), media)
    request.app.state.metrics.sparql_queries.labels(form).inc()
    return Response(outcome.body, media_type=outcome.media, headers={"X-Query-Ms": f"{outcome.elapsed_ms:.3f}"})


@router.get(
    "/sparql",
    name="sparql_get",
    summary="SPARQL 1.1 query (GET), or the service description without ?query",
    openapi_extra={"parameters": [{"name": "query", "in": "query", "required": False, "schema": {"type": "string"}, "examples": QUERY_EXAMPLES}]},
    responses={200: {"content": {m: {} for m in list(RESULT_FORMATS) + list(GRAPH_FORMATS)}}},
)
async def sparql_get(request: Request, accept: Annotated[str | None, Header()] = None) -> Response:
    params = parse_qs(request.url.query, keep_blank_values=True)
    query = params.get("query", [None])[-1]
    return await _answer(request, query, accept, params.get("format", [None])[-1], params)


async def _body_text(request: Request, field: str, direct: str) -> tuple[str | None, dict[str, list[str]]]:
    media = media_type(request.headers.get("content-type"))
    text = await utf8_text(request, "the body")
    if media == direct:
        return text, parse_qs(request.url.query)
    if media == "application/x-www-form-urlencoded":
        params = parse_qs(text, keep_blank_values=True)
        return params.get(field, [None])[-1], params
    raise UnsupportedMediaType(f"POST a {field} as {direct} or application/x-www-form-urlencoded, not {media or 'nothing'!r}")


@router.post(
    "/sparql",
    summary="SPARQL 1.1 query (POST: form or application/sparql-query)",
    openapi_extra={"requestBody": {"content": {"application/sparql-query": {"schema": {"type": "string"}, "examples": QUERY_EXAMPLES},
                                               "application/x-www-form-urlencoded": {"schema": {"type": "object", "properties": {"query": {"type": "string"}}}}}}},
    responses={200: {"content": {m: {} for m in list(RESULT_FORMATS) + list(GRAPH_FORMATS)}}},
)
async def sparql_post(request: Request, accept: Annotated[str | None, Header()] = None) -> Response:
    query, params = await _body_text(request, "query", "application/sparql-query")
    if query is None:
        if "update" in params:
            raise BadInput("this endpoint is read-only; POST SPARQL Update to /sparql/update with an editor token")
        raise BadInput("no query: send query=… or a body of type application/sparql-query")
    return await _answer(request, query, accept, params.get("format", [None])[-1], params)


@router.post(
    "/sparql/update",
    summary="SPARQL 1.1 Update as one SHACL-checked, versioned transaction (editor token)",
    status_code=200,
    response_model=WriteResult,
    openapi_extra={"requestBody": {"content": {"application/sparql-update": {"schema": {"type": "string"},
        "example": "INSERT DATA { nfex:ORB rdfs:seeAlso <https://docs.opencv.org> }"}}}},
)
async def sparql_update(request: Request, kg: KGDep, token: EditorDep, expected: IfMatchDep) -> Response:
    query, params = await _body_text(request, "update", "application/sparql-update")
    if not query or not query.strip():
        raise BadInput("no update: send update=… or a body of type application/sparql-update")
    message = params.get("message", ["SPARQL update"])[-1]
    result = await run_in_threadpool(
        kg.update, with_prefixes(query), author=token.name, message=message, expected_version=expected
    )
    return WriteResult.of(result).response()
