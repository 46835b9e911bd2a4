"""Running a client's SPARQL query with a time limit and a result-size limit that really hold.

How the limits are enforced (docs/service.md, "SPARQL limits"):

- Each query runs on a thread of a bounded pool (``NFEX_SPARQL_CONCURRENCY`` slots per process). The
  request waits for it at most ``NFEX_SPARQL_TIMEOUT_S`` and then answers 503 ``query-limit``; the
  event loop and every other endpoint keep answering meanwhile (pyoxigraph releases the GIL while it
  evaluates, and the remote store is plain I/O).
- Results are serialised by pyoxigraph (or streamed from the SPARQL server) into a writer that counts
  bytes and checks the deadline on every chunk: past either limit it raises, which stops the
  evaluation of a streaming query at its next 8 KiB chunk. So a timed-out query stops producing
  and its slot frees itself — except inside a blocking operator (ORDER BY, GROUP BY, aggregates),
  which pyoxigraph cannot interrupt: such a thread runs to the operator's end and then stops at its
  first write. It holds its slot meanwhile; when every slot is held, new queries are refused at once
  (503 ``query-limit``, "all query slots busy") instead of queueing, so a few runaway queries cannot
  pile up work or block the worker. A remote store gets the remaining time as its HTTP timeout.
"""
from __future__ import annotations

import asyncio
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

from nfex_core.errors import QueryLimitExceeded
from nfex_core.kg.backends import Backend


class LimitedWriter:
    """A binary sink that stops a query past its deadline or its byte budget."""

    def __init__(self, max_bytes: int, deadline: float, timeout_s: float) -> None:
        self.chunks: list[bytes] = []
        self.size = 0
        self.max_bytes = max_bytes
        self.deadline = deadline
        self.timeout_s = timeout_s
        self.error: QueryLimitExceeded | None = None

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


class QueryRunner:
    def __init__(self, backend: Backend, *, timeout_s: float, max_bytes: int, concurrency: int) -> None:
        self.backend = backend
        self.timeout_s = timeout_s
        self.max_bytes = max_bytes
        self._pool = ThreadPoolExecutor(max_workers=concurrency, thread_name_prefix="sparql")
        self._slots = threading.BoundedSemaphore(concurrency)
        self.concurrency = concurrency

    def _job(self, query: str, media: str, writer: LimitedWriter) -> QueryOutcome:
        t0 = time.perf_counter()
        try:
            stopped = False
            try:
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
        raise QueryLimitExceeded(detail, limit="time")

    def close(self) -> None:
        self._pool.shutdown(wait=False, cancel_futures=True)
