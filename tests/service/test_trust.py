"""Issue 16 against the running service (uvicorn on a loopback port): who may report, evidence before
influence, safe updates, a dead writer, CORS. Each test states the outsider's attempt it replays."""
from __future__ import annotations

import shutil
import signal
import threading
import time
from collections.abc import Iterator
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Any

import httpx
import pytest

from tests.conftest import stop_process
from tests.nfex_core.kg.test_crash import _wait_for, _writer

from .conftest import EDITOR, READER, REPORTERS, Service, assert_problem, auth, start_service

ORIGIN = "http://tools.example"
N = "https://w3id.org/nfex#"


@pytest.fixture(scope="module")
def svc(seeded_template: Path, tmp_path_factory: pytest.TempPathFactory) -> Iterator[Service]:
    """A service of its own (a fresh copy of the seeded store), with CORS for one origin. Symbolic: what is
    at stake is the evidence the rules and the measured accuracy read (SelectorNet may overrule a prior)."""
    folder = tmp_path_factory.mktemp("trust-service")
    shutil.copytree(seeded_template, folder / "store", ignore=shutil.ignore_patterns("LOCK"))
    s = start_service(str(folder / "store"), folder / "service.log", {"NFEX_CORS_ORIGINS": ORIGIN, "NFEX_NEURAL": "symbolic"})
    yield s
    stop_process(s.proc)


def select(svc: Service, context: dict[str, str]) -> dict[str, Any]:
    r = httpx.post(svc.url + "/v1/select", params={"consistency": "latest"}, json={"context": context})  # sees the reports
    assert r.status_code == 200, r.text
    return r.json()  # type: ignore[no-any-return]


def decision(sel: dict[str, Any]) -> tuple[Any, ...]:
    """What a client acts on: α*, Θ′, the candidates' order and scores, what was pruned and why."""
    return (sel["extractor"], sel["params"], [(c["extractor"], c["score"]) for c in sel["candidates"]],
            [(p["extractor"], [b["reason"] for b in p["because"]]) for p in sel["pruned"]])


def report(svc: Service, token: str, **fields: Any) -> httpx.Response:
    return httpx.post(svc.url + "/v1/feedback", json=fields, headers=auth(token))


# --- roles ---------------------------------------------------------------------------------------
def test_anonymous_feedback_is_401_and_writes_nothing(svc: Service) -> None:
    before = svc.version()
    body = {"extractor": "BRISK", "context": {"agent": "human"}, "ate_rmse": 0.001}
    doc = assert_problem(httpx.post(svc.url + "/v1/feedback", json=body), 401, "unauthorized")
    assert "reporter" in doc["detail"]
    assert httpx.post(svc.url + "/v1/feedback", json=body).headers["www-authenticate"].startswith("Bearer")
    assert_problem(httpx.post(svc.url + "/v1/feedback", json=body, headers=auth("not-a-token")), 401)
    assert_problem(httpx.post(svc.url + "/v1/feedback", json=body, headers={"Authorization": "Basic eDp5"}), 401)
    assert_problem(httpx.post(svc.url + "/v1/feedback", json=body, headers=auth(READER)), 403, "forbidden")
    assert_problem(httpx.post(svc.url + "/sparql/update", content="INSERT DATA { <urn:a> <urn:b> 1 }",
                              headers={**auth(REPORTERS["carol"]), "Content-Type": "application/sparql-update"}), 403)
    assert svc.version() == before


@pytest.mark.parametrize("query", ["access_token=whatever", f"token={EDITOR}", f"q={REPORTERS['dave']}"])
def test_a_token_in_the_query_string_is_refused(svc: Service, query: str) -> None:
    before = svc.version()
    doc = assert_problem(httpx.post(f"{svc.url}/v1/feedback?{query}", json={"extractor": "ORB", "ate_rmse": 1.0}), 400,
                         "token-in-url")
    assert "rotate" in doc["detail"]
    assert_problem(httpx.get(f"{svc.url}/v1/vocabulary?{query}"), 400, "token-in-url")
    assert svc.version() == before
    assert httpx.get(f"{svc.url}/v1/vocabulary?lang=en").status_code == 200  # other query strings pass


# --- evidence before influence ------------------------------------------------------------------
CONTEXT = {"agent": "human", "scene": "indoor"}


def _six(extractor: str, sequence: str) -> list[dict[str, Any]]:
    """Six windows claiming ``extractor`` is perfect and nearly free (one wild window among them)."""
    return [{"extractor": extractor, "context": CONTEXT, "sequence": sequence, "window_start": 100 * i, "window_end": 100 * i + 50,
             "ate_rmse": 5.0 if i == 5 else 0.001 + 0.0001 * i, "extraction_ms": 0.1, "width": 640, "height": 480,
             "tracking_lost": 0} for i in range(6)]


def test_reports_steer_only_once_corroborated_by_min_sources_reporters(svc: Service) -> None:
    baseline = select(svc, CONTEXT)
    target = next(c["extractor"] for c in baseline["candidates"][1:])  # a candidate that is not chosen now
    assert baseline["extractor"] != target

    for fields in _six(target, "trust/one-reporter"):  # one reporter, six reports
        assert report(svc, REPORTERS["carol"], **fields).status_code == 201
    assert decision(select(svc, CONTEXT)) == decision(baseline)
    listed = httpx.get(svc.url + "/v1/feedback", params={"status": "quarantined"}).json()
    assert listed["min_sources"] == 3 and len(listed["reports"]) >= 6
    assert "1 of the 3 reporters" in listed["reports"][0]["because"]

    for name in ("dave", "erin"):  # the same reports from two more reporters: three sources
        for fields in _six(target, f"trust/{name}"):
            assert report(svc, REPORTERS[name], **fields).status_code == 201
    sel = select(svc, CONTEXT)
    assert sel["extractor"] == target
    chosen = sel["candidates"][0]
    ev = chosen["evidence"]
    assert ev["aggregate"] == "median" and ev["windows"] == 18 and ev["sources"] == 3 and ev["outliers"] == 3
    assert {N + f"client_{n}" for n in ("carol", "dave", "erin")} <= set(ev["source_iris"])
    assert ev["ate_m"] == pytest.approx(0.0013, abs=1e-4)  # the median: the 5 m windows are outliers, not the answer
    configuration = ev["configuration"]
    assert configuration["sources"] == 3 and "from 3 sources" in configuration["because"]["reason"]
    assert not httpx.get(svc.url + "/v1/feedback", params={"status": "quarantined"}).json()["reports"]


def test_an_editor_can_accept_a_report(svc: Service) -> None:
    context = {"scene": "outdoor", "light": "bright"}
    baseline = select(svc, context)
    target = next(c["extractor"] for c in baseline["candidates"][1:])
    iris = []
    for i in range(3):
        r = report(svc, REPORTERS["carol"], extractor=target, context=context, sequence="trust/accept", window_start=10 * i,
                   window_end=10 * i + 10, ate_rmse=0.0005)
        iris.append(r.json()["iri"])
    assert decision(select(svc, context)) == decision(baseline)
    assert_problem(httpx.post(f"{svc.url}/v1/feedback/{iris[0].rsplit('#', 1)[1]}/accept", headers=auth(REPORTERS["dave"])), 403)
    assert_problem(httpx.post(f"{svc.url}/v1/feedback/measurement_{'0' * 32}/accept", headers=auth(EDITOR)), 404)
    assert_problem(httpx.post(f"{svc.url}/v1/feedback/..%2F..%2Fx/accept", headers=auth(EDITOR)), 404)
    for iri in iris:
        r = httpx.post(f"{svc.url}/v1/feedback/{iri.rsplit('#', 1)[1]}/accept", headers=auth(EDITOR))
        assert r.status_code == 200, r.text
    sel = select(svc, context)
    assert sel["extractor"] == target, [(c["extractor"], c["score"], c["evidence"]) for c in sel["candidates"]]
    assert sel["candidates"][0]["evidence"]["sources"] == 1
    accepted = {x["iri"]: x for x in httpx.get(svc.url + "/v1/feedback").json()["reports"]}
    assert all(accepted[i]["status"] == "admitted" and "accepted by" in accepted[i]["because"] for i in iris)


# --- safe updates -------------------------------------------------------------------------------
@pytest.fixture
def bait() -> Iterator[tuple[str, list[str]]]:
    """A loopback HTTP server that records every request it gets (nothing should reach it)."""
    seen: list[str] = []

    class Handler(BaseHTTPRequestHandler):
        def do_GET(self) -> None:  # noqa: N802
            seen.append(self.path)
            body = b"<urn:ssrf> <urn:p> <urn:o> ."
            self.send_response(200)
            self.send_header("Content-Type", "application/n-triples")
            self.send_header("Content-Length", str(len(body)))
            self.end_headers()
            self.wfile.write(body)

        do_POST = do_GET  # noqa: N815

        def log_message(self, *args: Any) -> None:
            pass

    server = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    yield f"http://127.0.0.1:{server.server_address[1]}", seen
    server.shutdown()


def update(svc: Service, text: str | bytes, token: str = EDITOR) -> httpx.Response:
    return httpx.post(svc.url + "/sparql/update", content=text, headers={**auth(token), "Content-Type": "application/sparql-update"})


def test_load_and_service_are_refused_and_nothing_is_fetched(svc: Service, bait: tuple[str, list[str]]) -> None:
    url, seen = bait
    before = svc.version()
    for text in (f"LOAD <{url}/x.nt>", f"LOAD SILENT <{url}/x.nt> INTO GRAPH <urn:g>",
                 f"INSERT {{ ?s ?p ?o }} WHERE {{ SERVICE <{url}/sparql> {{ ?s ?p ?o }} }}",
                 f"# harmless\nINSERT DATA {{ <urn:a> <urn:b> 1 }} ; load <{url}/y.nt>"):
        doc = assert_problem(update(svc, text), 403, "forbidden-operation")
        assert doc["operations"] and doc["operations"][0] in doc["detail"]
    assert_problem(update(svc, f"\\u004cOAD <{url}/x.nt>"), 400, "parse-error")  # the gate's grammar has no \\u escapes
    q = f"SELECT * WHERE {{ SERVICE <{url}/sparql> {{ ?s ?p ?o }} }}"
    assert_problem(httpx.get(svc.url + "/sparql", params={"query": q}), 403, "forbidden-operation")
    assert_problem(httpx.post(svc.url + "/sparql", content=q, headers={"Content-Type": "application/sparql-query"}), 403)
    rule = {"label": "fetch", "query": f"SELECT ?extractor ?reason WHERE {{ SERVICE <{url}/r> {{ ?extractor ?reason ?x }} }}"}
    assert_problem(httpx.put(svc.url + "/v1/rules/fetch", json=rule, headers=auth(EDITOR)), 403)
    stored = f'INSERT DATA {{ nfex:rule_fetch a nfex:SparqlRule ; rdfs:label "f" ; nfex:query "SELECT ?extractor ?reason WHERE {{ SERVICE <{url}/r> {{ }} }}" }}'
    assert_problem(update(svc, stored), 403)
    time.sleep(0.5)
    assert seen == [] and svc.version() == before


def test_clear_and_friends_are_refused_and_the_graph_keeps_every_triple(svc: Service) -> None:
    head = httpx.get(svc.url + "/v1/graph").json()
    for text in ("CLEAR DEFAULT", "CLEAR ALL", "CLEAR GRAPH <urn:nfex:meta>", "DROP ALL", "DROP SILENT GRAPH <urn:x>",
                 "CREATE GRAPH <urn:x>", "ADD DEFAULT TO <urn:x>", "MOVE DEFAULT TO <urn:x>", "COPY <urn:nfex:meta> TO DEFAULT"):
        doc = assert_problem(update(svc, text), 403, "forbidden-operation")
        assert text.split()[0] in doc["detail"]
    doc = assert_problem(update(svc, "DELETE WHERE { ?s ?p ?o }"), 422, "shacl-violation")  # the core shape
    assert any(v["source_shape"] == N + "CoreShape" for v in doc["violations"])
    assert httpx.get(svc.url + "/v1/graph").json() == head


BAD_UPDATES: list[str | bytes] = [
    "", "   ", "INSERT", "INSERT DATA {", "DELETE DATA { ?s ?p ?o }", "INSERT DATA { <a> <b> }", "\x00\x01", b"\xff\xfe\x00",
    "INSERT DATA { GRAPH <urn:nfex:meta> { <urn:nfex:head> nfex:versionNumber 99 } }", "INSERT DATA { _:b <urn:p> 1 }",
    "INSERT DATA { <urn:a> <urn:p> \"x\"^^<http://www.w3.org/2001/XMLSchema#integer> }", "WITH <urn:g> DELETE { ?s ?p ?o } WHERE { ?s ?p ?o }",
    "INSERT DATA { <urn:a> <urn:p> " + "1 , " * 20000 + "1 }", "SELECT * WHERE { ?s ?p ?o }", "PREFIX : <x> INSERT DATA { :a :b :c }",
    "INSERT { ?s <urn:p> ?o } WHERE { BIND (1/0 AS ?o) BIND (<urn:s> AS ?s) }", "DELETE { ?s ?p ?o } WHERE { ?s ?p ?o FILTER (isBlank(?s)) }",
    "INSERT DATA { <urn:a> <urn:p> \"\\uD800\" }", "INSERT DATA { <http://[::1]/a> <urn:p> 1 }", "USING <urn:g> INSERT { <urn:a> <urn:p> 1 } WHERE {}",
    "INSERT DATA { nfex:ORB nfex:token \"second\" }", "DELETE DATA { nfex:ORB a nfex:FeatureExtractor }",
]


@pytest.mark.parametrize("text", BAD_UPDATES, ids=range(len(BAD_UPDATES)))
def test_no_update_input_is_a_500(svc: Service, text: str | bytes) -> None:
    before = svc.version()
    r = update(svc, text)
    assert r.status_code < 500, r.text[:300]
    if r.status_code >= 400:
        assert_problem(r, r.status_code)
        assert svc.version() == before
    else:  # an update that means something harmless commits like any other
        assert r.json()["version"] >= before


# --- a dead writer on the shared store -----------------------------------------------------------
def test_a_writer_killed_between_claim_and_commit_does_not_block_the_next_write(
    remote_service: Service, oxigraph_url: str, tmp_path: Path
) -> None:
    """The service's next write commits once the dead writer's claim expires (its wait on the claim, bounded by the
    claim's time to live, is tests/nfex_core/kg/test_crash.py's); a claim that never expired would end it in a 409
    after CLAIM_WAIT_S."""
    proc = _writer(tmp_path, oxigraph_url, 3, stop=True)
    _wait_for(proc, "commit")  # it holds its claim on the next version and is about to commit
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    before = remote_service.version()
    r = httpx.post(remote_service.url + "/sparql/update", content='INSERT DATA { nfex:ORB rdfs:seeAlso "after a dead writer" }',
                   headers={**auth(EDITOR), "Content-Type": "application/sparql-update"}, timeout=60)
    assert r.status_code == 200, r.text
    assert r.json()["version"] == before + 1


# --- CORS ---------------------------------------------------------------------------------------
def test_cors_for_reads_only(svc: Service) -> None:
    pre = httpx.options(svc.url + "/v1/select", headers={"Origin": ORIGIN, "Access-Control-Request-Method": "POST",
                                                         "Access-Control-Request-Headers": "content-type"})
    assert pre.status_code == 204 and pre.headers["access-control-allow-origin"] == ORIGIN
    assert "POST" in pre.headers["access-control-allow-methods"]
    r = httpx.post(svc.url + "/v1/select", json={"context": {}}, headers={"Origin": ORIGIN})
    assert r.headers["access-control-allow-origin"] == ORIGIN
    # a body the JSON guard refuses is still a read's answer the page may see (its problem+json)
    bad = httpx.post(svc.url + "/v1/select", content=b'{"context": {"budget_ms": NaN}}',
                     headers={"Origin": ORIGIN, "Content-Type": "application/json"})
    assert bad.status_code == 400 and bad.headers["access-control-allow-origin"] == ORIGIN
    assert httpx.get(svc.url + "/sparql", params={"query": "ASK {}"}, headers={"Origin": ORIGIN}).headers[
        "access-control-allow-origin"] == ORIGIN
    for path, method in (("/sparql/update", "POST"), ("/v1/feedback", "POST"), ("/v1/rules/x", "PUT"), ("/v1/graph/rollback", "POST")):
        pre = httpx.options(svc.url + path, headers={"Origin": ORIGIN, "Access-Control-Request-Method": method})
        assert "access-control-allow-origin" not in pre.headers and pre.status_code >= 400
    write = httpx.post(svc.url + "/v1/feedback", json={}, headers={"Origin": ORIGIN, **auth(REPORTERS["carol"])})
    assert "access-control-allow-origin" not in write.headers
    other = httpx.get(svc.url + "/v1/vocabulary", headers={"Origin": "http://evil.example"})
    assert other.status_code == 200 and "access-control-allow-origin" not in other.headers


def test_no_cors_by_default(remote_service: Service) -> None:
    r = httpx.get(remote_service.url + "/v1/vocabulary", headers={"Origin": ORIGIN})
    assert "access-control-allow-origin" not in r.headers


# --- found by bench/bench_fuzz.py ----------------------------------------------------------------
def test_a_one_pixel_frame_is_a_400_not_a_500(svc: Service) -> None:
    import cv2
    import numpy as np

    ok, png = cv2.imencode(".png", np.zeros((1, 1), np.uint8))
    assert ok
    r = httpx.post(svc.url + "/v1/select", files={"frame": ("f.png", png.tobytes(), "image/png")}, data={"context": "{}"})
    assert "features need at least" in assert_problem(r, 400)["detail"]


def test_a_rollback_to_version_0_is_refused_by_the_core_shape(svc: Service) -> None:
    """Found by the fuzzer: the core shape refuses it in a few ASKs, before the change is computed or validated
    (KnowledgeGraph.commit's ``core_violations``)."""
    head = httpx.get(svc.url + "/v1/graph").json()
    doc = assert_problem(httpx.post(svc.url + "/v1/graph/rollback", json={"to": 0}, headers=auth(EDITOR), timeout=60), 422)
    assert any(v["source_shape"] == N + "CoreShape" for v in doc["violations"])
    assert httpx.get(svc.url + "/v1/graph").json() == head
