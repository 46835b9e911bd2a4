"""The service on a real uvicorn, on a free loopback port, over the embedded store."""
from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest

from tests.conftest import free_port, wait_http


@pytest.fixture
def service(store_path: Path) -> Iterator[str]:
    port = free_port()
    env = dict(os.environ, NFEX_STORE=str(store_path))
    proc = subprocess.Popen(
        [sys.executable, "-m", "nfex_core.cli.main", "serve", "--port", str(port), "--log-level", "warning"],
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )
    url = f"http://127.0.0.1:{port}"
    try:
        wait_http(url + "/healthz", proc=proc)
        yield url
    finally:
        proc.terminate()
        proc.wait(timeout=20)


def test_health_readiness_and_vocabulary(service: str) -> None:
    assert httpx.get(service + "/healthz").json() == {"status": "ok"}
    ready = httpx.get(service + "/readyz").json()
    assert ready["status"] == "ready" and ready["graph_version"] == 1
    vocab = httpx.get(service + "/v1/vocabulary").json()
    assert vocab["context"]["light"]["values"] == ["dark", "bright"]
    assert set(vocab["extractors"]) == {"ORB", "ORB_GRID", "SIFT", "AKAZE", "BRISK"}


def test_unknown_route_is_problem_json(service: str) -> None:
    r = httpx.get(service + "/nope")
    assert r.status_code == 404
    assert r.headers["content-type"] == "application/problem+json"
    assert r.json()["status"] == 404
