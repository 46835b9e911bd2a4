"""Snapshots (nfex_core/advisor/snapshots.py): a stale snapshot answers while the next compiles in the
background, compiles coalesce, staleness is reported, ``sync`` gives read-your-writes. The compile is a fake
the test holds (a build function gated by an Event); the Advisor test at the end uses a real graph."""
from __future__ import annotations

import threading
import time
from dataclasses import dataclass

import pytest

from nfex_core.advisor import Advisor
from nfex_core.advisor.snapshots import Snapshots
from nfex_core.kg import KnowledgeGraph, parse_rdf

from .test_advisor import RULE


@dataclass
class Snap:
    version: int


class Store:
    """A head version the test moves, and a build whose progress the test controls."""

    def __init__(self) -> None:
        self.head = 1
        self.gate = threading.Event()
        self.gate.set()
        self.started = threading.Event()
        self.built: list[int] = []
        self.fail = False

    def build(self) -> Snap:
        version = self.head  # a compile reads the head when it starts
        self.started.set()
        assert self.gate.wait(10), "the test never released the compile"
        if self.fail:
            raise RuntimeError("compile failed")
        self.built.append(version)
        return Snap(version)

    def commit(self, snaps: Snapshots[Snap]) -> None:
        self.head += 1
        snaps.learn(self.head)


def _background(store: Store) -> Snapshots[Snap]:
    snaps: Snapshots[Snap] = Snapshots(store.build, lambda: store.head, poll_interval_s=60, background=True)
    assert snaps.get().version == 1 and store.built == [1]  # the first snapshot: built in the caller
    return snaps



def _held_compile() -> tuple[Store, Snapshots[Snap]]:
    """A background Snapshots at version 1 whose compile of version 2 has started and is held (``store.gate``)."""
    store = Store()
    snaps = _background(store)
    store.gate.clear()
    store.started.clear()
    store.commit(snaps)
    assert store.started.wait(5)
    return store, snaps


def test_a_selection_does_not_wait_for_a_slow_read_of_a_remote_head() -> None:
    """Background mode: the head of a shared store, moved by another process, is read on a thread of its own once
    the poll interval is over; the selection that found it due answers at once, the next compile follows."""
    store = Store()
    reading = threading.Event()
    release = threading.Event()

    reads: list[float] = []

    def slow_head() -> int:
        reads.append(time.monotonic())
        reading.set()
        assert release.wait(10)
        return store.head

    snaps: Snapshots[Snap] = Snapshots(store.build, slow_head, poll_interval_s=0.05, background=True)
    snaps.sync(1)
    store.head = 2  # another replica's commit: nobody tells this process
    time.sleep(0.06)
    t = time.monotonic()
    assert snaps.is_fresh() and snaps.get().version == 1 and time.monotonic() - t < 0.5
    assert reading.wait(5)
    time.sleep(0.06)  # the interval is over again while the first read waits
    assert snaps.get().version == 1 and len(reads) == 1  # one read at a time: no second thread while the first waits
    release.set()
    deadline = time.monotonic() + 5
    while snaps.get().version < 2 and time.monotonic() < deadline:
        time.sleep(0.01)
    assert snaps.get().version == 2 and store.built == [1, 2]
    snaps.close()


def test_a_failed_read_of_the_head_waits_an_interval() -> None:
    """The store away: the snapshot answers, and the next read is tried after the poll interval, not at once."""
    store = Store()
    reads: list[float] = []

    def failing() -> int:
        reads.append(time.monotonic())
        if len(reads) > 1:
            raise ConnectionError("the store is away")
        return store.head

    snaps: Snapshots[Snap] = Snapshots(store.build, failing, poll_interval_s=0.3, background=True)
    snaps.sync()
    time.sleep(0.31)
    for _ in range(20):  # selections in quick succession
        assert snaps.get().version == 1
        time.sleep(0.005)
    assert len(reads) == 2, reads
    snaps.close()


def test_the_old_snapshot_answers_while_the_next_compiles_and_says_how_stale_it_is() -> None:
    store, snaps = _held_compile()  # the compile of version 2 runs, and is held
    time.sleep(0.02)
    snap = snaps.get()  # returns while the compile is still held: it did not wait for it
    assert snap.version == 1 and not store.gate.is_set()
    assert snaps.is_fresh()  # the service may answer it on its event loop
    head, stale_ms = snaps.staleness(snap)
    assert head == 2 and stale_ms >= 20
    store.gate.set()
    assert snaps.wait_idle(5)
    fresh = snaps.get()
    assert fresh.version == 2 and snaps.staleness(fresh) == (2, 0.0)


def test_commits_during_a_compile_coalesce_into_exactly_one_more() -> None:
    store, snaps = _held_compile()
    for _ in range(5):  # versions 3..7 land while version 2 compiles
        store.commit(snaps)
    store.gate.set()
    assert snaps.wait_idle(5)
    assert store.built == [1, 2, 7] and snaps.compiles == 3 and snaps.get().version == 7


def test_sync_waits_for_the_head_and_inline_mode_never_answers_stale() -> None:
    store, snaps = _held_compile()
    done: list[int] = []
    waiter = threading.Thread(target=lambda: done.append(snaps.sync().version))
    waiter.start()
    time.sleep(0.05)
    assert done == []  # read-your-writes waits for the compile of version 2
    store.gate.set()
    waiter.join(5)
    assert done == [2]

    inline = Store()
    snaps = Snapshots(inline.build, lambda: inline.head, poll_interval_s=60, background=False)
    assert snaps.get().version == 1
    inline.commit(snaps)
    assert not snaps.is_fresh() and snaps.get().version == 2 and inline.built == [1, 2]


def test_a_failed_background_compile_is_kept_and_the_old_snapshot_answers() -> None:
    store = Store()
    snaps = _background(store)
    store.fail = True
    store.commit(snaps)
    assert snaps.wait_idle(5)
    assert isinstance(snaps.error, RuntimeError) and snaps.get().version == 1
    with pytest.raises(RuntimeError, match="compile failed"):
        snaps.sync()
    store.fail = False
    assert snaps.sync().version == 2


def test_the_advisor_in_background_mode_reports_versions_and_reads_its_writes_when_asked(bare_kg: KnowledgeGraph) -> None:
    advisor = Advisor(bare_kg, neural="symbolic", background=True)
    ctx = {"reflectance": "reflective", "light": "bright", "texture": "high"}
    before = advisor.select(ctx)
    v0 = bare_kg.version
    assert before.extractor == "ORB" and before.versions["graph"] == before.versions["graph_head"] == v0
    assert before.versions["stale_ms"] == 0
    bare_kg.add(parse_rdf(RULE), author="test")
    during = advisor.select(ctx)  # answers at once: from v0 while v0 + 1 compiles, or from v0 + 1 when done
    assert during.versions["graph_head"] == v0 + 1 and during.versions["graph"] in (v0, v0 + 1)
    assert (during.versions["stale_ms"] > 0) == (during.versions["graph"] == v0)
    after = advisor.select(ctx, consistency="latest")  # read-your-writes, as the service's ?consistency=latest
    assert after.extractor != "ORB" and after.versions["graph"] == v0 + 1 and after.versions["stale_ms"] == 0
    advisor.close()


class Timed(Store):
    """A build that takes ``took`` seconds and notes when each started and ended."""

    def __init__(self, took: float) -> None:
        super().__init__()
        self.took = took
        self.spans: list[tuple[float, float]] = []

    def build(self) -> Snap:
        start, version = time.monotonic(), self.head  # a compile reads the head when it starts
        self.started.set()
        time.sleep(self.took)
        self.built.append(version)
        self.spans.append((start, time.monotonic()))
        return Snap(version)


@pytest.mark.parametrize("pause", [0.0, 1.0])
def test_a_compile_that_follows_another_waits_its_pause(pause: float) -> None:
    store = Timed(0.15)
    snaps: Snapshots[Snap] = Snapshots(store.build, lambda: store.head, poll_interval_s=60, background=True, pause=pause)
    snaps.get()  # the first snapshot, in the caller
    store.started.clear()
    store.commit(snaps)  # a background compile of version 2 starts at once
    assert store.started.wait(5)
    time.sleep(0.05)
    store.commit(snaps)  # lands mid-compile: one more compile follows
    assert snaps.wait_idle(10) and snaps.current is not None and snaps.current.version == 3
    assert store.built == [1, 2, 3]
    (_, first_end), (second_start, _) = store.spans[-2:]
    gap = second_start - first_end
    if pause:
        assert 0.14 <= gap < 0.5, gap  # about as long as the last compile took
    else:
        assert gap < 0.1, gap
    committed = time.monotonic()
    store.commit(snaps)  # after an idle spell the thread starts afresh: its first compile is not paced
    assert snaps.wait_idle(10)
    assert store.spans[-1][0] - committed < 0.1
    snaps.close()


def test_close_cuts_a_pause_short() -> None:
    store = Timed(0.3)
    snaps: Snapshots[Snap] = Snapshots(store.build, lambda: store.head, poll_interval_s=60, background=True, pause=1.0)
    snaps.get()
    store.started.clear()
    store.commit(snaps)
    assert store.started.wait(5)
    time.sleep(0.05)
    store.commit(snaps)
    while len(store.spans) < 2:  # the first background compile ended: its follower is pausing
        time.sleep(0.01)
    t = time.monotonic()
    snaps.close()
    assert time.monotonic() - t < 0.25


def test_a_negative_pause_is_refused() -> None:
    with pytest.raises(ValueError, match="pause"):
        Snapshots(lambda: Snap(1), lambda: 1, pause=-1)
