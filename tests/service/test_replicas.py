"""Replicas on one shared store stay consistent (issue 17): three `nfex serve` processes on one real
`oxigraph serve` seeded with the shipped graph; a report acknowledged by one replica is reflected in every
replica's context-only selections (default consistency, no ``?consistency=latest``): each replica's head read
(every NFEX_POLL_INTERVAL_S) finds the new version and its background compile brings it in (docs/service.md,
"Consistency").

The test waits for what the replicas say — the version that answered (``versions["graph"]``) and the evidence
it cites — not for a time; how long that takes is a figure for the bench (``bench/bench_scale.py`` measures
the compile per report) and is printed here (run with ``-s``)."""
from __future__ import annotations

import os
import subprocess
import sys
import time
from collections.abc import Iterator
from typing import Any

import httpx
import pytest

from nfex_core.knowledge import open_graph
from service.config import Settings
from tests.conftest import REPO, SparqlServer, free_port, start_sparql_server, stop_process

from .conftest import REPORTERS, TEST_ENV, auth

REPLICAS = 3
# the report's context: a selection there shows the measured evidence of the reported extractor
CONTEXT = {"agent": "drone", "light": "dark", "texture": "low"}
EXTRACTOR = "ORB"
PATIENCE_S = 120  # only so that a replica that never catches up ends the test: nothing is asserted on the time


@pytest.fixture(scope="module")
def shipped_server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[SparqlServer]:
    """A real `oxigraph serve`, seeded with the shipped graph (ontology/ with its measurements, rules/)."""
    proc, server = start_sparql_server("oxigraph", tmp_path_factory.mktemp("replicas-oxigraph"))
    try:
        graph = open_graph(settings=server.settings().replace(home=REPO), seed_empty=True)
        graph.close()
        yield server
    finally:
        stop_process(proc, timeout=10)


@pytest.fixture(scope="module")
def replicas(shipped_server: SparqlServer, tmp_path_factory: pytest.TempPathFactory) -> Iterator[list[str]]:
    """Three `nfex serve` processes on the shipped server, started side by side; yields their base URLs."""
    folder = tmp_path_factory.mktemp("replicas")
    procs: list[subprocess.Popen[bytes]] = []
    urls: list[str] = []
    env = dict(os.environ, NFEX_STORE=shipped_server.url, NFEX_HOME=str(REPO), NFEX_NEURAL="symbolic", **TEST_ENV)
    try:
        for i in range(REPLICAS):
            port = free_port()
            procs.append(subprocess.Popen(
                [sys.executable, "-m", "cli.main", "serve", "--port", str(port), "--log-level", "info"],
                env=env, stdout=(folder / f"replica-{i}.log").open("wb"), stderr=subprocess.STDOUT))
            urls.append(f"http://127.0.0.1:{port}")
        deadline = time.monotonic() + 120
        for url, proc in zip(urls, procs, strict=True):
            while not _ready(url):
                assert proc.poll() is None, f"a replica exited with {proc.returncode} before it was ready"
                assert time.monotonic() < deadline, f"{url} did not become ready within 120 s"
                time.sleep(0.2)
        yield urls
    finally:
        for proc in procs:
            stop_process(proc)


def _ready(url: str) -> bool:
    try:
        return httpx.get(url + "/readyz", timeout=2).status_code == 200
    except httpx.HTTPError:
        return False


def _select(url: str) -> dict[str, Any]:
    r = httpx.post(url + "/v1/select", json={"context": CONTEXT}, timeout=30)
    assert r.status_code == 200, r.text[:500]
    return r.json()


def _windows(selection: dict[str, Any]) -> int:
    """Measured windows of EXTRACTOR that count under CONTEXT, as the selection cites them."""
    for c in selection["candidates"]:
        if c["extractor"] == EXTRACTOR:
            return int((c.get("evidence") or {}).get("windows") or 0)
    raise AssertionError(f"{EXTRACTOR} is not a candidate under {CONTEXT}: {[c['extractor'] for c in selection['candidates']]}")


def _report(url: str, token: str, i: int) -> int:
    r = httpx.post(url + "/v1/feedback", headers=auth(token), timeout=60, json={
        "extractor": EXTRACTOR, "context": CONTEXT, "sequence": "pytest/replicas", "client": "pytest",
        "window_start": 100 * i, "window_end": 100 * i + 100, "ate_rmse": 0.3, "tracking_lost": 0})
    assert r.status_code == 201, r.text[:500]
    return int(r.json()["version"])


def _until(urls: list[str], seen: Any) -> dict[str, float]:
    """Poll each replica's selections until ``seen(selection)``; seconds until each did (inf: never, within
    PATIENCE_S)."""
    t0 = time.monotonic()
    took = dict.fromkeys(urls, float("inf"))
    while any(v == float("inf") for v in took.values()) and time.monotonic() - t0 < PATIENCE_S:
        for url in urls:
            if took[url] == float("inf") and seen(_select(url)):
                took[url] = time.monotonic() - t0
        time.sleep(0.02)
    return took


def test_a_report_acknowledged_by_one_replica_is_in_every_replicas_selections(replicas: list[str]) -> None:
    """Two reporters' reports first (quarantined: not corroborated, the evidence does not move), then a third
    reporter's through replica A corroborates them: from that version on the extractor's measured evidence
    under the context counts three more windows, and every replica's selections say so."""
    a = replicas[0]
    before = _windows(_select(a))
    tokens = list(REPORTERS.values())
    head = max(_report(a, tokens[k], k) for k in range(2))
    warm = _until(replicas, lambda s: s["versions"]["graph"] >= head)
    never = [u for u, t in warm.items() if t == float("inf")]
    assert not never, f"these replicas never answered from version {head}: {never}"
    assert {_windows(_select(u)) for u in replicas} == {before}  # two sources: still quarantined

    version = _report(a, tokens[2], 2)  # acknowledged: committed to the shared store
    took = _until(replicas, lambda s: s["versions"]["graph"] >= version and _windows(s) == before + 3)
    never = [u for u, t in took.items() if t == float("inf")]
    assert not never, f"a report acknowledged by {a} (version {version}) never reached these replicas' selections: {never}"
    compile_s = {u: httpx.get(u + "/readyz", timeout=10).json()["rule_table"]["compile_ms"] / 1000 for u in replicas}
    poll_s = Settings().poll_interval_s  # the replicas' (they share this environment)
    for i, u in enumerate(replicas):
        print(f"replica {i}: reflected after {took[u]:.2f} s; its compile of that version took {compile_s[u]:.2f} s; "
              f"poll interval {poll_s} s")
