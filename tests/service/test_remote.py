"""Remote-store mode: the service keeps its graph in a real SPARQL server (docker-compose's layout):
`oxigraph serve`, and Virtuoso (knowledge in a named graph, updates behind HTTP Digest); each test runs on both."""
from __future__ import annotations

import io
from concurrent.futures import ThreadPoolExecutor
from csv import reader

import httpx
import pytest

from tests.conftest import SparqlServer

from .conftest import REPORTER, Service, assert_problem, auth


def test_select_feedback_sparql_and_update_over_a_sparql_server(remote_service: Service, sparql_store: SparqlServer) -> None:
    svc = remote_service
    assert httpx.get(svc.url + "/readyz").json()["store"] == sparql_store.backend().location
    sel = httpx.post(svc.url + "/v1/select", json={"context": {"agent": "car", "motion": "fast"}}).json()
    assert "SIFT" in {p["extractor"] for p in sel["pruned"]}
    head = svc.version()
    r = httpx.post(svc.url + "/v1/feedback", json={"extractor": "SIFT", "context": {"scene": "indoor"}, "ate_rmse": 0.5,
                                                    "sequence": "remote/test", "client": "pytest"}, headers=auth(REPORTER))
    assert r.status_code == 201 and r.json()["version"] == head + 1
    # the measurement is in the SPARQL server itself (in the knowledge graph, where the server keeps it in a named one)
    assert sparql_store.backend().ask(f"ASK {{ <{r.json()['iri']}> a <https://w3id.org/nfex#Measurement> }}")
    csv = httpx.get(svc.url + "/sparql", params={"query": "SELECT ?x WHERE { ?x a nfex:FeatureExtractor } ORDER BY ?x"},
                    headers={"accept": "text/csv"})
    # the server's own CSV passes through (Virtuoso quotes every field, Oxigraph only where needed)
    assert csv.headers["content-type"].startswith("text/csv") and [row[0] for row in reader(io.StringIO(csv.text))][1:] == [
        "https://w3id.org/nfex#AKAZE", "https://w3id.org/nfex#BRISK", "https://w3id.org/nfex#ORB", "https://w3id.org/nfex#ORB_GRID",
        "https://w3id.org/nfex#SIFT", "https://w3id.org/nfex#XFEAT"]
    before = svc.version()
    assert_problem(httpx.post(svc.url + "/sparql/update", content="DELETE WHERE { nfex:SIFT nfex:matchNorm ?n }",
                              headers={"content-type": "application/sparql-update", **auth()}), 422, "shacl-violation")
    assert_problem(httpx.get(svc.url + "/sparql", params={"query": "SELECT nonsense"}), 400)
    assert svc.version() == before
    ok = httpx.post(svc.url + "/sparql/update", content="INSERT DATA { nfex:SIFT rdfs:seeAlso <https://example.org/r> }",
                    headers={"content-type": "application/sparql-update", **auth(), "If-Match": f'"{before}"'})
    assert ok.status_code == 200 and svc.version() == before + 1


@pytest.mark.slow
def test_replicas_share_the_graph_and_never_lose_a_write(remote_service: Service, remote_replica: Service) -> None:
    """Editors write through two replicas at once without If-Match: every write lands, each once."""
    head = remote_service.version()

    def write(i: int) -> int:
        svc = (remote_service, remote_replica)[i % 2]
        r = httpx.post(svc.url + "/sparql/update", content=f"INSERT DATA {{ nfex:ORB rdfs:seeAlso <https://example.org/replica/{i}> }}",
                       headers={"content-type": "application/sparql-update", **auth()}, timeout=60)
        assert r.status_code == 200, r.text
        return int(r.json()["version"])

    with ThreadPoolExecutor(4) as pool:
        versions = sorted(pool.map(write, range(8)))
    assert versions == list(range(head + 1, head + 9))
    rows = httpx.get(remote_replica.url + "/sparql", params={
        "query": "SELECT ?x WHERE { nfex:ORB rdfs:seeAlso ?x FILTER STRSTARTS(STR(?x), 'https://example.org/replica/') }"}).json()
    assert len(rows["results"]["bindings"]) == 8
    # a rule written through one replica prunes in the other's next selection (it polls the head every NFEX_POLL_INTERVAL_S, 0.25 s by default)
    query = ('SELECT ?extractor ?reason WHERE { FILTER (?agent = nfex:agent_drone && ?texture = nfex:texture_low) '
             'BIND (nfex:ORB AS ?extractor) BIND ("pytest replica rule" AS ?reason) }')
    r = httpx.put(remote_service.url + "/v1/rules/pytest-replica", json={"label": "replica", "query": query}, headers=auth())
    assert r.status_code == 201, r.text
    import time

    deadline = time.monotonic() + 10
    while True:
        # generous: the first selection at a new version reloads the vocabulary from the server, which under
        # load (Virtuoso and both replicas compiling) can take longer than httpx's default 5 s
        sel = httpx.post(remote_replica.url + "/v1/select", json={"context": {"agent": "drone", "texture": "low"}}, timeout=30).json()
        if "ORB" in {p["extractor"] for p in sel["pruned"]}:
            break
        assert time.monotonic() < deadline, "the replica never saw the rule"
        time.sleep(0.2)


def test_a_slow_query_on_the_sparql_server_is_cut_at_the_time_limit(remote_service: Service) -> None:
    # a join no server can count without evaluating (Virtuoso counts a bare cross product within the limit)
    slow = "SELECT (COUNT(*) AS ?n) WHERE { ?a ?p ?o . ?b ?q ?r . FILTER (STRLEN(STR(?o)) + STRLEN(STR(?r)) > 3) }"
    doc = assert_problem(httpx.get(remote_service.url + "/sparql", params={"query": slow}, timeout=30), 503, "query-limit")
    assert doc["limit"] == "time"  # cut by the time limit (the server's or ours), not finished
    assert httpx.get(remote_service.url + "/healthz").status_code == 200
