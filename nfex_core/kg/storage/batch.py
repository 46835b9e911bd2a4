"""Group commit: writes that arrive together are handled by one call, so they share one transaction.

Each commit pays a fixed price — reading the head, checking which triples are present, SHACL on the touched
nodes, the guarded update, and, in the service, the rule table's recompile that every new version triggers.
A fleet of clients reporting per window pays it per report; ``Batcher`` lets them pay it per batch:

    submit(item) ─► queue ─► one flusher thread: a batch opens when its first item can be taken (it arrived,
                             and the last flush has ended) and closes as soon as it holds the items expected,
                             else when ``window_s`` has passed since it opened (or at ``max_items``); then
                             ``flush(items)`` ─► each ``submit`` returns its own result (or raises its own)

A caller returns only after ``flush`` returned, i.e. after its batch is committed (durable): ``submit`` waits for it
on the caller's thread, ``submit_future`` hands back a future instead (the service awaits it on its event loop, so
a report holds no thread while its batch forms and commits, and a fleet is not capped by a thread pool's size); an
item whose future was cancelled before its batch was taken is left out of it. One flush runs at
a time; items that arrive during a flush join the next batch, which opens when the flush ends, so the callers
that flush just answered can join it too — a fleet's clients each post their next report when the last is
answered. The items *expected* are those callers plus the items already waiting when it ended: everyone in the
system then (one, when the first item came more than ``window_s`` after the flush: nobody is waiting for it). So
four clients make batches of four that close as soon as the fourth arrives, a report after a quiet spell goes at
once, and a fleet that grows or shrinks is followed within a batch (one that shrinks costs one wait of ``window_s``). Closing on a window alone kept every batch open for the whole window; counting the
window from the oldest item's arrival sent the items queued during a flush off at once, without the callers
it answered — four clients split into batches of three and one, two commits a round (bench/bench_fleet.py);
closing once arrivals paused for a few ms split them the same way whenever a client was late. An item waits at
most the flush under way plus ``window_s``.
What a batch means — one ``KnowledgeGraph.commit`` of the union, and what happens when it is rejected — is
``flush``'s business (``nfex_core.feedback.ReportWriter``); this module only gathers and hands back.
"""
from __future__ import annotations

import threading
import time
from collections.abc import Callable, Sequence
from concurrent.futures import Future
from dataclasses import dataclass, field
from typing import Any, Generic, TypeVar

T = TypeVar("T")
R = TypeVar("R")


@dataclass
class _Slot(Generic[T]):
    item: T
    arrived: float = field(default_factory=time.monotonic)
    future: Future[Any] = field(default_factory=Future)


class Batcher(Generic[T, R]):
    """``flush(items)`` returns one result or exception per item, in order; ``max_items`` ≥ 1 bounds a batch
    (1: every item alone), ``window_s`` ≥ 0 how long a batch waits at most for the items it expects (the
    module's docstring)."""

    def __init__(self, flush: Callable[[Sequence[T]], Sequence[R | BaseException]], *, max_items: int = 64,
                 window_s: float = 0.02, name: str = "nfex-batch") -> None:
        if max_items < 1 or window_s < 0:
            raise ValueError(f"a batch needs max_items >= 1 and window_s >= 0, got {max_items} and {window_s}")
        self._flush = flush
        self.max_items = max_items
        self.window_s = window_s
        self._free_since = float("-inf")  # when the last flush ended: no batch opens before
        self._expected = 1  # the next batch's size, once this many are queued it closes (the module's docstring)
        self.name = name
        self.batches = 0  # flushes so far, and the items they carried (for tests and /metrics)
        self.items = 0
        self._queue: list[_Slot[T]] = []
        self._cond = threading.Condition()
        self._worker: threading.Thread | None = None
        self._closed = False

    def submit(self, item: T) -> R:
        """Queue ``item``, wait until its batch is flushed, and return its result (or raise its exception)."""
        return self.submit_future(item).result()

    def submit_future(self, item: T) -> Future[R]:
        """Queue ``item``; the future gets its result (or exception) once its batch is flushed."""
        slot: _Slot[T] = _Slot(item)
        with self._cond:
            if self._closed:
                raise RuntimeError(f"{self.name} is closed")
            self._queue.append(slot)
            self._cond.notify()
            if self._worker is None:
                self._worker = threading.Thread(target=self._run, name=self.name, daemon=True)
                self._worker.start()
        return slot.future

    def _take(self) -> list[_Slot[T]]:
        """The next batch (empty when none is queued: the flusher then ends)."""
        with self._cond:
            # the callers the last flush answered come back within a window, or are not expected any more
            expected = self._expected if self._queue and self._queue[0].arrived - self._free_since <= self.window_s else 1
            while self._queue and len(self._queue) < min(expected, self.max_items):
                left = max(self._queue[0].arrived, self._free_since) + self.window_s - time.monotonic()
                if left <= 0:
                    break
                self._cond.wait(left)
            batch = self._queue[: self.max_items]
            del self._queue[: self.max_items]
            if not batch:
                self._worker = None
            return batch

    def _run(self) -> None:
        while batch := self._take():
            batch = [s for s in batch if s.future.set_running_or_notify_cancel()]  # a cancelled item is left out
            if not batch:
                continue
            try:
                results = list(self._flush([s.item for s in batch]))
                if len(results) != len(batch):
                    raise RuntimeError(f"{self.name}: flush returned {len(results)} results for {len(batch)} items")
            except BaseException as e:  # the whole batch failed (e.g. the store went away): every caller hears it
                results = [e] * len(batch)
            with self._cond:
                self._free_since = time.monotonic()
                self._expected = max(1, len(batch) + len(self._queue))  # its callers may come back; the waiting will go
            self.batches += 1
            self.items += len(batch)
            for slot, r in zip(batch, results, strict=True):
                if isinstance(r, BaseException):
                    slot.future.set_exception(r)
                else:
                    slot.future.set_result(r)

    def close(self, timeout: float = 30.0) -> None:
        """Refuse new items; the queued ones are still flushed."""
        with self._cond:
            self._closed = True
            worker = self._worker
        if worker is not None:
            worker.join(timeout)
