"""Third-party SPARQL clients in their default modes against the real service: SPARQLWrapper over its
whole format × query form × method matrix, rdflib's SPARQLStore with returnFormat="json", parse errors
at the user's line and column, and the service description behind a gateway."""
from __future__ import annotations

import csv
import io
import json
import re
import warnings
from typing import Any
from xml.dom.minidom import Document

import httpx
import pyoxigraph as ox
import pytest
import rdflib
from rdflib.plugins.stores.sparqlstore import SPARQLStore
from SPARQLWrapper import (
    CSV,
    GET,
    JSON,
    JSONLD,
    N3,
    POST,
    POSTDIRECTLY,
    RDF,
    RDFXML,
    TSV,
    TURTLE,
    URLENCODED,
    XML,
    SPARQLWrapper,
)

from nfex_core.kg.namespaces import PREFIXES

from .conftest import EDITOR, Service, assert_problem

NFEX = rdflib.Namespace("https://w3id.org/nfex#")
SD = rdflib.Namespace("http://www.w3.org/ns/sparql-service-description#")
QUERIES = {
    "SELECT": "SELECT ?x ?c WHERE { ?x a nfex:FeatureExtractor ; nfex:opencvConstructor ?c } ORDER BY ?x",
    "ASK": "ASK { nfex:ORB a nfex:FeatureExtractor }",
    "CONSTRUCT": "CONSTRUCT { nfex:ORB ?p ?o } WHERE { nfex:ORB ?p ?o }",
    "DESCRIBE": "DESCRIBE nfex:ORB",
}
# what SPARQLWrapper offers per query form (its returnFormat constants); rdf and json for a graph are its
# aliases of RDF/XML and JSON-LD
FORMATS = {"SELECT": [JSON, XML, CSV, TSV], "ASK": [JSON, XML, CSV, TSV],
           "CONSTRUCT": [TURTLE, N3, XML, RDFXML, RDF, JSONLD, JSON], "DESCRIBE": [TURTLE, N3, XML, RDFXML, RDF, JSONLD, JSON]}
METHODS = {"GET": (GET, URLENCODED), "POST-form": (POST, URLENCODED), "POST-direct": (POST, POSTDIRECTLY)}
MATRIX = [(form, fmt, m) for form, fmts in FORMATS.items() for fmt in fmts for m in METHODS]
ORB_CONSTRUCTOR = (NFEX.ORB, NFEX.opencvConstructor, rdflib.Literal("ORB_create"))


def _check_converted(form: str, fmt: str, value: Any) -> None:
    if form == "SELECT":
        if fmt == JSON:
            assert [b["c"]["value"] for b in value["results"]["bindings"]][2] == "ORB_create"
        elif fmt == XML:
            assert isinstance(value, Document) and len(value.getElementsByTagName("result")) == 5
        else:
            rows = list(csv.reader(io.StringIO(value.decode()), delimiter="," if fmt == CSV else "\t"))
            assert len(rows) == 6 and rows[0] in (["x", "c"], ["?x", "?c"])
    elif form == "ASK":
        if fmt == JSON:
            assert value["boolean"] is True
        elif fmt == XML:
            assert value.getElementsByTagName("boolean")[0].firstChild.data == "true"
        else:
            assert value.decode().strip() == "true"
    elif fmt in (TURTLE, N3):
        assert ORB_CONSTRUCTOR in rdflib.Graph().parse(data=value.decode(), format="turtle")
    else:  # SPARQLWrapper parsed RDF/XML or JSON-LD into an rdflib graph
        assert ORB_CONSTRUCTOR in value


@pytest.mark.parametrize("form,fmt,method", MATRIX, ids=[f"{a}-{b}-{c}" for a, b, c in MATRIX])
def test_sparqlwrapper_in_its_default_mode(service: Service, form: str, fmt: str, method: str) -> None:
    wrapper = SPARQLWrapper(service.url + "/sparql")
    assert wrapper.onlyConneg is False  # it sends format=, output= and results= beside Accept
    wrapper.setQuery(QUERIES[form])
    wrapper.setReturnFormat(fmt)
    wrapper.setMethod(METHODS[method][0])
    wrapper.setRequestMethod(METHODS[method][1])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = wrapper.query()
        converted = result.convert()
    mismatch = [str(w.message) for w in caught if "Format requested was" in str(w.message)]
    assert not mismatch, mismatch
    _check_converted(form, fmt, converted)


@pytest.mark.parametrize("method", ["GET", "POST", "POST_FORM"])
def test_rdflib_sparqlstore_with_json_results(service: Service, method: str) -> None:
    graph = rdflib.Graph(SPARQLStore(service.url + "/sparql", returnFormat="json", method=method))
    rows = list(graph.query(QUERIES["SELECT"]))
    assert len(rows) == 5 and str(rows[2][1]) == "ORB_create"
    assert graph.query(QUERIES["ASK"]).askAnswer is True
    constructed = graph.query(QUERIES["CONSTRUCT"]).graph  # asked with Accept: sparql-results+json
    assert constructed is not None and ORB_CONSTRUCTOR in constructed


def test_a_format_word_the_form_cannot_carry_falls_back_to_accept(service: Service) -> None:
    for fmt in ("yaml", "turtle", "image/png"):
        r = httpx.get(service.url + "/sparql", params={"query": QUERIES["SELECT"], "format": fmt}, headers={"accept": "text/csv"})
        assert r.status_code == 200 and r.headers["content-type"].startswith("text/csv"), (fmt, r.text[:200])
    r = httpx.get(service.url + "/sparql", params={"query": QUERIES["CONSTRUCT"], "output": "json"})
    assert r.headers["content-type"].startswith("application/ld+json")  # JSON, for a graph
    r = httpx.get(service.url + "/sparql", params={"query": QUERIES["SELECT"], "results": "text/tab-separated-values"})
    assert r.headers["content-type"].startswith("text/tab-separated-values")


BAD = {
    "query": ("SELECT ?x\nWHERE {\n  ?x nfex:role ?r ;\n     ?y }", "/sparql"),
    "update": ("INSERT DATA {\n  nfex:ORB rdfs:seeAlso\n}", "/sparql/update"),
}


def _oracle(text: str, kind: str) -> tuple[int, int]:
    """Where Oxigraph's parser puts the error with the prefixes declared out of band (no hidden lines)."""
    prefixes = {p: str(ns) for p, ns in PREFIXES.items()}
    try:
        (ox.Store().query if kind == "query" else ox.Store().update)(text, prefixes=prefixes)
    except SyntaxError as e:
        m = re.search(r"at (\d+):(\d+)", str(e))
        assert m, str(e)
        return int(m.group(1)), int(m.group(2))
    raise AssertionError("the text parsed")


@pytest.mark.parametrize("kind", ["query", "update"])
def test_parse_errors_name_the_users_line_and_column(service: Service, kind: str) -> None:
    _parse_error_names_line_and_column(service, kind)


@pytest.mark.parametrize("kind", ["query", "update"])
def test_parse_errors_name_the_users_line_and_column_over_a_sparql_server(remote_service: Service, kind: str) -> None:
    """The same positions where the graph lives in a SPARQL server (each kind the suite starts)."""
    _parse_error_names_line_and_column(remote_service, kind)


def _parse_error_names_line_and_column(svc: Service, kind: str) -> None:
    text, path = BAD[kind]
    line, column = _oracle(text, kind)
    assert line >= 3
    if kind == "query":
        r = httpx.post(svc.url + path, content=text, headers={"content-type": "application/sparql-query"})
    else:
        r = httpx.post(svc.url + path, content=text, headers={"content-type": "application/sparql-update", "authorization": f"Bearer {EDITOR}"})
    doc = assert_problem(r, 400, "parse-error")
    # the gate's parser names the position in the text as sent (no hidden PREFIX lines shift it); it may
    # stop a token before Oxigraph's parser does (at the missing term rather than at the next one)
    assert abs(doc["line"] - line) <= 1 and doc["line"] <= len(text.splitlines()), (doc["detail"], line, column)
    assert 1 <= doc["column"] <= len(text.splitlines()[doc["line"] - 1]) + 1
    assert f"{doc['line']}:{doc['column']}" in doc["detail"]


def _description(svc: Service, headers: dict[str, str] | None = None) -> rdflib.Graph:
    r = httpx.get(svc.url + "/sparql", headers=headers or {})
    assert r.status_code == 200 and r.headers["content-type"].startswith("text/turtle")
    return rdflib.Graph().parse(data=r.text, format="turtle")


def _endpoints(g: rdflib.Graph) -> dict[str, str]:
    return {str(g.value(s, SD.supportedLanguage)).rsplit("#", 1)[1]: str(g.value(s, SD.endpoint))
            for s in g.subjects(rdflib.RDF.type, SD.Service)}


def test_service_description_lists_query_and_update_endpoints(service: Service) -> None:
    assert _endpoints(_description(service)) == {"SPARQL11Query": service.url + "/sparql",
                                                 "SPARQL11Update": service.url + "/sparql/update"}


@pytest.mark.parametrize("headers,base", [
    ({"x-forwarded-proto": "https", "x-forwarded-host": "kg.example.org", "x-forwarded-port": "8443",
      "x-forwarded-prefix": "/nfex/"}, "https://kg.example.org:8443/nfex"),
    ({"host": "localhost", "x-forwarded-port": "8000"}, "http://localhost:8000"),           # nginx's $host drops the port
    ({"x-forwarded-host": "localhost:8000", "x-forwarded-port": "80"}, "http://localhost:8000"),  # compose: 8000 → 80
    ({"x-forwarded-proto": "https", "x-forwarded-host": "kg.example.org", "x-forwarded-port": "443"}, "https://kg.example.org"),
    ({"x-forwarded-host": "evil host/<x>", "host": "localhost:9"}, "http://localhost:9"),   # malformed: ignored
])
def test_service_description_behind_a_gateway(service: Service, headers: dict[str, str], base: str) -> None:
    assert _endpoints(_description(service, headers)) == {"SPARQL11Query": base + "/sparql", "SPARQL11Update": base + "/sparql/update"}


def test_service_description_in_json_ld(service: Service) -> None:
    r = httpx.get(service.url + "/sparql", headers={"accept": "application/ld+json"})
    assert r.headers["content-type"].startswith("application/ld+json")
    g = rdflib.Graph().parse(data=json.dumps(r.json()), format="json-ld")
    assert _endpoints(g)["SPARQL11Update"] == service.url + "/sparql/update"
    browser = httpx.get(service.url + "/sparql", headers={"accept": "text/html,application/xhtml+xml"})
    assert browser.status_code == 200 and browser.headers["content-type"].startswith("text/turtle")
