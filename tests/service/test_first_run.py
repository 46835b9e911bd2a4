"""The README's first command on a fresh machine: ``nfex serve`` with an empty HOME and no store configured."""
from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import httpx
import pytest

from tests.conftest import free_port, stop_process


def test_serve_starts_on_an_empty_home(tmp_path: Path, record_property: pytest.RecordProperty) -> None:
    """No ~/.local/share, no XDG_DATA_HOME, no NFEX_STORE: the default store folder and its parents are
    created, the store is seeded and the service becomes ready, its compiled rule table kept for the next start
    in the empty HOME's cache (rules/persisted.py), a folder of this user's only."""
    home = tmp_path / "home"
    home.mkdir()
    env = {k: v for k, v in os.environ.items() if k not in ("XDG_DATA_HOME", "XDG_CACHE_HOME", "NFEX_STORE", "NFEX_COMPILED_CACHE")}
    env["HOME"] = str(home)
    port = free_port()
    log = tmp_path / "serve.log"
    t0 = time.monotonic()
    proc = subprocess.Popen(
        [sys.executable, "-m", "cli.main", "serve", "--port", str(port)],
        env=env, stdout=log.open("wb"), stderr=subprocess.STDOUT,
    )
    url = f"http://127.0.0.1:{port}/readyz"
    checkpoints = home / ".local" / "share" / "nfex" / ".store.query-checkpoints"
    try:
        deadline = t0 + 120
        status = None
        while time.monotonic() < deadline:
            assert proc.poll() is None, f"nfex serve exited with {proc.returncode}:\n{log.read_text()[-2000:]}"
            try:
                status = httpx.get(url, timeout=2).status_code
            except httpx.HTTPError:
                status = None
            if status == 200:
                break
            time.sleep(0.2)
        assert status == 200, log.read_text()[-2000:]
        ready_s = time.monotonic() - t0
        record_property("ready_s", round(ready_s, 1))
        print(f"nfex serve on an empty HOME: ready in {ready_s:.1f} s")
        assert httpx.get(url).json()["store"] == str(home / ".local" / "share" / "nfex" / "store")
        assert (home / ".local" / "share" / "nfex" / "store").is_dir()
        compiled = home / ".cache" / "nfex" / "compiled"
        assert len(list(compiled.glob("*.pickle"))) == 1 and compiled.stat().st_mode & 0o777 == 0o700
        # a SPARQL query runs in a worker process over a checkpoint beside the store, removed at shutdown
        r = httpx.get(f"http://127.0.0.1:{port}/sparql", params={"query": "SELECT ?x WHERE { ?x a nfex:FeatureExtractor }"},
                      headers={"Accept": "application/sparql-results+json"}, timeout=30)
        assert r.status_code == 200 and r.json()["results"]["bindings"], r.text[:300]
        assert checkpoints.is_dir()
    finally:
        stop_process(proc)
    assert not checkpoints.exists(), "the query checkpoints outlived the service"
