"""Replicas on one shared store stay consistent (issue 17): three `nfex serve` processes on one real
`oxigraph serve` seeded with the shipped graph; a report acknowledged by one replica is reflected in every
replica's context-only selections (default consistency, no ``?consistency=latest``) within the bound of
docs/service.md ("Consistency"): a poll interval (NFEX_POLL_INTERVAL_S) plus at most two compiles.

Issue 17 asks for 2 s, and the test asserts it. Whether that holds depends on the compile time, which the test
reads from each replica (``/readyz`` ``rule_table.compile_ms``): a report's compile is incremental
(docs/architecture.md), ~0.1 s on the shipped graph, so the bound is a poll interval plus a fraction of a second;
a failure prints the bound in the replica's measured compile time beside the time taken (run with ``-s`` for
the times of a pass)."""
from __future__ import annotations

import dataclasses
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
TARGET_S = 2.0  # issue 17: "reflected in every replica's selections within 2 s"
SLACK_S = 0.5  # this test's own loop: one select per replica per round, on a 2-core machine


@pytest.fixture(scope="module")
def shipped_server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[SparqlServer]:
    """A real `oxigraph serve`, seeded with the shipped graph (ontology/ with its measurements, rules/)."""
    proc, server = start_sparql_server("oxigraph", tmp_path_factory.mktemp("replicas-oxigraph"))
    try:
        graph = open_graph(settings=dataclasses.replace(server.settings(), home=REPO), seed_empty=True)
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
                [sys.executable, "-m", "nfex_core.cli.main", "serve", "--port", str(port), "--log-level", "info"],
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


def _until(urls: list[str], seen: Any, timeout: float) -> dict[str, float]:
    """Poll each replica's selections until ``seen(selection)``; seconds until each did (inf: never)."""
    t0 = time.monotonic()
    took = dict.fromkeys(urls, float("inf"))
    while any(v == float("inf") for v in took.values()) and time.monotonic() - t0 < timeout:
        for url in urls:
            if took[url] == float("inf") and seen(_select(url)):
                took[url] = time.monotonic() - t0
        time.sleep(0.02)
    return took


def test_a_report_acknowledged_by_one_replica_is_in_every_replicas_selections(replicas: list[str]) -> None:
    """Two reporters' reports first (quarantined: not corroborated, the evidence does not move), then a third
    reporter's through replica A corroborates them: from that version on the extractor's measured evidence
    under the context counts three more windows. Each replica must answer so within the bound."""
    a = replicas[0]
    before = _windows(_select(a))
    tokens = list(REPORTERS.values())
    head = max(_report(a, tokens[k], k) for k in range(2))
    warm = _until(replicas, lambda s: s["versions"]["graph"] >= head, timeout=30)
    assert max(warm.values()) < 30, f"replicas never reached version {head}: {warm}"
    assert {_windows(_select(u)) for u in replicas} == {before}  # two sources: still quarantined

    version = _report(a, tokens[2], 2)  # acknowledged: committed to the shared store
    took = _until(replicas, lambda s: s["versions"]["graph"] >= version and _windows(s) == before + 3, timeout=30)
    compile_s = {u: httpx.get(u + "/readyz", timeout=10).json()["rule_table"]["compile_ms"] / 1000 for u in replicas}
    poll_s = Settings().poll_interval_s  # the replicas' (they share this environment)
    for i, u in enumerate(replicas):
        print(f"replica {i}: reflected after {took[u]:.2f} s (target {TARGET_S} s); its compile of that version took "
              f"{compile_s[u]:.2f} s; poll interval {poll_s} s")
    late = {u: (round(t, 2), round(poll_s + 2 * compile_s[u] + SLACK_S, 2)) for u, t in took.items() if t > TARGET_S}
    assert not late, f"a report acknowledged by {a} reached these replicas after {TARGET_S} s (took, the bound in their compile times): {late}"
