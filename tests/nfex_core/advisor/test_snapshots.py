"""Snapshots (nfex_core/advisor/snapshots.py): a stale snapshot answers while the next compiles in the
background, compiles coalesce, staleness is reported, ``sync`` gives read-your-writes. The compile is a fake
the test holds (a build function gated by an Event); the Advisor test uses a real graph.

No test here reads the wall clock: the module's clock is a ``Clock`` the test moves (poll intervals, staleness,
how long a compile took), and a compile's pause is observed as the wait it asks for (``Pauses``)."""
from __future__ import annotations

import threading
from dataclasses import dataclass
from types import SimpleNamespace

import pytest

from nfex_core.advisor import Advisor
from nfex_core.advisor import snapshots as snapshots_module
from nfex_core.advisor.snapshots import Snapshots
from nfex_core.kg import KnowledgeGraph, parse_rdf

from .test_advisor import RULE


class Clock:
    """``time.monotonic`` for the snapshots module: it moves only when the test (or a fake compile) moves it."""

    def __init__(self) -> None:
        self.now = 1000.0
        self._lock = threading.Lock()

    def __call__(self) -> float:
        with self._lock:
            return self.now

    def advance(self, seconds: float) -> None:
        with self._lock:
            self.now += seconds


@pytest.fixture
def clock(monkeypatch: pytest.MonkeyPatch) -> Clock:
    clock = Clock()
    monkeypatch.setattr(snapshots_module, "time", SimpleNamespace(monotonic=clock))
    return clock


class Pauses(threading.Event):
    """A ``Snapshots``' closing event that notes each pause a compile asks for; ``hold`` makes a pause wait for
    ``close()`` (else it returns at once, as a pause that ran out)."""

    def __init__(self, hold: bool = False) -> None:
        super().__init__()
        self.asked: list[float] = []
        self.pausing = threading.Event()
        self.hold = hold

    def wait(self, timeout: float | None = None) -> bool:
        self.asked.append(-1.0 if timeout is None else timeout)
        self.pausing.set()
        return super().wait(None if self.hold else 0)


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


def test_a_selection_does_not_wait_for_a_slow_read_of_a_remote_head(clock: Clock) -> None:
    """Background mode: the head of a shared store, moved by another process, is read on a thread of its own once
    the poll interval is over; the selection that found it due answers while that read is still held, the next
    compile follows."""
    store = Store()
    reading = threading.Event()
    release = threading.Event()

    reads: list[float] = []

    def slow_head() -> int:
        reads.append(clock())
        reading.set()
        assert release.wait(10)
        return store.head

    snaps: Snapshots[Snap] = Snapshots(store.build, slow_head, poll_interval_s=0.05, background=True)
    snaps.sync(1)
    store.head = 2  # another replica's commit: nobody tells this process
    clock.advance(0.06)
    assert snaps.is_fresh() and snaps.get().version == 1  # answered while the read below is held
    assert reading.wait(5) and snaps._poller is not None and snaps._poller.is_alive() and not release.is_set()
    clock.advance(0.06)  # the interval is over again while the first read waits
    assert snaps.get().version == 1 and len(reads) == 1  # one read at a time: no second thread while the first waits
    release.set()
    snaps._poller.join(5)
    assert snaps.wait_idle(5)
    assert snaps.get().version == 2 and store.built == [1, 2]
    snaps.close()


def test_a_failed_read_of_the_head_waits_an_interval(clock: Clock) -> None:
    """The store away: the snapshot answers, and the next read is tried after the poll interval, not at once."""
    store = Store()
    reads: list[float] = []

    def failing() -> int:
        reads.append(clock())
        if len(reads) > 1:
            raise ConnectionError("the store is away")
        return store.head

    snaps: Snapshots[Snap] = Snapshots(store.build, failing, poll_interval_s=0.3, background=True)
    snaps.sync()
    clock.advance(0.31)
    assert snaps.get().version == 1  # due: a read starts on its own thread, and fails
    assert snaps._poller is not None
    snaps._poller.join(5)
    clock.advance(0.29)
    for _ in range(20):  # selections in quick succession, within an interval of the failed read
        assert snaps.get().version == 1
    assert len(reads) == 2, reads
    clock.advance(0.02)
    assert snaps.get().version == 1
    snaps._poller.join(5)
    assert len(reads) == 3, reads  # an interval after the failed read: tried again
    snaps.close()


def test_the_old_snapshot_answers_while_the_next_compiles_and_says_how_stale_it_is(clock: Clock) -> None:
    store, snaps = _held_compile()  # the compile of version 2 runs, and is held
    clock.advance(0.02)
    snap = snaps.get()  # returns while the compile is still held: it did not wait for it
    assert snap.version == 1 and not store.gate.is_set()
    assert snaps.is_fresh()  # the service may answer it on its event loop
    assert snaps.staleness(snap) == (2, pytest.approx(20.0))  # version 2 has been known for 20 ms
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
    waiting = threading.Event()
    sync = snaps.sync

    def note_and_sync() -> None:
        waiting.set()
        done.append(sync().version)

    waiter = threading.Thread(target=note_and_sync)
    waiter.start()
    assert waiting.wait(5)
    waiter.join(0.05)
    assert waiter.is_alive() and done == []  # read-your-writes waits for the held compile of version 2
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
    """A build that takes ``took`` seconds of the test's clock (the clock moves by it while building)."""

    def __init__(self, clock: Clock, took: float) -> None:
        super().__init__()
        self.clock = clock
        self.took = took

    def build(self) -> Snap:
        version = self.head  # a compile reads the head when it starts
        self.started.set()
        assert self.gate.wait(10), "the test never released the compile"
        self.clock.advance(self.took)
        self.built.append(version)
        return Snap(version)


@pytest.mark.parametrize("pause", [0.0, 1.0, 5.0])
def test_a_compile_that_follows_another_waits_its_pause(clock: Clock, pause: float) -> None:
    """A compile that follows another without the thread going idle waits ``pause`` times as long as the last one
    took, at most MAX_PAUSE_S; the first compile after an idle spell waits for nothing."""
    store = Timed(clock, 0.15)
    snaps: Snapshots[Snap] = Snapshots(store.build, lambda: store.head, poll_interval_s=60, background=True, pause=pause)
    pauses = snaps._closing = Pauses()
    snaps.get()  # the first snapshot, in the caller
    store.gate.clear()
    store.started.clear()
    store.commit(snaps)  # a background compile of version 2 starts at once, and is held
    assert store.started.wait(5)
    store.commit(snaps)  # lands mid-compile: one more compile follows
    store.gate.set()
    assert snaps.wait_idle(10) and snaps.current is not None and snaps.current.version == 3
    assert store.built == [1, 2, 3]
    assert pauses.asked == ([pytest.approx(min(0.15 * pause, snapshots_module.MAX_PAUSE_S))] if pause else [])
    pauses.asked.clear()
    store.commit(snaps)  # after an idle spell the thread starts afresh: its first compile is not paced
    assert snaps.wait_idle(10) and store.built == [1, 2, 3, 4]
    assert pauses.asked == []
    snaps.close()


def test_close_cuts_a_pause_short(clock: Clock) -> None:
    store = Timed(clock, 0.3)
    snaps: Snapshots[Snap] = Snapshots(store.build, lambda: store.head, poll_interval_s=60, background=True, pause=1.0)
    pauses = snaps._closing = Pauses(hold=True)  # a pause lasts until close() sets the event
    snaps.get()
    store.gate.clear()
    store.started.clear()
    store.commit(snaps)
    assert store.started.wait(5)
    store.commit(snaps)
    store.gate.set()
    assert pauses.pausing.wait(5)  # the first background compile ended: its follower is pausing
    assert pauses.asked == [pytest.approx(0.3)]
    assert snaps.close(timeout=10)  # True: the worker ended, its pause cut short (it would hold forever)
    assert store.built == [1, 2]  # no compile after close()


def test_a_negative_pause_is_refused() -> None:
    with pytest.raises(ValueError, match="pause"):
        Snapshots(lambda: Snap(1), lambda: 1, pause=-1)
