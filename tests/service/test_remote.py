"""Remote-store mode: the service keeps its graph in a real `oxigraph serve` (docker-compose's layout)."""
from __future__ import annotations

import httpx

from .conftest import Service, assert_problem, auth


def test_select_feedback_sparql_and_update_over_a_sparql_server(remote_service: Service, oxigraph_url: str) -> None:
    svc = remote_service
    assert httpx.get(svc.url + "/readyz").json()["store"].startswith(oxigraph_url)
    sel = httpx.post(svc.url + "/v1/select", json={"context": {"agent": "car", "motion": "fast"}}).json()
    assert "SIFT" in {p["extractor"] for p in sel["pruned"]}
    head = svc.version()
    r = httpx.post(svc.url + "/v1/feedback", json={"extractor": "SIFT", "context": {"scene": "indoor"}, "ate_rmse": 0.5,
                                                    "sequence": "remote/test", "client": "pytest"})
    assert r.status_code == 201 and r.json()["version"] == head + 1
    # the measurement is in the SPARQL server itself
    direct = httpx.post(oxigraph_url + "/query", content=f"ASK {{ <{r.json()['iri']}> a <https://w3id.org/nfex#Measurement> }}",
                        headers={"content-type": "application/sparql-query", "accept": "application/sparql-results+json"})
    assert direct.json()["boolean"] is True
    csv = httpx.get(svc.url + "/sparql", params={"query": "SELECT ?x WHERE { ?x a nfex:FeatureExtractor } ORDER BY ?x"},
                    headers={"accept": "text/csv"})
    assert csv.headers["content-type"].startswith("text/csv") and csv.text.split()[1:] == [
        "https://w3id.org/nfex#AKAZE", "https://w3id.org/nfex#BRISK", "https://w3id.org/nfex#ORB", "https://w3id.org/nfex#SIFT"]
    before = svc.version()
    assert_problem(httpx.post(svc.url + "/sparql/update", content="DELETE WHERE { nfex:SIFT nfex:matchNorm ?n }",
                              headers={"content-type": "application/sparql-update", **auth()}), 422, "shacl-violation")
    assert_problem(httpx.get(svc.url + "/sparql", params={"query": "SELECT nonsense"}), 400)
    assert svc.version() == before
    ok = httpx.post(svc.url + "/sparql/update", content="INSERT DATA { nfex:SIFT rdfs:seeAlso <https://example.org/r> }",
                    headers={"content-type": "application/sparql-update", **auth(), "If-Match": f'"{before}"'})
    assert ok.status_code == 200 and svc.version() == before + 1
