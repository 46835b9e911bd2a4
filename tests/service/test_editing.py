"""Editing behind bearer tokens: SPARQL Update, REST resources, versions; SHACL 422s, If-Match 412s."""
from __future__ import annotations

import httpx
import pytest

from .conftest import READER, Service, assert_problem, auth

INSERT = "INSERT DATA { nfex:ORB rdfs:seeAlso <https://docs.opencv.org/%d> }"
UPDATE = {"content-type": "application/sparql-update"}


@pytest.mark.parametrize("headers,status,slug", [
    ({}, 401, "unauthorized"),
    ({"Authorization": "Bearer wrong"}, 401, "unauthorized"),
    ({"Authorization": "Basic YWxpY2U6eA=="}, 401, "unauthorized"),
    (auth(READER), 403, "forbidden"),
])
def test_writes_need_an_editor_token(service: Service, headers: dict, status: int, slug: str) -> None:  # type: ignore[type-arg]
    before = service.version()
    assert_problem(httpx.post(service.url + "/sparql/update", content=INSERT % 1, headers={**UPDATE, **headers}), status, slug)
    assert_problem(httpx.post(service.url + "/v1/graph/rollback", json={"to": 1}, headers=headers), status, slug)
    assert_problem(httpx.put(service.url + "/v1/rules/x", json={"label": "x", "query": "x"}, headers=headers), status, slug)
    assert service.version() == before


def test_update_if_match_and_etag(service: Service) -> None:
    head = service.version()
    r = httpx.post(service.url + "/sparql/update", content=INSERT % 2, headers={**UPDATE, **auth(), "If-Match": f'"{head}"'})
    assert r.status_code == 200 and r.json()["version"] == head + 1 and r.headers["etag"] == f'"{head + 1}"'
    # a second editor who read version `head` is refused, and nothing is written
    doc = assert_problem(httpx.post(service.url + "/sparql/update", content=INSERT % 3,
                                    headers={**UPDATE, **auth(), "If-Match": f'"{head}"'}), 412, "precondition-failed")
    assert doc["current_version"] == head + 1 and service.version() == head + 1
    assert_problem(httpx.post(service.url + "/sparql/update", content=INSERT % 3, headers={**UPDATE, **auth(), "If-Match": "soon"}), 400)
    ask = httpx.get(service.url + "/sparql", params={"query": "ASK { nfex:ORB rdfs:seeAlso <https://docs.opencv.org/3> }"}).json()
    assert ask["boolean"] is False


@pytest.mark.parametrize("update,status,slug", [
    ("DELETE WHERE { nfex:ORB nfex:matchNorm ?n }", 422, "shacl-violation"),
    ("DELETE { nfex:ORB_nfeatures nfex:defaultValue ?d } INSERT { nfex:ORB_nfeatures nfex:defaultValue 0 } WHERE { nfex:ORB_nfeatures nfex:defaultValue ?d }", 422, "shacl-violation"),
    ("INSERT DATA { GRAPH <urn:nfex:meta> { <urn:nfex:head> nfex:versionNumber 99 } }", 400, "bad-input"),
    ("INSERT DATA { nfex:ORB nfex:x }", 400, "parse-error"),
    ("INSERT DATA { [] a nfex:Configuration }", 400, "bad-input"),
])
def test_bad_updates_change_nothing(service: Service, update: str, status: int, slug: str) -> None:
    before = service.version()
    doc = assert_problem(httpx.post(service.url + "/sparql/update", content=update, headers={**UPDATE, **auth()}), status, slug)
    if slug == "shacl-violation":
        assert doc["violations"] and doc["violations"][0]["source_shape"].startswith("https://w3id.org/nfex#")
    assert service.version() == before


def test_rule_resource_changes_selections(service: Service) -> None:
    context = {"agent": "human", "light": "dark"}
    sel = httpx.post(service.url + "/v1/select", json={"context": context}).json()
    assert "AKAZE" not in {p["extractor"] for p in sel["pruned"]}
    query = ('SELECT ?extractor ?reason WHERE { FILTER (?agent = nfex:agent_human && ?light = nfex:light_dark) '
             'BIND (nfex:AKAZE AS ?extractor) BIND ("pytest: too slow handheld in the dark" AS ?reason) }')
    r = httpx.put(service.url + "/v1/rules/pytest-akaze-dark", json={"label": "pytest rule", "query": query}, headers=auth())
    assert r.status_code == 201, r.text
    assert httpx.get(service.url + "/v1/rules/pytest-akaze-dark").json()["label"] == "pytest rule"
    sel = httpx.post(service.url + "/v1/select", json={"context": context}).json()
    assert {p["extractor"]: p["because"][0]["rule"] for p in sel["pruned"]}["AKAZE"].endswith("rule_pytest_akaze_dark")
    bad = httpx.put(service.url + "/v1/rules/pytest-bad", json={"label": "bad", "query": "SELECT ?x WHERE { ?x a nfex:FeatureExtractor }"}, headers=auth())
    assert_problem(bad, 400, "bad-input")  # no ?extractor ?reason
    assert httpx.delete(service.url + "/v1/rules/pytest-akaze-dark", headers=auth()).status_code == 200
    sel = httpx.post(service.url + "/v1/select", json={"context": context}).json()
    assert "AKAZE" not in {p["extractor"] for p in sel["pruned"]}
    assert_problem(httpx.get(service.url + "/v1/rules/pytest-akaze-dark"), 404)


def test_condition_value_extends_the_api(service: Service) -> None:
    assert_problem(httpx.post(service.url + "/v1/select", json={"context": {"reflectance": "glossy"}}), 422, "unknown-name")
    r = httpx.post(service.url + "/v1/conditions/reflectance/values", json={"name": "glossy", "label": "glossy"}, headers=auth())
    assert r.status_code == 201, r.text
    assert httpx.post(service.url + "/v1/select", json={"context": {"reflectance": "glossy"}}).status_code == 200
    assert "glossy" in httpx.get(service.url + "/v1/vocabulary").json()["context"]["reflectance"]["values"]
    bad = httpx.post(service.url + "/v1/conditions/reflectance/values", json={"name": "Not A Token"}, headers=auth())
    assert_problem(bad, 400, "bad-input")
    before = service.version()
    upper = httpx.post(service.url + "/v1/conditions/reflectance/values", json={"name": "Glossy"}, headers=auth())
    assert "lower-case token" in assert_problem(upper, 422, "shacl-violation")["detail"]
    assert service.version() == before
    assert httpx.delete(service.url + "/v1/conditions/reflectance/values/glossy", headers=auth()).status_code == 200
    assert_problem(httpx.post(service.url + "/v1/select", json={"context": {"reflectance": "glossy"}}), 422)


def test_parameter_patch_is_shacl_checked(service: Service) -> None:
    before = service.version()
    doc = assert_problem(httpx.patch(service.url + "/v1/extractors/ORB/parameters/nfeatures", json={"default": 50000}, headers=auth()), 422)
    assert "outside its range" in doc["detail"] and service.version() == before
    assert_problem(httpx.patch(service.url + "/v1/extractors/ORB/parameters/colour", json={"default": 1}, headers=auth()), 422, "unknown-name")
    r = httpx.patch(service.url + "/v1/extractors/BRISK/parameters/thresh", json={"label": "FAST threshold (pytest)"}, headers=auth())
    assert r.status_code == 200 and r.json()["changed"]
    assert httpx.get(service.url + "/v1/extractors/BRISK/parameters/thresh").json()["label"] == "FAST threshold (pytest)"


EXTRACTOR = """@prefix nfex: <https://w3id.org/nfex#> .
nfex:ORB_WIDE a nfex:FeatureExtractor ; nfex:token "ORB_WIDE" ; nfex:opencvConstructor "ORB_create" ;
    nfex:matchNorm "NORM_HAMMING" ; nfex:descriptorKind nfex:BinaryDescriptor ; nfex:performs nfex:SteeredBRIEF .
"""


def test_extractor_put_get_delete(service: Service) -> None:
    r = httpx.put(service.url + "/v1/extractors/ORB_WIDE", content=EXTRACTOR, headers={"content-type": "text/turtle", **auth()})
    if r.status_code == 422:  # the seed's descriptor kinds / operations differ: report which
        pytest.fail(r.text)
    assert r.status_code == 201, r.text
    assert httpx.get(service.url + "/v1/extractors/ORB_WIDE").json()["constructor"] == "ORB_create"
    ttl = httpx.get(service.url + "/v1/extractors/ORB_WIDE", headers={"accept": "text/turtle"})
    assert "ORB_create" in ttl.text
    broken = EXTRACTOR.replace('"NORM_HAMMING"', '"NORM_FANCY"')
    before = service.version()
    assert_problem(httpx.put(service.url + "/v1/extractors/ORB_WIDE", content=broken, headers={"content-type": "text/turtle", **auth()}), 422)
    assert_problem(httpx.put(service.url + "/v1/extractors/ORB_WIDE", content="nfex:x nfex:y", headers={"content-type": "text/turtle", **auth()}), 400)
    assert_problem(httpx.put(service.url + "/v1/extractors/ORB_WIDE", content=EXTRACTOR, headers={"content-type": "application/json", **auth()}), 415)
    other = EXTRACTOR + "nfex:ORB rdfs:label \"hijack\" .\n@prefix rdfs: <http://www.w3.org/2000/01/rdf-schema#> ."
    assert_problem(httpx.put(service.url + "/v1/extractors/ORB_WIDE", content=other, headers={"content-type": "text/turtle", **auth()}), 400)
    assert service.version() == before
    assert httpx.delete(service.url + "/v1/extractors/ORB_WIDE", headers=auth()).status_code == 200
    assert_problem(httpx.get(service.url + "/v1/extractors/ORB_WIDE"), 422, "unknown-name")


def test_program_resource_with_the_dsl(service: Service) -> None:
    assert "default" in {p["name"] for p in httpx.get(service.url + "/v1/programs").json()["programs"]}
    text = 'adjust BRISK.thresh by 0.9 when agent is drone and scene is indoor because "pytest: indoor drones"\n'
    plain = {"content-type": "text/plain", **auth()}
    r = httpx.put(service.url + "/v1/programs/pytest", content=text, headers=plain)
    assert r.status_code == 201, r.text
    assert "BRISK.thresh by 0.9" in httpx.get(service.url + "/v1/programs/pytest").json()["text"]
    sel = httpx.post(service.url + "/v1/select", json={"context": {"agent": "drone", "scene": "indoor"}}).json()
    brisk = next(c for c in sel["candidates"] if c["extractor"] == "BRISK")
    assert any("pytest: indoor drones" in b["reason"] for a in brisk["adjustments"] for b in a["because"])
    before = service.version()
    syntax = assert_problem(httpx.put(service.url + "/v1/programs/pytest", content="adjust BRISK.thresh by\n", headers=plain), 400, "parse-error")
    assert syntax["line"] == 2 and "api:pytest:2:1" in syntax["detail"]  # where the program ended early
    assert_problem(httpx.put(service.url + "/v1/programs/pytest", content="adjust FAST9.thresh by 2 when light is dark\n", headers=plain), 422)
    assert_problem(httpx.put(service.url + "/v1/programs/pytest", content=text, headers={"content-type": "application/json", **auth()}), 415)
    assert_problem(httpx.put(service.url + "/v1/programs/pytest", content=text, headers={"content-type": "text/plain"}), 401)
    assert service.version() == before
    assert httpx.delete(service.url + "/v1/programs/pytest", headers=auth()).status_code == 200
    assert_problem(httpx.get(service.url + "/v1/programs/pytest"), 404)


def test_versions_diff_and_rollback(service: Service) -> None:
    head = service.version()
    r = httpx.post(service.url + "/sparql/update", content="INSERT DATA { nfex:SIFT rdfs:seeAlso <https://example.org/sift> }",
                   headers={**UPDATE, **auth()})
    assert r.json()["version"] == head + 1
    versions = httpx.get(service.url + "/v1/graph/versions", params={"limit": 2}).json()["versions"]
    assert versions[0]["version"] == head + 1 and versions[0]["author"] == "alice"
    one = httpx.get(f"{service.url}/v1/graph/versions/{head + 1}").json()
    assert one["added"] == ["<https://w3id.org/nfex#SIFT> <http://www.w3.org/2000/01/rdf-schema#seeAlso> <https://example.org/sift> ."]
    assert httpx.get(service.url + "/v1/graph/diff", params={"since": head}).json()["added_count"] == 1
    assert_problem(httpx.get(service.url + "/v1/graph/versions/99999"), 404)
    assert_problem(httpx.post(service.url + "/v1/graph/rollback", json={"to": head}, headers={**auth(), "If-Match": f'"{head}"'}), 412)
    r = httpx.post(service.url + "/v1/graph/rollback", json={"to": head}, headers={**auth(), "If-Match": f'"{head + 1}"'})
    assert r.status_code == 200 and r.json()["version"] == head + 2 and r.json()["removed"] == 1
    assert httpx.get(service.url + "/v1/graph/diff", params={"since": head}).json()["added_count"] == 0
    assert_problem(httpx.post(service.url + "/v1/graph/rollback", json={"to": -1}, headers=auth()), 422, "invalid-request")
