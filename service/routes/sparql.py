"""The SPARQL 1.1 Protocol endpoint (read-only) and SPARQL 1.1 Update behind an editor token.

Query by ``GET /sparql?query=…``, by form ``POST`` (``query=…``) or by ``POST`` with
``Content-Type: application/sparql-query``. SELECT/ASK answer in JSON, XML, CSV or TSV and
CONSTRUCT/DESCRIBE in Turtle, N-Triples, JSON-LD or RDF/XML, by ``Accept`` or ``format=``/``output=``/
``results=`` (service/negotiation.py). nFEX's prefixes (nfex:, sosa:, prov:, …) are predeclared; parse
errors give the line and column in the query as sent. ``GET /sparql`` without a query returns the
service description (SPARQL 1.1 Service Description), which names the query, update and graph store
endpoints with the URLs the client used (``X-Forwarded-*`` honoured, service/urls.py).
"""
from __future__ import annotations

from typing import Annotated
from urllib.parse import parse_qs

import rdflib
from fastapi import APIRouter, Header, Request
from fastapi.concurrency import run_in_threadpool
from fastapi.responses import Response
from rdflib.namespace import RDF, RDFS

from nfex_core.errors import BadInput, ParseError
from nfex_core.kg.storage.backends import GRAPH_FORMATS, RESULT_FORMATS
from nfex_core.kg.storage.sparql_gate import gate_query
from nfex_core.kg.storage.sparql_query import at_user_lines, with_prefixes

from ..bodies import media_type, utf8_text
from ..deps import EditorDep, IfMatchDep, KGDep
from ..images import UnsupportedMediaType
from ..negotiation import FORMAT_PARAMS, NotAcceptable, from_format_params, negotiate
from ..schemas import PROBLEM_RESPONSES, WriteResult, problems
from ..urls import public_url

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
RDFLIB_FORMATS = {"text/turtle": "turtle", "application/n-triples": "nt", "application/ld+json": "json-ld",
                  "application/rdf+xml": "xml"}
QUERY_EXAMPLES = {
    "parameters": {"summary": "every parameter and its role", "value": "SELECT ?p ?role WHERE { ?p a nfex:Parameter ; nfex:role/nfex:token ?role }"}
}
RESULTS_DOC = {
    200: {
        "description": "SELECT/ASK results or a CONSTRUCT/DESCRIBE graph; without a query, the service description",
        "content": {
            **{m: {"schema": {"type": "string"}} for m in list(RESULT_FORMATS) + list(GRAPH_FORMATS)},
            "application/sparql-results+json": {"schema": {"$ref": "#/components/schemas/SparqlResults"}},
        },
    },
    **PROBLEM_RESPONSES,
    **problems(406, 415),
}


def service_description(request: Request, accept: str | None) -> Response:
    """SPARQL 1.1 Service Description: the query service, the update service, the dataset."""
    g = rdflib.Graph()
    g.bind("sd", SD)
    s = rdflib.URIRef(public_url(request, "/sparql"))
    update = rdflib.URIRef(public_url(request, "/sparql/update"))
    store = rdflib.URIRef(public_url(request, "/sparql/graph"))
    g.add((s, RDF.type, SD.Service))
    g.add((s, SD.endpoint, s))
    g.add((s, SD.supportedLanguage, SD.SPARQL11Query))
    for media in list(RESULT_FORMATS) + list(GRAPH_FORMATS):
        g.add((s, SD.resultFormat, rdflib.URIRef(FORMAT_IRIS[media])))
    g.add((update, RDF.type, SD.Service))
    g.add((update, SD.endpoint, update))
    g.add((update, SD.supportedLanguage, SD.SPARQL11Update))
    g.add((update, RDFS.comment, rdflib.Literal(
        "Each update is one SHACL-checked, versioned transaction; needs Authorization: Bearer <token> with the editor role.")))
    g.add((s, RDFS.seeAlso, store))
    g.add((store, RDFS.comment, rdflib.Literal(
        "SPARQL 1.1 Graph Store HTTP Protocol: ?default (the knowledge; GET, and PUT/POST/DELETE with an editor token) "
        "and ?graph=<iri> (the version history, read-only).")))
    ds = rdflib.URIRef(str(s) + "#dataset")
    for service in (s, update):
        g.add((service, SD.defaultDataset, ds))
    g.add((ds, RDF.type, SD.Dataset))
    g.add((ds, RDFS.comment, rdflib.Literal(
        "The default graph holds nFEX's knowledge; named graphs urn:nfex:meta and urn:nfex:version:N:added|removed hold "
        "the version history. Queries here are read-only; updates go to the update endpoint.")))
    try:
        media = negotiate(accept, "describe") if accept else "text/turtle"
    except NotAcceptable:
        media = "text/turtle"  # a browser's text/html: the description in its default format
    return Response(g.serialize(format=RDFLIB_FORMATS[media]), media_type=media)


async def _answer(request: Request, query: str | None, accept: str | None, params: dict[str, list[str]]) -> Response:
    if query is None:
        return service_description(request, accept)
    if params.get("default-graph-uri") or params.get("named-graph-uri"):
        raise BadInput("default-graph-uri / named-graph-uri are not supported: the dataset is fixed (see the service description)")
    form = gate_query(query).form
    asked = [v for name in FORMAT_PARAMS for v in params.get(name, [])]
    media = from_format_params(asked, form) or negotiate(accept, form)
    try:
        outcome = await request.app.state.queries.run(with_prefixes(query), media)
    except ParseError as e:
        raise at_user_lines(e, query) from None
    request.app.state.metrics.sparql_queries.labels(form).inc()
    return Response(outcome.body, media_type=outcome.media, headers={"X-Query-Ms": f"{outcome.elapsed_ms:.3f}"})


@router.get(
    "/sparql",
    name="sparql_get",
    summary="SPARQL 1.1 query (GET), or the service description without ?query",
    openapi_extra={"parameters": [
        {"name": "query", "in": "query", "required": False, "schema": {"type": "string"}, "examples": QUERY_EXAMPLES},
        *({"name": p, "in": "query", "required": False, "schema": {"type": "string"},
           "description": "A format word (json, xml, csv, tsv, turtle, n3, json-ld, rdf+xml) or media type; "
           "one this query form cannot carry is ignored"} for p in FORMAT_PARAMS),
    ]},
    responses=RESULTS_DOC,
    response_class=Response,
)
async def sparql_get(request: Request, accept: Annotated[str | None, Header()] = None) -> Response:
    params = parse_qs(request.url.query, keep_blank_values=True)
    return await _answer(request, params.get("query", [None])[-1], accept, params)


async def _body_text(request: Request, field: str, direct: str) -> tuple[str | None, dict[str, list[str]]]:
    """The query (or update) and every parameter: the URL's and, for a form, the body's."""
    media = media_type(request.headers.get("content-type"))
    text = await utf8_text(request, "the body")
    params = parse_qs(request.url.query, keep_blank_values=True)
    if media == direct:
        return text, params
    if media == "application/x-www-form-urlencoded":
        for name, values in parse_qs(text, keep_blank_values=True).items():
            params.setdefault(name, []).extend(values)
        return params.get(field, [None])[-1], params
    raise UnsupportedMediaType(f"POST a {field} as {direct} or application/x-www-form-urlencoded, not {media or 'nothing'!r}")


@router.post(
    "/sparql",
    summary="SPARQL 1.1 query (POST: form or application/sparql-query)",
    openapi_extra={"requestBody": {"content": {"application/sparql-query": {"schema": {"type": "string"}, "examples": QUERY_EXAMPLES},
                                               "application/x-www-form-urlencoded": {"schema": {"type": "object", "properties": {
                                                   "query": {"type": "string"}, "format": {"type": "string"}}}}}}},
    responses=RESULTS_DOC,
    response_class=Response,
)
async def sparql_post(request: Request, accept: Annotated[str | None, Header()] = None) -> Response:
    query, params = await _body_text(request, "query", "application/sparql-query")
    if query is None:
        if "update" in params:
            raise BadInput("this endpoint is read-only; POST SPARQL Update to /sparql/update with an editor token")
        raise BadInput("no query: send query=… or a body of type application/sparql-query")
    return await _answer(request, query, accept, params)


@router.post(
    "/sparql/update",
    summary="SPARQL 1.1 Update as one SHACL-checked, versioned transaction (editor token)",
    status_code=200,
    response_model=WriteResult,
    responses={**PROBLEM_RESPONSES, **problems(409, 412, 415)},
    openapi_extra={"requestBody": {"content": {"application/sparql-update": {"schema": {"type": "string"},
        "example": "INSERT DATA { nfex:ORB rdfs:seeAlso <https://docs.opencv.org> }"}}}},
)
async def sparql_update(request: Request, kg: KGDep, token: EditorDep, expected: IfMatchDep) -> Response:
    query, params = await _body_text(request, "update", "application/sparql-update")
    if not query or not query.strip():
        raise BadInput("no update: send update=… or a body of type application/sparql-update")
    message = params.get("message", ["SPARQL update"])[-1]
    try:
        result = await run_in_threadpool(
            kg.update, with_prefixes(query), author=token.name, message=message, expected_version=expected
        )
    except ParseError as e:
        raise at_user_lines(e, query) from None
    return WriteResult.of(result).response()

