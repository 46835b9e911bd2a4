"""The SPARQL 1.1 Protocol endpoint: query forms, formats, service description, limits, read-only."""
from __future__ import annotations

import csv
import io
import json
import threading
import time

import httpx
import pytest
import rdflib

from .conftest import Service, assert_problem

SELECT = "SELECT ?x ?c WHERE { ?x a nfex:FeatureExtractor ; nfex:opencvConstructor ?c } ORDER BY ?x"
CONSTRUCT = "CONSTRUCT { nfex:ORB ?p ?o } WHERE { nfex:ORB ?p ?o }"
SLOW = "SELECT (COUNT(*) AS ?n) WHERE { ?a a nfex:ConditionValue . ?b ?p ?o . ?c ?q ?r }"  # ~3 s of work


def test_get_form_post_and_direct_post_agree(service: Service) -> None:
    a = httpx.get(service.url + "/sparql", params={"query": SELECT}).json()
    b = httpx.post(service.url + "/sparql", data={"query": SELECT}).json()
    c = httpx.post(service.url + "/sparql", content=SELECT, headers={"content-type": "application/sparql-query"}).json()
    assert a == b == c
    assert [r["x"]["value"].rsplit("#", 1)[1] for r in a["results"]["bindings"]] == ["AKAZE", "BRISK", "ORB", "ORB_GRID", "SIFT"]


@pytest.mark.parametrize("accept,media", [
    ("application/sparql-results+json", "application/sparql-results+json"),
    ("application/sparql-results+xml", "application/sparql-results+xml"),
    ("text/csv", "text/csv"),
    ("text/tab-separated-values", "text/tab-separated-values"),
    ("application/json", "application/sparql-results+json"),
    ("text/csv;q=0.5, application/sparql-results+xml;q=0.9", "application/sparql-results+xml"),
    ("*/*", "application/sparql-results+json"),
])
def test_select_formats_by_accept(service: Service, accept: str, media: str) -> None:
    r = httpx.get(service.url + "/sparql", params={"query": SELECT}, headers={"accept": accept})
    assert r.status_code == 200 and r.headers["content-type"].startswith(media)
    if media == "text/csv":
        rows = list(csv.reader(io.StringIO(r.text)))
        assert rows[0] == ["x", "c"] and len(rows) == 6  # header + 5 extractors


@pytest.mark.parametrize("accept,fmt", [("text/turtle", "turtle"), ("application/n-triples", "nt"), ("application/ld+json", "json-ld")])
def test_construct_formats_by_accept(service: Service, accept: str, fmt: str) -> None:
    r = httpx.get(service.url + "/sparql", params={"query": CONSTRUCT}, headers={"accept": accept})
    assert r.status_code == 200 and r.headers["content-type"].startswith(accept)
    g = rdflib.Graph().parse(data=r.text, format=fmt)
    assert (rdflib.URIRef("https://w3id.org/nfex#ORB"), rdflib.URIRef("https://w3id.org/nfex#opencvConstructor"), rdflib.Literal("ORB_create")) in g


def test_ask_and_unacceptable_format(service: Service) -> None:
    r = httpx.get(service.url + "/sparql", params={"query": "ASK { nfex:ORB a nfex:FeatureExtractor }"})
    assert r.json() == {"head": {}, "boolean": True}
    assert_problem(httpx.get(service.url + "/sparql", params={"query": CONSTRUCT}, headers={"accept": "text/csv"}), 406)


def test_service_description(service: Service) -> None:
    r = httpx.get(service.url + "/sparql")
    assert r.status_code == 200 and r.headers["content-type"].startswith("text/turtle")
    g = rdflib.Graph().parse(data=r.text, format="turtle")
    sd = rdflib.Namespace("http://www.w3.org/ns/sparql-service-description#")
    assert (None, rdflib.RDF.type, sd.Service) in g
    assert (None, sd.resultFormat, rdflib.URIRef("http://www.w3.org/ns/formats/SPARQL_Results_CSV")) in g


@pytest.mark.parametrize("kwargs,status", [
    ({"params": {"query": "SELEC ?x WHERE {}"}}, 400),
    ({"params": {"query": "SELECT ?x WHERE { ?x ?y }"}}, 400),
    ({"params": {"query": "INSERT DATA { nfex:a nfex:b nfex:c }"}}, 400),
    ({"params": {"query": "DROP ALL"}}, 400),
    ({"params": {"query": ""}}, 400),
    ({"params": {"query": SELECT, "default-graph-uri": "urn:x"}}, 400),
])
def test_invalid_queries_and_updates_are_400(service: Service, kwargs: dict, status: int) -> None:  # type: ignore[type-arg]
    before = service.version()
    assert_problem(httpx.get(service.url + "/sparql", **kwargs), status)
    assert service.version() == before


def test_post_update_form_and_wrong_media_are_refused(service: Service) -> None:
    assert_problem(httpx.post(service.url + "/sparql", data={"update": "INSERT DATA { nfex:a nfex:b nfex:c }"}), 400)
    assert_problem(httpx.post(service.url + "/sparql", content=SELECT, headers={"content-type": "text/plain"}), 415)


def test_time_limit_answers_503_and_does_not_block_the_worker(service: Service) -> None:
    result: dict[str, httpx.Response] = {}

    def slow() -> None:
        result["r"] = httpx.get(service.url + "/sparql", params={"query": SLOW}, timeout=60)

    thread = threading.Thread(target=slow)
    thread.start()
    time.sleep(0.2)  # the slow query goes first
    # while the slow query runs, the same worker answers other requests: the selection is answered before it
    r = httpx.post(service.url + "/v1/select", json={"context": {"agent": "car"}}, timeout=5)
    assert r.status_code == 200
    assert thread.is_alive() and "r" not in result, "the selection waited for the slow query"
    thread.join()
    doc = assert_problem(result["r"], 503, "query-limit")  # cut by the time limit, not finished
    assert doc["limit"] == "time"


def test_result_size_limit_answers_503(service: Service) -> None:
    doc = assert_problem(httpx.get(service.url + "/sparql", params={"query": "SELECT * WHERE { GRAPH ?g { ?s ?p ?o } }"}), 503, "query-limit")
    assert doc["limit"] == "result-size"
    ok = httpx.get(service.url + "/sparql", params={"query": "SELECT * WHERE { GRAPH ?g { ?s ?p ?o } } LIMIT 10"})
    assert len(json.loads(ok.text)["results"]["bindings"]) == 10
