"""Fixtures shared by the whole suite: seeded stores, a real Oxigraph server, free ports, the data folder."""
from __future__ import annotations

import dataclasses
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest

from nfex_core.config import Settings
from nfex_core.kg import KnowledgeGraph
from nfex_core.knowledge import open_graph

REPO = Path(__file__).resolve().parent.parent
BARE_HOME_FLAG = "NFEX_TEST_BARE_HOME"


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
    settings = dataclasses.replace(Settings.from_env(), home=REPO)
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


@pytest.fixture
def oxigraph_server(tmp_path: Path) -> Iterator[str]:
    """A real ``oxigraph serve`` process on a free loopback port; yields its base URL."""
    exe = shutil.which("oxigraph") or str(Path(sys.executable).parent / "oxigraph")
    if not Path(exe).exists():
        pytest.skip("the oxigraph server binary is not installed (pip install oxigraph)")
    port = free_port()
    proc = subprocess.Popen(
        [exe, "serve", "--location", str(tmp_path / "oxigraph"), "--bind", f"127.0.0.1:{port}"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )
    url = f"http://127.0.0.1:{port}"
    try:
        wait_http(url + "/query?query=ASK%7B%7D", proc=proc)
        yield url
    finally:
        stop_process(proc, timeout=10)


@pytest.fixture(scope="session")
def data_dir() -> Path:
    """../shared/data (or $NFEX_DATA); tests that need real sequences skip where it is absent."""
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
        [sys.executable, "-m", "nfex_core.cli.main", *args], env=env, capture_output=True, text=True, input=input, timeout=120
    )
