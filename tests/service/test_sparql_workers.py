"""The query workers of the embedded store (service/sparql_exec.py): a worker handed back to the idle ones is no
longer the finished query's to kill, so a deadline that fires late cannot stop another query's worker."""
from __future__ import annotations

import time
from pathlib import Path

from nfex_core.kg.storage.backends import EmbeddedBackend
from service.sparql_exec import LimitedWriter, QueryRunner

QUERY = "SELECT (COUNT(*) AS ?n) WHERE { ?s ?p ?o }"


def test_a_released_worker_is_not_its_last_querys_to_kill(tmp_path: Path) -> None:
    backend = EmbeddedBackend(tmp_path / "store")
    runner = QueryRunner(backend, timeout_s=30, max_bytes=1 << 20, concurrency=2, version=lambda: 1)
    try:
        first = LimitedWriter(1 << 20, time.monotonic() + 30, 30)
        runner._in_worker(QUERY, "application/sparql-results+json", first)
        assert first.cancel is None  # released with its answer: the late deadline of `first` has nothing to kill
        second = LimitedWriter(1 << 20, time.monotonic() + 30, 30)
        runner._in_worker(QUERY, "application/sparql-results+json", second)  # the same worker, taken again
        assert len(runner._idle) == 1 and runner._idle[0].proc.poll() is None
        assert b'"n"' in b"".join(second.chunks)
    finally:
        runner.close()
        backend.close()
