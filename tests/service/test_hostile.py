"""Hostile input against a real ``nfex serve``, on the embedded store and on a real ``oxigraph serve``: deep
nesting, escapes that walk around a lexical reading, forbidden operations, concurrent read-modify-write
updates, non-finite numbers, lone surrogates, huge numbers, deep JSON, deep and wide frames, stalled bodies.
After each, the server is alive, nothing was fetched from the loopback, and the graph is as before."""
from __future__ import annotations

import shutil
import socket
import threading
import time
from collections.abc import Iterator
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

import cv2
import httpx
import numpy as np
import pytest

from tests.conftest import start_sparql_server, stop_process
from tests.service.conftest import EDITOR, REPORTER, Service, assert_problem, auth, start_service

LIMITS = {"NFEX_MAX_SESSIONS_PER_CLIENT": "2"}  # the suite's shared services allow every test's sessions: 16


@pytest.fixture(scope="module", params=["embedded", "oxigraph"])
def target(request: pytest.FixtureRequest, seeded_template: Path, tmp_path_factory: pytest.TempPathFactory) -> Iterator[Service]:
    folder = tmp_path_factory.mktemp(f"hostile-{request.param}")
    server_proc = None
    if request.param == "embedded":
        store = folder / "store"
        shutil.copytree(seeded_template, store, ignore=shutil.ignore_patterns("LOCK"))
        svc = start_service(str(store), folder / "service.log", LIMITS)
    else:
        (folder / "oxigraph").mkdir()
        server_proc, server = start_sparql_server("oxigraph", folder / "oxigraph")
        svc = start_service(server.url, folder / "service.log", {**server.env, **LIMITS})
    yield svc
    stop_process(svc.proc)
    if server_proc is not None:
        assert server_proc.poll() is None, "oxigraph serve died during the hostile suite"
        stop_process(server_proc)


class _Recorder(BaseHTTPRequestHandler):
    hits: list[str] = []

    def do_GET(self) -> None:  # noqa: N802 (http.server's name)
        self.hits.append(self.path)
        self.send_response(200)
        self.send_header("Content-Type", "application/n-triples")
        self.end_headers()
        self.wfile.write(b"<urn:foreign> <urn:p> <urn:o> .\n")

    do_POST = do_GET

    def log_message(self, *args: object) -> None:
        pass


@pytest.fixture(scope="module")
def listener() -> Iterator[tuple[str, list[str]]]:
    """A server on the loopback that records every request: a fetch through nFEX would show here."""
    hits: list[str] = []
    handler = type("Recorder", (_Recorder,), {"hits": hits})
    server = ThreadingHTTPServer(("127.0.0.1", 0), handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    yield f"http://127.0.0.1:{server.server_address[1]}", hits
    server.shutdown()


def alive(svc: Service) -> None:
    assert svc.proc.poll() is None, f"nfex serve died (exit {svc.proc.poll()})"
    assert httpx.get(svc.url + "/healthz").status_code == 200
    r = httpx.get(svc.url + "/sparql", params={"query": "ASK { ?s ?p ?o }"}, headers={"Accept": "application/sparql-results+json"})
    assert r.status_code == 200 and r.json()["boolean"] is True


@pytest.mark.parametrize("query,status,slug", [
    ("SELECT * WHERE " + "{" * 3000 + " ?s ?p ?o " + "}" * 3000, 400, "sparql-too-complex"),
    ("SELECT * WHERE { ?s ?p ?o FILTER(" + "(" * 10_000 + "?o" + ")" * 10_000 + ") }", 400, "sparql-too-complex"),
    ("SELECT * WHERE { ?s ?p ?o FILTER(" + "+".join(["?o"] * 3000) + " > 0) }", 400, "sparql-too-complex"),
    ("SELECT * WHERE { " + " UNION ".join(["{ ?s ?p ?o }"] * 1000) + " }", 400, "sparql-too-complex"),
])
def test_deep_or_long_queries_are_refused_and_the_server_lives(target: Service, query: str, status: int, slug: str) -> None:
    for send in (lambda: httpx.get(target.url + "/sparql", params={"query": query}),
                 lambda: httpx.post(target.url + "/sparql", content=query, headers={"Content-Type": "application/sparql-query"})):
        assert_problem(send(), status, slug)
    alive(target)


def test_the_deepest_shapes_the_gate_admits_run_on_the_store(target: Service) -> None:
    """Just under the gate's bound, each shape reaches the store (embedded or oxigraph serve) and is answered."""
    for query in ("SELECT * WHERE { ?s ?p ?o FILTER(" + "+".join(["1"] * 190) + " > 0) } LIMIT 1",
                  "SELECT * WHERE { " + " UNION ".join(["{ ?s a ?o }"] * 190) + " } LIMIT 1",
                  "SELECT * WHERE " + "{" * 60 + " ?s ?p ?o " + "}" * 60 + " LIMIT 1"):
        r = httpx.get(target.url + "/sparql", params={"query": query}, headers={"Accept": "application/sparql-results+json"})
        assert r.status_code == 200, r.text[:300]
    alive(target)


def test_service_behind_a_local_name_escape_is_refused_and_nothing_is_fetched(target: Service, listener: tuple[str, list[str]]) -> None:
    url, hits = listener
    before = len(hits)
    query = (f"PREFIX ex: <http://e/> SELECT * WHERE {{ OPTIONAL {{ ?s ex:a\\# ?o }} "
             f"SERVICE <{url}/sparql> {{ ?x ?y ?z }} }}")
    assert_problem(httpx.get(target.url + "/sparql", params={"query": query}), 403, "forbidden-operation")
    for spelt in ("sErViCe", "SERVICE"):
        q = f"SELECT * WHERE {{ ?s ?p ?o . {spelt} <{url}/x> {{ ?x ?y ?z }} }} # ex:a\\#"
        assert httpx.get(target.url + "/sparql", params={"query": q}).status_code in (400, 403)
    assert len(hits) == before, hits[before:]
    alive(target)


def test_load_behind_an_escape_is_refused_and_writes_nothing(target: Service, listener: tuple[str, list[str]]) -> None:
    url, hits = listener
    before, version = len(hits), target.version()
    update = f"PREFIX ex: <http://e/> INSERT DATA {{ ex:a\\# ex:b ex:c }} ; LOAD <{url}/x.nt>"
    r = httpx.post(target.url + "/sparql/update", content=update,
                   headers={**auth(), "Content-Type": "application/sparql-update"})
    assert_problem(r, 403, "forbidden-operation")
    rule = {"label": "walk-around", "query": "PREFIX ex: <http://e/> SELECT ?extractor ?reason WHERE { "
            f"?extractor ex:a\\# ?reason SERVICE <{url}/sparql> {{ ?x ?y ?z }} }}"}
    assert httpx.put(target.url + "/v1/rules/walk-around", json=rule, headers=auth()).status_code == 403
    deep = "SELECT ?extractor ?reason WHERE " + "{" * 3000 + " ?extractor ?p ?reason " + "}" * 3000
    assert httpx.put(target.url + "/v1/rules/deep", json={"label": "deep", "query": deep}, headers=auth()).status_code == 400
    deep_update = "INSERT { <urn:a> <urn:b> ?o } WHERE " + "{" * 3000 + " ?s ?p ?o " + "}" * 3000
    r = httpx.post(target.url + "/sparql/update", content=deep_update, headers={**auth(), "Content-Type": "application/sparql-update"})
    assert_problem(r, 400, "sparql-too-complex")
    assert len(hits) == before and target.version() == version
    r = httpx.get(target.url + "/sparql", params={"query": "ASK { <urn:foreign> ?p ?o }"}, headers={"Accept": "application/sparql-results+json"})
    assert r.json()["boolean"] is False
    alive(target)


def test_concurrent_read_modify_write_updates_lose_nothing(target: Service) -> None:
    counter = f"urn:counter:{time.monotonic_ns()}"
    headers = {**auth(), "Content-Type": "application/sparql-update"}
    r = httpx.post(target.url + "/sparql/update", content=f"INSERT DATA {{ <{counter}> <urn:v> 0 }}", headers=headers)
    assert r.status_code == 200, r.text
    increment = (f"DELETE {{ <{counter}> <urn:v> ?v }} INSERT {{ <{counter}> <urn:v> ?w }} "
                 f"WHERE {{ <{counter}> <urn:v> ?v BIND(?v + 1 AS ?w) }}")
    outcomes: list[tuple[int, bool | None]] = []

    def editor() -> None:
        with httpx.Client(timeout=60) as client:
            for _ in range(25):
                resp = client.post(target.url + "/sparql/update", content=increment, headers=headers)
                outcomes.append((resp.status_code, resp.json().get("changed") if resp.status_code == 200 else None))

    threads = [threading.Thread(target=editor) for _ in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    acknowledged = sum(1 for status, changed in outcomes if status == 200 and changed)
    assert all(status in (200, 409, 412) for status, _ in outcomes), outcomes
    assert all(changed for status, changed in outcomes if status == 200), "an update was acknowledged unchanged"
    r = httpx.get(target.url + "/sparql", params={"query": f"SELECT ?v WHERE {{ <{counter}> <urn:v> ?v }}"},
                  headers={"Accept": "application/sparql-results+json"})
    values = [int(b["v"]["value"]) for b in r.json()["results"]["bindings"]]
    assert values == [acknowledged] and acknowledged >= 25, (values, acknowledged)


def test_bad_values_are_4xx_and_store_nothing(target: Service) -> None:
    version = target.version()
    # no token: a deep JSON array as the multipart context, lone surrogates in JSON bodies and parts
    deep = "[" * 10_000 + "]" * 10_000
    assert_problem(httpx.post(target.url + "/v1/select", files={"context": (None, deep)}), 400)
    surrogate = b'{"context": {"agent": "\\ud800"}}'
    assert_problem(httpx.post(target.url + "/v1/sessions", content=surrogate, headers={"Content-Type": "application/json"}), 400, "bad-input")
    assert_problem(httpx.post(target.url + "/v1/select", files={"context": (None, '{"agent": "\\udfff"}')}), 400)
    assert_problem(httpx.post(target.url + "/v1/select", content=b'{"context": {"budget_ms": NaN}}',
                              headers={"Content-Type": "application/json"}), 400, "bad-input")
    # reporter: non-finite and surrogate values in feedback
    reporter = {**auth(REPORTER), "Content-Type": "application/json"}
    base = '{"extractor": "ORB", "context": {"agent": "car"}, "sequence": "hostile/1", "mean_inliers": 10'
    for body in (base + ', "params": {"nfeatures": NaN}}', base + ', "params": {"nfeatures": Infinity}}',
                 base + ', "params": {"nfeatures": -Infinity}}', base + ', "ate_rmse": Infinity}', base + ', "ate_rmse": 1e999}',
                 base + ', "params": {"\\ud800": 1}}', '{"extractor": "\\ud800", "mean_inliers": 1}',
                 base + ', "window_start": 1' + "0" * 5000 + "}"):
        assert_problem(httpx.post(target.url + "/v1/feedback", content=body.encode(), headers=reporter), 400)
    assert_problem(httpx.post(target.url + "/v1/feedback", json={"extractor": "ORB", "mean_inliers": 1, "ate_rmse": "Infinity"},
                              headers=auth(REPORTER)), 422)
    assert httpx.get(target.url + "/v1/feedback").status_code == 200
    # editor: non-finite ranges and defaults, a huge If-Match
    editor = {**auth(EDITOR), "Content-Type": "application/json"}
    for body in (b'{"max": NaN}', b'{"default": Infinity}', b'{"min": -Infinity}'):
        assert_problem(httpx.patch(target.url + "/v1/extractors/ORB/parameters/nfeatures", content=body, headers=editor), 400)
    assert_problem(httpx.patch(target.url + "/v1/extractors/ORB/parameters/nfeatures", json={"max": "NaN"}, headers=editor), 422)
    assert_problem(httpx.patch(target.url + "/v1/extractors/ORB/parameters/nfeatures", json={"max": 9000},
                               headers={**editor, "If-Match": '"' + "9" * 5000 + '"'}), 400)
    assert target.version() == version
    alive(target)


def test_a_budget_is_a_number_in_a_frame_requests_context(target: Service) -> None:
    frame = cv2.imencode(".png", np.full((120, 160), 128, np.uint8))[1].tobytes()
    for context in ('{"agent": "car", "budget_ms": 20}', '{"agent": "car", "budget_ms": "20"}'):
        r = httpx.post(target.url + "/v1/select", files={"frame": ("f.png", frame, "image/png"), "context": (None, context)})
        assert r.status_code == 200, r.text[:300]
    doc = assert_problem(httpx.post(target.url + "/v1/select", files={"context": (None, '{"agent": true}')}), 400)
    assert "'agent'" in doc["detail"] and "boolean" in doc["detail"]


def test_a_frame_that_decodes_past_the_budget_is_refused_before_decoding(target: Service) -> None:
    deep = cv2.imencode(".png", np.zeros((1500, 2000), np.uint16))[1].tobytes()  # 3 Mpx of 16-bit samples
    doc = assert_problem(httpx.post(target.url + "/v1/select", files={"frame": ("f.png", deep, "image/png")}), 413)
    assert "2 bytes a pixel" in doc["detail"]
    flat = cv2.imencode(".png", np.zeros((1500, 2000), np.uint8))[1].tobytes()  # the same pixels, 8-bit: decoded
    assert httpx.post(target.url + "/v1/select", files={"frame": ("f.png", flat, "image/png")}).status_code == 200
    alive(target)


def test_a_stalled_body_is_answered_408_and_the_connection_freed(target: Service) -> None:
    host, port = target.url.removeprefix("http://").split(":")
    with socket.create_connection((host, int(port)), timeout=30) as s:
        s.sendall(b"POST /v1/sessions HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\nContent-Length: 100\r\n\r\n{\"co")
        reply = s.recv(4096)  # the test env's NFEX_BODY_TIMEOUT_S is 3 s: the answer comes before the socket's 30 s
    assert reply.startswith(b"HTTP/1.1 408"), reply[:200]
    alive(target)


RUNAWAY = "SELECT (COUNT(*) AS ?n) WHERE { ?a ?b ?c . ?d ?e ?f . ?g ?h ?i }"


def _children(pid: int) -> list[tuple[int, str, str]]:
    """(pid, state, command line) of the processes whose parent is ``pid`` (Linux /proc)."""
    out = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
            if int(fields[1]) == pid:
                cmd = (stat.parent / "cmdline").read_bytes().replace(b"\0", b" ").decode()
                out.append((int(stat.parent.name), fields[0], cmd))
        except (OSError, IndexError, ValueError):
            continue
    return out


def test_runaway_queries_stop_at_their_deadline_and_free_their_slots(target: Service) -> None:
    """Four queries that would run for minutes get 503 at the time limit; at once after, a simple query is
    answered (their slots are free) and, on the embedded store, no worker process is left computing."""
    answers: list[httpx.Response] = []

    def runaway() -> None:
        answers.append(httpx.get(target.url + "/sparql", params={"query": RUNAWAY}, timeout=120))

    threads = [threading.Thread(target=runaway) for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for r in answers:
        assert assert_problem(r, 503, "query-limit")["limit"] == "time"
    r = httpx.get(target.url + "/sparql", params={"query": "SELECT ?s WHERE { ?s a nfex:FeatureExtractor } LIMIT 1"},
                  headers={"Accept": "application/sparql-results+json"})
    assert r.status_code == 200, r.text[:300]
    workers = [pid for pid, _, cmd in _children(target.proc.pid) if "service.query_worker" in cmd]
    before = {pid: _cpu_ticks(pid) for pid in workers}
    time.sleep(1.0)  # a worker still computing a runaway query would use this second
    busy = {pid: _cpu_ticks(pid) - ticks for pid, ticks in before.items() if _cpu_ticks(pid) - ticks > 20}
    assert not busy, f"query workers still computing (clock ticks in 1 s): {busy}"
    alive(target)


def _cpu_ticks(pid: int) -> int:
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return 0  # ended
    return int(fields[11]) + int(fields[12])  # utime + stime


def test_session_creation_is_limited_per_client_with_retry_after(target: Service) -> None:
    # LIMITS: 2 sessions a client; a token is its own client, whatever its address
    opened = [httpx.post(target.url + "/v1/sessions", json={"context": {"agent": "car"}}) for _ in range(2)]
    assert all(r.status_code == 201 for r in opened), opened[0].text
    refused = httpx.post(target.url + "/v1/sessions", json={"context": {"agent": "car"}})
    doc = assert_problem(refused, 429, "too-many-sessions")
    assert int(refused.headers["Retry-After"]) >= 1 and doc["retry_after_s"] > 0
    other = httpx.post(target.url + "/v1/sessions", json={"context": {"agent": "car"}}, headers=auth(REPORTER))
    assert other.status_code == 201, other.text
    for r in (*opened, other):
        assert httpx.delete(target.url + f"/v1/sessions/{r.json()['id']}").status_code in (200, 204)
    assert httpx.post(target.url + "/v1/sessions", json={"context": {"agent": "car"}}).status_code == 201


def test_a_retried_report_is_one_measurement(target: Service) -> None:
    report = {"extractor": "ORB", "context": {"agent": "car"}, "sequence": "hostile/retry", "mean_inliers": 42.0}
    key = f"retry-{time.monotonic_ns()}"
    first = httpx.post(target.url + "/v1/feedback", json=report, headers={**auth(REPORTER), "Idempotency-Key": key})
    assert first.status_code == 201, first.text
    again = httpx.post(target.url + "/v1/feedback", json=report, headers={**auth(REPORTER), "Idempotency-Key": key})
    assert again.status_code == 200 and again.json()["iri"] == first.json()["iri"] and not again.json()["changed"]
    plain = httpx.post(target.url + "/v1/feedback", json=report, headers=auth(REPORTER))
    assert plain.status_code == 201 and plain.json()["iri"] != first.json()["iri"]
    for iri, times in ((first.json()["iri"], 1), (plain.json()["iri"], 1)):  # each report once in the graph
        r = httpx.get(target.url + "/sparql", params={"query": f"SELECT (COUNT(?t) AS ?n) WHERE {{ <{iri}> sosa:resultTime ?t }}"},
                      headers={"Accept": "application/sparql-results+json"})
        assert int(r.json()["results"]["bindings"][0]["n"]["value"]) == times, r.text


def test_a_store_outage_keeps_the_replica_in_rotation(seeded_template: Path, tmp_path: Path) -> None:
    (tmp_path / "oxigraph").mkdir()
    server_proc, server = start_sparql_server("oxigraph", tmp_path / "oxigraph")
    svc = start_service(server.url, tmp_path / "service.log", server.env)
    try:
        stop_process(server_proc)
        ready = httpx.get(svc.url + "/readyz")
        assert ready.status_code == 200, ready.text
        assert ready.json()["writes"] == "unavailable" and "snapshot" in ready.json()["detail"]
        assert_problem(httpx.get(svc.url + "/readyz/writes"), 503, "store-unavailable")
        assert httpx.post(svc.url + "/v1/select", json={"context": {"agent": "car"}}).status_code == 200
    finally:
        stop_process(svc.proc)
        if server_proc.poll() is None:
            stop_process(server_proc)
