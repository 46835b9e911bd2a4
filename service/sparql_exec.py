"""Running a client's SPARQL query with a time limit and a result-size limit that really hold.

How the limits are enforced (docs/service.md, "SPARQL limits"):

- At most ``NFEX_SPARQL_CONCURRENCY`` queries run at once per process; when every slot is held, a new query is
  refused at once (503 ``query-limit``, "all query slots busy") instead of queueing. The request waits for its
  query at most ``NFEX_SPARQL_TIMEOUT_S`` and then answers 503 ``query-limit``; the event loop and every other
  endpoint keep answering meanwhile.
- **Embedded store**: each query runs in a worker process (service/query_worker.py) over a read-only
  checkpoint of the store, made when the graph version moved (``Checkpoints``). At the deadline the worker is
  killed: the slot and the CPU are free at once, whatever the query was doing (pyoxigraph cannot interrupt a
  blocking operator — ORDER BY, GROUP BY, an aggregate over a huge join — in a thread), and a replacement
  starts on the next query. A crash inside a worker is a 503 for that query alone.
- Results are bounded by ``NFEX_SPARQL_MAX_BYTES`` where they are serialised (in the worker, or into a writer
  that counts bytes and checks the deadline on every chunk for a remote store).
- **Remote store**: the remaining time is the HTTP timeout to the SPARQL server (whose own timeout, e.g.
  ``oxigraph serve --timeout-s``, cancels the query there); an in-memory store runs queries on threads.
"""
from __future__ import annotations

import asyncio
import json
import logging
import shutil
import subprocess
import sys
import threading
import time
import uuid
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

from nfex_core.errors import ParseError, QueryLimitExceeded, StoreUnavailable
from nfex_core.kg.storage.backends import GRAPH_FORMATS, RESULT_FORMATS, Backend, EmbeddedBackend

from .query_worker import read_message, write_message

log = logging.getLogger("nfex.service")


class LimitedWriter:
    """A binary sink that stops a query past its deadline or its byte budget."""

    def __init__(self, max_bytes: int, deadline: float, timeout_s: float) -> None:
        self.chunks: list[bytes] = []
        self.size = 0
        self.max_bytes = max_bytes
        self.deadline = deadline
        self.timeout_s = timeout_s
        self.error: QueryLimitExceeded | None = None
        self.cancel: Callable[[], None] | None = None  # stops the query's worker process, where it has one

    def write(self, data: bytes) -> int:
        if self.error is None:
            if time.monotonic() > self.deadline:
                self.error = QueryLimitExceeded(f"the query ran past its time limit of {self.timeout_s:g} s", limit="time")
            elif self.size + len(data) > self.max_bytes:
                self.error = QueryLimitExceeded(
                    f"the result exceeds the size limit of {self.max_bytes} bytes; add LIMIT or narrow the query",
                    limit="result-size",
                    max_bytes=self.max_bytes,
                )
        if self.error is not None:
            raise OSError(self.error.detail)
        self.chunks.append(bytes(data))
        self.size += len(data)
        return len(data)

    def flush(self) -> None:
        pass


@dataclass(frozen=True)
class QueryOutcome:
    body: bytes
    media: str
    elapsed_ms: float


@dataclass
class Checkpoint:
    version: int
    path: Path
    users: int = 0


@dataclass
class Checkpoints:
    """Read-only copies of the embedded store for the query workers, one per graph version that a query asked
    for (RocksDB checkpoints: hard links to the store's immutable files, so a copy costs milliseconds, not a
    copy of the data). A copy no query uses any more, once a newer one exists, is deleted."""

    backend: EmbeddedBackend
    version: Callable[[], int]
    root: Path
    current: Checkpoint | None = None
    lock: threading.Lock = field(default_factory=threading.Lock)

    def acquire(self) -> Checkpoint:
        with self.lock:
            head = self.version()
            if self.current is None or self.current.version != head:
                with self.backend.write_lock:  # no commit half-seen: the copy is of one version
                    head = self.version()
                    path = self.root / f"v{head}-{uuid.uuid4().hex[:8]}"
                    self.root.mkdir(parents=True, exist_ok=True)
                    self.backend.checkpoint(path)
                old, self.current = self.current, Checkpoint(head, path)
                if old is not None and old.users == 0:
                    shutil.rmtree(old.path, ignore_errors=True)
            self.current.users += 1
            return self.current

    def release(self, checkpoint: Checkpoint) -> None:
        with self.lock:
            checkpoint.users -= 1
            if checkpoint is not self.current and checkpoint.users == 0:
                shutil.rmtree(checkpoint.path, ignore_errors=True)

    def close(self) -> None:
        shutil.rmtree(self.root, ignore_errors=True)


class Worker:
    """One query worker process (service/query_worker.py)."""

    def __init__(self) -> None:
        # buffered pipes: a read of n bytes returns n (or ends at EOF), where a raw pipe may return fewer
        self.proc = subprocess.Popen([sys.executable, "-P", "-m", "service.query_worker"], stdin=subprocess.PIPE,
                                     stdout=subprocess.PIPE)
        self.killed = False

    def ask(self, request: dict[str, object]) -> tuple[dict[str, object], bytes] | None:
        """The worker's answer, or None when it died or was killed before answering."""
        assert self.proc.stdin is not None and self.proc.stdout is not None
        try:
            write_message(self.proc.stdin, json.dumps(request).encode())  # type: ignore[arg-type]
            self.proc.stdin.flush()
            head = read_message(self.proc.stdout)  # type: ignore[arg-type]
            if head is None:
                return None
            header = json.loads(head)
            body = self.proc.stdout.read(int(header.get("size", 0))) if header.get("ok") else b""
        except (OSError, ValueError):
            return None
        return header, body

    def kill(self) -> None:
        self.killed = True
        self.proc.kill()

    def close(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
        self.proc.wait()


class QueryRunner:
    def __init__(self, backend: Backend, *, timeout_s: float, max_bytes: int, concurrency: int,
                 version: Callable[[], int] | None = None) -> None:
        self.backend = backend
        self.timeout_s = timeout_s
        self.max_bytes = max_bytes
        self._pool = ThreadPoolExecutor(max_workers=concurrency, thread_name_prefix="sparql")
        self._slots = threading.BoundedSemaphore(concurrency)
        self.concurrency = concurrency
        self.checkpoints: Checkpoints | None = None
        if isinstance(backend, EmbeddedBackend) and backend.location != ":memory:" and version is not None:
            store = Path(backend.location)
            self.checkpoints = Checkpoints(backend, version, store.parent / f".{store.name}.query-checkpoints")
            self.checkpoints.close()  # what a process killed before its shutdown left
        self._idle: list[Worker] = []
        self._workers_lock = threading.Lock()

    def _worker(self) -> Worker:
        with self._workers_lock:
            while self._idle:
                worker = self._idle.pop()
                if worker.proc.poll() is None:
                    return worker
        return Worker()

    def _release(self, worker: Worker, writer: LimitedWriter) -> None:
        """``worker`` back to the idle ones, no longer this query's to kill: under the lock ``run`` kills under, so a
        deadline that fires now cannot kill a worker another query has taken."""
        with self._workers_lock:
            writer.cancel = None
            self._idle.append(worker)

    def _in_worker(self, query: str, media: str, writer: LimitedWriter) -> str:
        assert self.checkpoints is not None
        checkpoint = self.checkpoints.acquire()
        worker = self._worker()
        writer.cancel = worker.kill
        if writer.error is not None:  # the deadline passed while the checkpoint was made
            self.checkpoints.release(checkpoint)
            self._release(worker, writer)
            raise OSError("stopped at its deadline")
        try:
            graph = media if media in GRAPH_FORMATS else "text/turtle"
            results = media if media in RESULT_FORMATS else "application/sparql-results+json"
            request = {"store": str(checkpoint.path), "query": query, "graph": graph, "results": results,
                       "default_graph": getattr(self.backend, "graph", None), "max_bytes": writer.max_bytes}
            answer = worker.ask(request)
        finally:
            self.checkpoints.release(checkpoint)
        if answer is None:
            worker.close()
            if writer.error is not None or worker.killed:
                raise OSError("stopped at its deadline")
            raise StoreUnavailable("the query's worker process ended before answering (see the service log)")
        self._release(worker, writer)
        header, body = answer
        if not header["ok"]:
            if header["error"] == "syntax":
                raise ParseError(f"invalid SPARQL query: {header['detail']}")
            if header["error"] == "result-size":
                writer.error = QueryLimitExceeded(
                    f"the result exceeds the size limit of {writer.max_bytes} bytes; add LIMIT or narrow the query",
                    limit="result-size", max_bytes=writer.max_bytes)
                raise OSError(writer.error.detail)
            raise StoreUnavailable(f"the query could not read the store: {header['detail']}")
        writer.chunks.append(body)
        writer.size = len(body)
        return graph if header["kind"] == "triples" else results

    def _job(self, query: str, media: str, writer: LimitedWriter) -> QueryOutcome:
        t0 = time.perf_counter()
        try:
            stopped = False
            try:
                if self.checkpoints is not None:
                    written = self._in_worker(query, media, writer)
                else:
                    remaining = max(0.05, writer.deadline - time.monotonic())
                    written = self.backend.query_to(query, media, writer, timeout_s=remaining)
            except OSError:
                if writer.error is None:
                    raise
                # raised outside this block, so no traceback keeps pyoxigraph's result objects (which
                # must be dropped on the thread that made them) alive into the event loop
                stopped = True
            if stopped or writer.error is not None:
                assert writer.error is not None
                raise QueryLimitExceeded(writer.error.detail, **writer.error.extra)
            return QueryOutcome(b"".join(writer.chunks), written, (time.perf_counter() - t0) * 1000)
        finally:
            self._slots.release()

    async def run(self, query: str, media: str, *, max_bytes: int | None = None) -> QueryOutcome:
        """Run ``query`` within the time limit and ``max_bytes`` (default: the runner's result-size limit)."""
        if not self._slots.acquire(blocking=False):
            raise QueryLimitExceeded(
                f"all {self.concurrency} query slots are busy (long-running queries); retry later", limit="concurrency"
            )
        limit = self.max_bytes if max_bytes is None else max_bytes
        writer = LimitedWriter(limit, time.monotonic() + self.timeout_s, self.timeout_s)
        loop = asyncio.get_running_loop()
        try:
            fut = loop.run_in_executor(self._pool, self._job, query, media, writer)
        except BaseException:
            self._slots.release()
            raise
        # wait for the job or the deadline, whichever comes first (a timer and a callback: no extra tasks)
        waiter = loop.create_future()

        def wake(_: object = None) -> None:
            if not waiter.done():
                waiter.set_result(None)

        fut.add_done_callback(wake)
        timer = loop.call_later(self.timeout_s, wake)
        try:
            await waiter
        finally:
            timer.cancel()
        if fut.done():
            return fut.result()
        fut.add_done_callback(lambda f: f.cancelled() or f.exception())  # an abandoned query's error is expected
        detail = f"the query ran past its time limit of {self.timeout_s:g} s"
        writer.error = writer.error or QueryLimitExceeded(detail, limit="time")  # stops it at its next write
        with self._workers_lock:  # a worker the job has released is no longer this query's (``_release``)
            if writer.cancel is not None:
                writer.cancel()  # or, in a worker process, at once
        raise QueryLimitExceeded(detail, limit="time")

    def close(self) -> None:
        self._pool.shutdown(wait=False, cancel_futures=True)
        with self._workers_lock:
            idle, self._idle = self._idle, []
        for worker in idle:
            worker.close()
        if self.checkpoints is not None:
            self.checkpoints.close()
