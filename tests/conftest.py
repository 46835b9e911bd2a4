"""Fixtures shared by the whole suite: seeded stores, a real Oxigraph server, free ports, the data folder."""
from __future__ import annotations

import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import httpx
import pytest
from hypothesis import HealthCheck, settings

from nfex_core.config import Settings
from nfex_core.kg import KnowledgeGraph
from nfex_core.kg.backends import Backend, open_backend
from nfex_core.knowledge import open_graph

REPO = Path(__file__).resolve().parent.parent
BARE_HOME_FLAG = "NFEX_TEST_BARE_HOME"
pytest_plugins = ["tests.require"]

# The property tests behind "a carried compile equals a full compile" (rules/test_setup.py, rules/test_persisted.py,
# evidence/test_index.py, evidence/test_view.py): 50 examples each, derandomised so that a failure in CI is the same
# failure on any machine (Hypothesis derives the examples from the test's name instead of a random seed).
CARRIED_EXAMPLES = settings(max_examples=50, derandomize=True, deadline=None,
                            suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])


def _bare_home(dest: Path) -> Path:
    """ontology/ (without the generated measurements/) and rules/ of this checkout, copied to ``dest``."""
    shutil.copytree(REPO / "ontology", dest / "ontology", ignore=shutil.ignore_patterns("measurements"))
    shutil.copytree(REPO / "rules", dest / "rules")
    return dest


def pytest_configure(config: pytest.Config) -> None:
    """The suite runs on a home without the shipped sweeps (ontology/measurements/, ~21k triples).

    Seeding that home takes ~3 s instead of ~17 s, and tests of mechanics (stores, rules, the service)
    should not hinge on measured data. Tests that are about the shipped measurements ask for
    ``shipped_kg`` / ``shipped_cli_env``. Set once in the controller; xdist workers inherit it.
    """
    if os.environ.get(BARE_HOME_FLAG):
        return
    real = Settings.from_env()
    home = _bare_home(Path(tempfile.mkdtemp(prefix="nfex-test-home-")))
    os.environ.setdefault("NFEX_DATA", str(real.data))
    os.environ.setdefault("NFEX_MODELS", str(real.models))
    os.environ["NFEX_HOME"] = str(home)
    os.environ[BARE_HOME_FLAG] = str(home)


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def wait_http(url: str, timeout: float = 30.0, proc: subprocess.Popen | None = None) -> None:  # type: ignore[type-arg]
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if proc is not None and proc.poll() is not None:
            raise RuntimeError(f"process exited with {proc.returncode} before {url} answered")
        try:
            httpx.get(url, timeout=1.0)
            return
        except httpx.HTTPError:
            time.sleep(0.1)
    raise TimeoutError(f"{url} did not answer within {timeout} s")


@pytest.fixture(scope="session")
def seeded_template(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A store seeded once per test worker (without the shipped sweeps); tests get copies (~3 s)."""
    path = tmp_path_factory.mktemp("seeded") / "store"
    kg = open_graph(str(path))
    kg.backend.flush()  # type: ignore[attr-defined]
    kg.close()
    del kg
    return path


def _copy_store(template: Path, dest: Path) -> Path:
    """A private copy of a template store (its LOCK file left behind) at ``dest``."""
    shutil.copytree(template, dest, ignore=shutil.ignore_patterns("LOCK"))
    return dest


@pytest.fixture
def store_path(seeded_template: Path, tmp_path: Path) -> Path:
    """A fresh copy of the seeded store in this test's folder."""
    return _copy_store(seeded_template, tmp_path / "store")


@pytest.fixture
def kg(store_path: Path) -> Iterator[KnowledgeGraph]:
    graph = KnowledgeGraph.open(str(store_path))
    yield graph
    graph.close()


@pytest.fixture(scope="session")
def bare_template(seeded_template: Path) -> tuple[Path, Settings]:
    """The store seeded without the shipped sweeps (the suite's default, see pytest_configure)."""
    return seeded_template, Settings.from_env()


@pytest.fixture(scope="session")
def shipped_template(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Settings]:
    """A store seeded from this checkout's ontology/ and rules/ *with* the shipped sweeps' Measurements."""
    settings = Settings.from_env().replace(home=REPO)
    path = tmp_path_factory.mktemp("shipped") / "store"
    graph = open_graph(str(path), settings=settings)
    graph.backend.flush()  # type: ignore[attr-defined]
    graph.close()
    return path, settings


def _open_copy(template: tuple[Path, Settings], dest: Path) -> Iterator[KnowledgeGraph]:
    graph = KnowledgeGraph.open(str(_copy_store(template[0], dest)), settings=template[1])
    yield graph
    graph.close()


def _cli_env(store: Path, home: Path, **extra: str) -> dict[str, str]:
    env = dict(os.environ)
    env.update(NFEX_STORE=str(store), NFEX_HOME=str(home), NFEX_AUTHOR="test", **extra)
    return env


@pytest.fixture
def shipped_kg(shipped_template: tuple[Path, Settings], tmp_path: Path) -> Iterator[KnowledgeGraph]:
    """A fresh copy of the store with the shipped measurements (ontology/measurements/)."""
    yield from _open_copy(shipped_template, tmp_path / "shipped-store")


@pytest.fixture
def shipped_cli_env(shipped_template: tuple[Path, Settings], tmp_path: Path) -> dict[str, str]:
    """CLI environment on a copy of the store with the shipped measurements."""
    return _cli_env(_copy_store(shipped_template[0], tmp_path / "shipped-cli-store"), REPO)


@pytest.fixture
def bare_kg(bare_template: tuple[Path, Settings], tmp_path: Path) -> Iterator[KnowledgeGraph]:
    """A fresh copy of the store without shipped measurements: tests that add their own measurements."""
    yield from _open_copy(bare_template, tmp_path / "bare-store")


@pytest.fixture
def bare_cli_env(bare_template: tuple[Path, Settings], tmp_path: Path) -> dict[str, str]:
    """CLI environment on a copy of the store without shipped measurements (and no trained model)."""
    store = _copy_store(bare_template[0], tmp_path / "bare-cli-store")
    return _cli_env(store, bare_template[1].home, NFEX_NEURAL="symbolic")


def stop_process(proc: subprocess.Popen, timeout: float = 20) -> None:  # type: ignore[type-arg]
    """Terminate ``proc``; kill it if it has not exited after ``timeout`` seconds."""
    proc.terminate()
    try:
        proc.wait(timeout=timeout)
    except subprocess.TimeoutExpired:
        proc.kill()


@dataclass(frozen=True)
class SparqlServer:
    """A real SPARQL server process on a loopback port, and the ``NFEX_STORE*`` settings that reach it."""

    name: str
    url: str
    """``NFEX_STORE``"""
    env: dict[str, str] = field(default_factory=dict)
    """the further ``NFEX_STORE_*`` settings this server needs (update endpoint, credentials, named graph)"""

    def settings(self) -> Settings:
        base = Settings.from_env().replace(store=self.url)
        fields = {name: self.env.get(f"NFEX_{name.upper()}") for name in ("store_update", "store_user", "store_password", "store_graph")}
        return base.replace(**fields)

    def open(self, *, seed: bool = True) -> KnowledgeGraph:
        return open_graph(settings=self.settings(), seed_empty=seed)

    def backend(self) -> Backend:
        """The server as nFEX's backend sees it, without a KnowledgeGraph on top (no seeding, no checks)."""
        return open_backend(self.url, self.settings())


def _start_oxigraph(folder: Path, *extra: str) -> tuple[subprocess.Popen, SparqlServer]:  # type: ignore[type-arg]
    exe = shutil.which("oxigraph") or str(Path(sys.executable).parent / "oxigraph")
    if not Path(exe).exists():
        pytest.skip("the oxigraph server binary is not installed (pip install oxigraph)")
    port = free_port()
    proc = subprocess.Popen([exe, "serve", "--location", str(folder / "oxigraph"), "--bind", f"127.0.0.1:{port}", *extra],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    url = f"http://127.0.0.1:{port}"
    try:
        wait_http(url + "/query?query=ASK%7B%7D", proc=proc)
    except BaseException:
        stop_process(proc, timeout=10)
        raise
    return proc, SparqlServer("oxigraph", url)


VIRTUOSO_INI = """[Database]
DatabaseFile = {db}/virtuoso.db
ErrorLogFile = {db}/virtuoso.log
LockFile = {db}/virtuoso.lck
TransactionFile = {db}/virtuoso.trx
xa_persistent_file = {db}/virtuoso.pxa
[TempDatabase]
DatabaseFile = {db}/virtuoso-temp.db
TransactionFile = {db}/virtuoso-temp.trx
[Parameters]
ServerPort = 127.0.0.1:{sql_port}
DisableUnixSocket = 1
; as Debian's virtuoso.ini: with the default (1) ASK answers come back as SELECTs of __ASK_RETVAL
CaseMode = 2
DirsAllowed = {db}
NumberOfBuffers = 10000
MaxDirtyBuffers = 6000
[HTTPServer]
ServerPort = 127.0.0.1:{http_port}
ServerRoot = {db}
ServerThreads = 10
Charset = UTF-8
[SPARQL]
; a CONSTRUCT of the whole knowledge graph must not be cut at Virtuoso's default 10,000 rows
ResultSetMaxRows = 1000000
MaxQueryCostEstimationTime = 400
; the server itself cancels a query past it, as oxigraph serve --timeout-s 10 does
MaxQueryExecutionTime = {timeout_s}
"""
KNOWLEDGE_GRAPH = "https://w3id.org/nfex/graph/knowledge"


def _start_virtuoso(folder: Path, timeout_s: int = 60) -> tuple[subprocess.Popen, SparqlServer]:  # type: ignore[type-arg]
    """Virtuoso (Debian's virtuoso-opensource-7-bin) with a private database and ini on free loopback ports.

    Its default graph is the union of all graphs, so the knowledge goes in a named graph; updates need a
    user with SPARQL update rights: the database's own ``dba`` through ``/sparql-auth`` (HTTP Digest)."""
    exe = shutil.which("virtuoso-t")
    if exe is None:
        pytest.skip("Virtuoso is not installed (apt-get install virtuoso-opensource-7-bin; make test installs it)")
    db = folder / "virtuoso"
    db.mkdir(parents=True)
    http_port = free_port()
    ini = db / "virtuoso.ini"
    ini.write_text(VIRTUOSO_INI.format(db=db, sql_port=free_port(), http_port=http_port, timeout_s=timeout_s))
    proc = subprocess.Popen([exe, "+foreground", "+configfile", str(ini)], cwd=db,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    endpoint = f"http://127.0.0.1:{http_port}/sparql-auth"
    try:
        wait_http(f"http://127.0.0.1:{http_port}/sparql?query=ASK%7B%7D", timeout=60, proc=proc)
    except BaseException:
        stop_process(proc, timeout=10)
        raise
    env = {"NFEX_STORE_UPDATE": endpoint, "NFEX_STORE_USER": "dba", "NFEX_STORE_PASSWORD": "dba",
           "NFEX_STORE_GRAPH": KNOWLEDGE_GRAPH}
    return proc, SparqlServer("virtuoso", endpoint, env)


SPARQL_SERVERS = {"oxigraph": _start_oxigraph, "virtuoso": _start_virtuoso}


def start_sparql_server(name: str, folder: Path) -> tuple[subprocess.Popen, SparqlServer]:  # type: ignore[type-arg]
    """A fresh server of kind ``name``; the service tests pass the time limit the compose file gives Oxigraph."""
    if name == "oxigraph":
        return _start_oxigraph(folder, "--timeout-s", "10")
    return _start_virtuoso(folder, timeout_s=10)


@pytest.fixture
def oxigraph_server(tmp_path: Path) -> Iterator[str]:
    """A real ``oxigraph serve`` process on a free loopback port; yields its base URL (tests of one server)."""
    proc, server = _start_oxigraph(tmp_path)
    try:
        yield server.url
    finally:
        stop_process(proc, timeout=10)


@pytest.fixture(params=sorted(SPARQL_SERVERS))
def sparql_server(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[SparqlServer]:
    """A real, empty SPARQL server per test: ``oxigraph serve`` and Virtuoso (each test runs on both)."""
    proc, server = SPARQL_SERVERS[request.param](tmp_path)
    try:
        yield server
    finally:
        stop_process(proc, timeout=10)


@pytest.fixture(scope="session")
def data_dir() -> Path:
    """../shared/data (or $NFEX_DATA); tests that need real sequences skip where it is absent — and fail under
    NFEX_REQUIRE=all (CI sets it: a missing data folder must not pass as a green build)."""
    path = Settings.from_env().data
    if not path.is_dir():
        pytest.skip(f"dataset folder {path} is absent (set NFEX_DATA)")
    return path


@pytest.fixture
def cli_env(store_path: Path) -> dict[str, str]:
    env = dict(os.environ)
    env["NFEX_STORE"] = str(store_path)
    env["NFEX_AUTHOR"] = "test"
    return env


def run_cli(args: list[str], env: dict[str, str], input: str | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "cli.main", *args], env=env, capture_output=True, text=True, input=input, timeout=120
    )
