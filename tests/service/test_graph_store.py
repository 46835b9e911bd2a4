"""The SPARQL 1.1 Graph Store HTTP Protocol at /sparql/graph on a service of its own (these tests replace
and empty the default graph): reading with content negotiation, and writes through the same versioned,
SHACL-checked transactions as every other edit — a rejected write leaves the graph exactly as it was."""
from __future__ import annotations

import json
import shutil
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest
import rdflib

from tests.conftest import stop_process

from .conftest import EDITOR, READER, Service, assert_problem, auth, start_service

NFEX = rdflib.Namespace("https://w3id.org/nfex#")
GSP = "/sparql/graph"
DEFAULT = {"default": ""}
BAD_CONFIG = """@prefix nfex: <https://w3id.org/nfex#> .
nfex:cfg_gsp_bad a nfex:Configuration ; nfex:ofExtractor nfex:ORB ; nfex:hasSetting nfex:cfg_gsp_bad_sf .
nfex:cfg_gsp_bad_sf a nfex:ParameterSetting ; nfex:parameter nfex:ORB_scaleFactor ; nfex:value 0.5 .
"""
SEE_ALSO = (NFEX.ORB, rdflib.RDFS.seeAlso, rdflib.URIRef("https://docs.opencv.org/5.x/db/d95/classcv_1_1ORB.html"))


@pytest.fixture(scope="module")
def store_service(seeded_template: Path, tmp_path_factory: pytest.TempPathFactory) -> Iterator[Service]:
    folder = tmp_path_factory.mktemp("graph-store")
    shutil.copytree(seeded_template, folder / "store", ignore=shutil.ignore_patterns("LOCK"))
    svc = start_service(str(folder / "store"), folder / "service.log")
    yield svc
    stop_process(svc.proc)


def ntriples(triples: set) -> str:  # type: ignore[type-arg]
    g = rdflib.Graph()
    for t in triples:
        g.add(t)
    return g.serialize(format="nt")


def read(svc: Service, accept: str = "application/n-triples", **params: str) -> tuple[rdflib.Graph, httpx.Response]:
    r = httpx.get(svc.url + GSP, params=params or DEFAULT, headers={"accept": accept}, timeout=60)
    assert r.status_code == 200, r.text[:300]
    fmt = {"text/turtle": "turtle", "application/n-triples": "nt", "application/ld+json": "json-ld", "application/rdf+xml": "xml"}
    data = json.dumps(r.json()) if accept == "application/ld+json" else r.text
    return rdflib.Graph().parse(data=data, format=fmt[accept]), r


@pytest.mark.parametrize("accept", ["text/turtle", "application/n-triples", "application/ld+json", "application/rdf+xml"])
def test_get_the_default_graph_in_each_format(store_service: Service, accept: str) -> None:
    graph, r = read(store_service, accept)
    assert r.headers["content-type"].startswith(accept) and r.headers["etag"] == f'"{store_service.version()}"'
    assert (NFEX.ORB, NFEX.opencvConstructor, rdflib.Literal("ORB_create")) in graph
    assert len(graph) == httpx.get(store_service.url + "/v1/graph").json()["triples"]


def test_get_a_named_graph_and_the_errors(store_service: Service) -> None:
    meta, _ = read(store_service, "text/turtle", graph="urn:nfex:meta")
    assert (rdflib.URIRef("urn:nfex:version:1"), rdflib.RDF.type, NFEX.GraphVersion) in meta
    assert_problem(httpx.get(store_service.url + GSP, params={"graph": "urn:nfex:nothing"}), 404)
    assert_problem(httpx.get(store_service.url + GSP), 400)
    assert_problem(httpx.get(store_service.url + GSP, params={"default": "", "graph": "urn:nfex:meta"}), 400)
    assert_problem(httpx.get(store_service.url + GSP, params={"graph": "not an iri"}), 400)
    assert_problem(httpx.get(store_service.url + GSP, params=DEFAULT, headers={"accept": "text/csv"}), 406)
    head = httpx.head(store_service.url + GSP, params=DEFAULT)
    assert head.status_code == 200 and head.content == b"" and int(head.headers["content-length"]) > 1000


def test_writes_need_an_editor_and_named_graphs_are_read_only(store_service: Service) -> None:
    before = store_service.version()
    body = {"content": "<urn:x> <urn:y> <urn:z> .", "headers": {"content-type": "application/n-triples"}}
    assert_problem(httpx.post(store_service.url + GSP, params=DEFAULT, **body), 401)
    r = httpx.post(store_service.url + GSP, params=DEFAULT, content=body["content"],
                   headers={**body["headers"], **auth(READER)})
    assert_problem(r, 403)
    r = httpx.put(store_service.url + GSP, params={"graph": "urn:nfex:meta"}, content=body["content"],
                  headers={**body["headers"], **auth()})
    assert_problem(r, 405, "read-only-graph")
    assert r.headers["allow"] == "GET, HEAD, OPTIONS"
    r = httpx.post(store_service.url + GSP, params=DEFAULT, content=body["content"], headers={"content-type": "text/csv", **auth()})
    assert_problem(r, 415)
    assert store_service.version() == before


def test_post_merges_and_a_rejected_post_changes_nothing(store_service: Service) -> None:
    before, _ = read(store_service)
    version = store_service.version()
    r = httpx.post(store_service.url + GSP, params=DEFAULT, content=BAD_CONFIG, headers={"content-type": "text/turtle", **auth()})
    doc = assert_problem(r, 422, "shacl-violation")
    assert "ConfigurationShape" in doc["detail"]
    after, _ = read(store_service)
    assert store_service.version() == version and set(after) == set(before)

    triple = " ".join(t.n3() for t in SEE_ALSO) + " ."
    r = httpx.post(store_service.url + GSP, params=DEFAULT, content=triple, headers={"content-type": "application/n-triples", **auth()})
    assert r.status_code == 200, r.text
    assert r.json() == {"version": version + 1, "changed": True, "added": 1, "removed": 0, "iri": None}
    assert r.headers["etag"] == f'"{version + 1}"'
    merged, _ = read(store_service)
    assert set(merged) == set(before) | {SEE_ALSO}


def test_put_replaces_and_a_rejected_put_changes_nothing(store_service: Service) -> None:
    before, _ = read(store_service)
    version = store_service.version()
    label = next(t for t in before.triples((NFEX.BRISK, rdflib.RDFS.label, None)))
    wanted = set(before) - {label} | {(NFEX.BRISK, rdflib.RDFS.label, rdflib.Literal("BRISK (binary robust invariant)"))}
    body = ntriples(wanted)

    stale = httpx.put(store_service.url + GSP, params=DEFAULT, content=body,
                      headers={"content-type": "application/n-triples", "if-match": f'"{version - 1}"', **auth()})
    assert_problem(stale, 412)
    bad = body + rdflib.Graph().parse(data=BAD_CONFIG, format="turtle").serialize(format="nt")
    assert_problem(httpx.put(store_service.url + GSP, params=DEFAULT, content=bad,
                             headers={"content-type": "application/n-triples", **auth()}), 422, "shacl-violation")
    unchanged, _ = read(store_service)
    assert store_service.version() == version and set(unchanged) == set(before)

    r = httpx.put(store_service.url + GSP, params=DEFAULT, content=body,
                  headers={"content-type": "application/n-triples", "if-match": f'"{version}"', **auth()}, timeout=120)
    assert r.status_code == 200, r.text
    assert (r.json()["added"], r.json()["removed"]) == (1, 1)
    replaced, _ = read(store_service)
    assert set(replaced) == wanted
    history = httpx.get(store_service.url + f"/v1/graph/versions/{version + 1}").json()
    assert history["message"] == "graph store: PUT default graph" and history["author"] == "alice"


def test_delete_of_the_whole_graph_is_refused_by_the_core_shape_and_changes_nothing(store_service: Service) -> None:
    """Emptying the knowledge would leave nothing to select from: nfex:CoreShape refuses it like CLEAR DEFAULT."""
    before, _ = read(store_service)
    version = store_service.version()
    assert_problem(httpx.put(store_service.url + GSP, params=DEFAULT, content="", headers={"content-type": "text/turtle", **auth()}), 400)
    doc = assert_problem(httpx.delete(store_service.url + GSP, params=DEFAULT, headers=auth(EDITOR), timeout=120), 422)
    assert "CoreShape" in json.dumps(doc)
    assert store_service.version() == version and set(read(store_service)[0]) == set(before)
