"""The real service under uvicorn on free loopback ports: over an embedded store, and over a real
``oxigraph serve`` (remote-store mode), each started once per test session with the settings below."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import httpx
import pytest

from tests.conftest import (
    SPARQL_SERVERS,
    SparqlServer,
    free_port,
    start_sparql_server,
    stop_process,
    wait_http,
)

EDITOR = "editor-secret-1"
READER = "reader-secret-2"
REPORTERS = {"carol": "reporter-secret-3", "dave": "reporter-secret-4", "erin": "reporter-secret-5"}  # nfex:minSources = 3
REPORTER = REPORTERS["carol"]
# the settings the tests (and docker-compose.yml) run the service with
TEST_ENV = {
    "NFEX_TOKENS": f"alice:{EDITOR}:editor,bob:{READER}:reader," + ",".join(f"{n}:{t}:reporter" for n, t in REPORTERS.items()),
    "NFEX_LOG_LEVEL": "info",
    "NFEX_COMPILED_CACHE": "none",  # no kept tables in the developer's cache (tests/service/test_restart.py sets one)
    "NFEX_LOG_JSON": "true",
    "NFEX_SPARQL_TIMEOUT_S": "1.5",
    "NFEX_SPARQL_MAX_BYTES": "262144",
    "NFEX_MAX_BODY_BYTES": "4194304",
    "NFEX_MAX_IMAGE_BYTES": "3145728",
    "NFEX_MAX_PIXELS": "4000000",
    "NFEX_MAX_DECODED_BYTES": "4000000",
    "NFEX_BODY_TIMEOUT_S": "3",
    "NFEX_MAX_SESSIONS": "16",
    "NFEX_MAX_SESSIONS_PER_CLIENT": "16",  # every test's sessions come from one address
}


@dataclass
class Service:
    url: str
    log: Path
    proc: subprocess.Popen  # type: ignore[type-arg]

    def version(self) -> int:
        return int(httpx.get(self.url + "/v1/graph").json()["version"])

    def log_lines(self) -> list[str]:
        return self.log.read_text().splitlines()


def start_service(store: str, log: Path, extra_env: dict[str, str] | None = None) -> Service:
    port = free_port()
    env = {**os.environ, "NFEX_STORE": store, **TEST_ENV, **(extra_env or {})}
    proc = subprocess.Popen(
        [sys.executable, "-m", "cli.main", "serve", "--port", str(port), "--log-level", "info"],
        env=env, stdout=log.open("wb"), stderr=subprocess.STDOUT,
    )
    url = f"http://127.0.0.1:{port}"
    wait_http(url + "/healthz", timeout=60, proc=proc)
    deadline = time.monotonic() + 60
    while httpx.get(url + "/readyz").status_code != 200:
        if time.monotonic() > deadline:
            raise TimeoutError("the service did not become ready")
        time.sleep(0.1)
    return Service(url, log, proc)


@pytest.fixture(scope="session")
def service(seeded_template: Path, tmp_path_factory: pytest.TempPathFactory) -> Iterator[Service]:
    """The service over a copy of the seeded embedded store (shared by the session: tests that write
    compare versions before and after, and use condition values no other test uses)."""
    folder = tmp_path_factory.mktemp("service")
    store = folder / "store"
    shutil.copytree(seeded_template, store, ignore=shutil.ignore_patterns("LOCK"))
    svc = start_service(str(store), folder / "service.log")
    yield svc
    stop_process(svc.proc)


@pytest.fixture(scope="session", params=sorted(SPARQL_SERVERS))
def sparql_store(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory) -> Iterator[SparqlServer]:
    """A real SPARQL server for the remote-store mode, one per kind for the session: ``oxigraph serve`` (as
    docker-compose.yml runs it: the server cancels queries past --timeout-s itself) and Virtuoso."""
    proc, server = start_sparql_server(request.param, tmp_path_factory.mktemp(request.param))
    yield server
    stop_process(proc)


@pytest.fixture(scope="session")
def oxigraph_url(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    """An ``oxigraph serve`` of its own, as docker-compose.yml runs it (tests of that one server)."""
    proc, server = start_sparql_server("oxigraph", tmp_path_factory.mktemp("oxigraph"))
    yield server.url
    stop_process(proc)


@pytest.fixture(scope="session")
def remote_service(sparql_store: SparqlServer, tmp_path_factory: pytest.TempPathFactory) -> Iterator[Service]:
    """The service in remote-store mode: its graph lives in a real SPARQL server."""
    folder = tmp_path_factory.mktemp("remote-service")
    svc = start_service(sparql_store.url, folder / "service.log", sparql_store.env)
    yield svc
    stop_process(svc.proc)


@pytest.fixture(scope="session")
def remote_replica(remote_service: Service, sparql_store: SparqlServer, tmp_path_factory: pytest.TempPathFactory) -> Iterator[Service]:
    """A second replica on the same SPARQL server, as docker-compose.yml runs several."""
    folder = tmp_path_factory.mktemp("remote-replica")
    svc = start_service(sparql_store.url, folder / "service.log", sparql_store.env)
    yield svc
    stop_process(svc.proc)


def assert_problem(r: httpx.Response, status: int, slug: str | None = None) -> dict:  # type: ignore[type-arg]
    assert r.status_code == status, (r.status_code, r.text[:500])
    assert r.headers["content-type"].startswith("application/problem+json"), r.headers["content-type"]
    doc = r.json()
    assert doc["status"] == status and doc["detail"] and doc["title"]
    assert doc["type"].startswith("https://w3id.org/nfex/problems/")
    if slug is not None:
        assert doc["type"].endswith("/" + slug), doc["type"]
    return doc  # type: ignore[no-any-return]


def auth(token: str = EDITOR) -> dict[str, str]:
    return {"Authorization": f"Bearer {token}"}
