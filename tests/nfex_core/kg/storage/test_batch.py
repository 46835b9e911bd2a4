"""Group commit (nfex_core/kg/storage/batch.py) and the feedback writer on it (nfex_core/feedback.py ReportWriter), on a
real store: writes that arrive together share one graph version, each caller gets its own result, a bad
report fails alone."""
from __future__ import annotations

import threading
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor

import pytest

from nfex_core.errors import UnknownName, ValidationFailed
from nfex_core.feedback import Feedback, ReportWriter, Written
from nfex_core.kg import KnowledgeGraph
from nfex_core.kg.storage.batch import Batcher


class Held:
    """A flush that records its batches and holds the first ones (``hold``) until ``gate`` is set; each item's result
    is ``result(item)``."""

    def __init__(self, hold: int | None = 1, result: Callable[[int], int | BaseException] = lambda i: i) -> None:
        self.gate, self.started = threading.Event(), threading.Event()
        self.batches: list[list[int]] = []
        self.hold, self.result = hold, result

    def __call__(self, items: Sequence[int]) -> list[int | BaseException]:
        self.batches.append(list(items))
        self.started.set()
        if self.hold is None or len(self.batches) <= self.hold:
            assert self.gate.wait(10)
        return [self.result(i) for i in items]

    def release_when_queued(self, batcher: Batcher[int, int], n: int) -> None:
        while len(batcher._queue) < n:  # noqa: SLF001 - the test waits until they are queued
            threading.Event().wait(0.005)
        self.gate.set()


def test_items_queued_during_a_flush_form_one_batch_and_each_caller_gets_its_own_result() -> None:
    flush = Held(hold=None, result=lambda i: ValueError(f"bad {i}") if i == 13 else i * 10)
    batcher: Batcher[int, int] = Batcher(flush, max_items=64, window_s=0.0)
    with ThreadPoolExecutor(12) as pool:
        head = pool.submit(batcher.submit, 0)
        assert flush.started.wait(5)  # the first item is being flushed (held); these eleven queue meanwhile
        rest = {i: pool.submit(batcher.submit, i) for i in range(10, 21)}
        flush.release_when_queued(batcher, 11)
        assert head.result(5) == 0
        for i, f in rest.items():
            if i == 13:
                with pytest.raises(ValueError, match="bad 13"):
                    f.result(5)
            else:
                assert f.result(5) == i * 10
    assert flush.batches == [[0], list(range(10, 21))] and batcher.batches == 2 and batcher.items == 12


def test_the_callers_a_flush_answered_join_the_items_queued_during_it() -> None:
    """A batch opens when the last flush ends and expects the callers it answered and the items waiting: a fleet's
    clients, each posting again once answered, join the reports that queued meanwhile instead of those going off
    alone (three and one, round after round), and the batch goes as soon as they are in, not after the window."""
    flush = Held()
    batcher: Batcher[int, int] = Batcher(flush, max_items=64, window_s=60.0)  # a minute: the results would time out

    def client(i: int) -> int:  # answered, it reports again at once
        return batcher.submit(i) + batcher.submit(i + 100)

    with ThreadPoolExecutor(2) as pool:
        first = pool.submit(client, 1)
        assert flush.started.wait(5)
        queued = pool.submit(batcher.submit, 2)  # arrives while the first batch is being flushed
        flush.release_when_queued(batcher, 1)
        assert first.result(10) == 1 + 101 and queued.result(10) == 2
    assert flush.batches == [[1], [2, 101]]


def test_a_caller_that_does_not_come_back_costs_one_window() -> None:
    flush = Held(hold=None)
    batcher: Batcher[int, int] = Batcher(flush, max_items=64, window_s=0.2)
    with ThreadPoolExecutor(2) as pool:
        first = pool.submit(batcher.submit, 1)
        assert flush.started.wait(5)
        second = pool.submit(batcher.submit, 2)
        flush.release_when_queued(batcher, 1)
        assert first.result(10) == 1 and second.result(10) == 2  # 2 expected 1 to come back: it went after the window
        assert batcher._expected == 1  # noqa: SLF001 - and the next batch expects one again
    assert flush.batches == [[1], [2]]


def test_a_lone_item_goes_at_once() -> None:
    batcher: Batcher[int, int] = Batcher(list, max_items=64, window_s=60.0)
    with ThreadPoolExecutor(1) as pool:
        assert pool.submit(batcher.submit, 7).result(30) == 7  # a minute's window would time this out


def test_a_batch_is_bounded_by_count() -> None:
    seen: list[int] = []
    batcher: Batcher[int, int] = Batcher(lambda items: (seen.append(len(items)), list(items))[1], max_items=3, window_s=0.5)
    with ThreadPoolExecutor(7) as pool:
        assert sorted(pool.map(batcher.submit, range(7))) == list(range(7))
    assert max(seen) <= 3 and sum(seen) == 7


def test_a_future_gets_its_result_and_a_cancelled_item_is_left_out() -> None:
    """``submit_future``: no thread waits; the future gets the item's result or exception once its batch is flushed,
    and an item cancelled before its batch was taken is not flushed (the others of its batch are)."""
    flush = Held(hold=1, result=lambda i: ValueError(f"bad {i}") if i == 3 else i * 10)
    batcher: Batcher[int, int] = Batcher(flush, max_items=64, window_s=0.5)
    first = batcher.submit_future(1)
    assert flush.started.wait(5)
    queued = [batcher.submit_future(i) for i in (2, 3, 4)]  # queued during the first flush
    assert queued[2].cancel()  # 4: its caller went away
    flush.release_when_queued(batcher, 3)
    assert first.result(10) == 10 and queued[0].result(10) == 20
    with pytest.raises(ValueError, match="bad 3"):
        queued[1].result(10)
    assert queued[2].cancelled()
    assert flush.batches == [[1], [2, 3]]


def _report(i: int, **fields: object) -> Feedback:
    return Feedback(**{"extractor": "ORB", "context": {"agent": "car"}, "sequence": "batch/test", "reporter": f"r{i % 3}",
                       "window_start": 10 * i, "window_end": 10 * i + 10, "ate_rmse": 0.5 + i / 100, **fields})  # type: ignore[arg-type]


def test_concurrent_reports_are_committed_in_fewer_versions_and_a_bad_one_fails_alone(kg: KnowledgeGraph) -> None:
    writer = ReportWriter(kg, max_items=64, window_s=0.05)
    v0 = kg.version
    reports = [_report(i) for i in range(12)]
    reports[4] = _report(4, frames=0)  # passes the Python checks, violates MeasurementShape (frameCount ≥ 1)
    reports[7] = _report(7, extractor="FAST9")  # an unknown extractor: fails while its graph is built
    with ThreadPoolExecutor(12) as pool:
        futures = [pool.submit(writer.write, fb) for fb in reports]
        outcomes: list[Written | BaseException] = []
        for f in futures:
            try:
                outcomes.append(f.result(60))
            except Exception as e:  # noqa: BLE001 - each report's own outcome is what is checked
                outcomes.append(e)
    writer.close()
    assert isinstance(outcomes[4], ValidationFailed) and "frameCount" in str(outcomes[4])
    assert isinstance(outcomes[7], UnknownName)
    good = [o for i, o in enumerate(outcomes) if i not in (4, 7)]
    assert all(isinstance(o, Written) for o in good)
    iris = {o.iri for o in good if isinstance(o, Written)}
    assert len(iris) == 10  # each report its own Measurement
    versions = kg.version - v0
    assert 1 <= versions < 10, f"{versions} versions for 10 committed reports"
    for o in good:
        assert isinstance(o, Written) and kg.ask(f"ASK {{ <{o.iri}> a nfex:Measurement }}")
