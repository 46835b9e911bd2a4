"""Keeping the advisor's snapshot current without making selections wait for a compile.

A snapshot (graph version, vocabulary, compiled rule table) takes about a second to build on the shipped
graph; a selection must pay microseconds. So, once a first snapshot exists (that one is built in the
caller: there is nothing older to answer from), ``Snapshots`` works in one of two modes:

- **background** (the service's): a commit only *marks* the snapshot stale. The stale snapshot keeps
  answering while the next one compiles on a single background thread. One compile runs at a time; commits
  that arrive during a compile are coalesced into exactly one more compile, of whatever the head is when
  it starts. While commits stream in, a compile that follows another waits ``pause`` times as long as the
  last one took (1: compiles get at most half of the process, whose Python threads share one interpreter
  lock with the commits and the requests; docs/service.md, "Pacing", has what bench/bench_fleet.py showed). Staleness
  is bounded: a selection answers from a version at most one compile time plus that pause (at most
  ``MAX_PAUSE_S``: a full compile of a large graph does not hold the next one back for as long) (plus the
  compile already running, when a commit lands mid-compile) behind the last commit made through this
  process, plus ``poll_interval_s`` and one read of the head for commits other processes make to a shared remote
  store (the head is read at most once per interval, on a thread of its own: a selection never waits for it). Each selection says which version answered (``versions["graph"]``),
  the newest version known (``versions["graph_head"]``) and for how long a newer one has been waiting
  (``versions["stale_ms"]``, 0 when fresh).
- **inline** (the library's default; the CLI, evaluations, notebooks): a selection after a commit waits
  for the compile of the new head — read-your-writes, as before background compilation existed.

In both modes ``get(wait=True)``/``sync()`` reads the store's head and returns only a snapshot of that
version or newer: the explicit read-your-writes a caller asks for (the service's editor writes, and a
select with ``?consistency=latest``). A failed background compile is logged and kept (``error``); the
stale snapshot goes on answering and the next commit or ``sync()`` tries again (``sync()`` raises).
"""
from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from typing import Generic, Protocol, TypeVar

log = logging.getLogger("nfex.advisor")
MAX_PAUSE_S = 0.5


class Versioned(Protocol):
    """What ``Snapshots`` keeps: anything with the graph ``version`` it was built from."""

    version: int


S = TypeVar("S", bound=Versioned)


class Snapshots(Generic[S]):
    """``build()`` makes a snapshot of the store's current version; ``head()`` reads the store's head version
    (a store round trip); ``learn(v)`` is called on each commit made through this process."""

    def __init__(self, build: Callable[[], S], head: Callable[[], int], *, poll_interval_s: float = 1.0,
                 background: bool = True, pause: float = 1.0) -> None:
        if pause < 0:
            raise ValueError(f"a compile's pause is a ratio >= 0, got {pause}")
        self._build = build
        self._read_head = head
        self.poll_interval_s = poll_interval_s
        self.background = background
        self.pause = pause
        self._last_compile_s = 0.0  # how long the last background compile took (the next one's pause)
        self._closing = threading.Event()
        self.error: BaseException | None = None
        self.compiles = 0  # snapshots built so far (the tests count coalescing with it)
        self._snap: S | None = None
        self._head = -1  # the newest version known to exist
        self._pending: list[tuple[int, float]] = []  # (version, when it became known), newer than the snapshot
        self._checked_at = float("-inf")  # when the head was last read or told
        self._state = threading.Lock()  # guards the fields above and the worker's hand-over
        self._compile = threading.Lock()  # held while building: one compile at a time
        self._worker: threading.Thread | None = None
        self._wanted = False
        self._closed = False
        self._polling = False  # a head read is under way (``_poll``)
        self._poller: threading.Thread | None = None

    # ------------------------------------------------------------------ what is known
    @property
    def current(self) -> S | None:
        return self._snap

    def learn(self, version: int, now: float | None = None) -> None:
        """A commit (or a read of the head) says ``version`` exists; in background mode a compile is started."""
        self._note(version, now)
        if self.background and self._behind():
            self._kick()

    def _note(self, version: int, now: float | None = None) -> None:
        now = time.monotonic() if now is None else now
        with self._state:
            self._checked_at = now
            if version > self._head:
                self._head = version
                snap = self._snap
                if snap is None or version > snap.version:
                    self._pending.append((version, now))

    def staleness(self, snap: S) -> tuple[int, float]:
        """(the newest version known, ms since a version newer than ``snap`` became known; 0 when fresh)."""
        with self._state:
            head = max(self._head, snap.version)
            waiting = [t for v, t in self._pending if v > snap.version]
        return head, (round((time.monotonic() - waiting[0]) * 1000, 1) if waiting else 0.0)

    def is_fresh(self) -> bool:
        """Whether ``get()`` answers from memory at once: in background mode whenever a snapshot exists (a head
        read due is made on its own thread); inline, when the head was read or told within the poll interval and
        the snapshot is the head's."""
        snap = self._snap
        if snap is not None and self.background:  # a head read due is made on its own thread (``get``)
            return True
        return snap is not None and time.monotonic() - self._checked_at < self.poll_interval_s and not self._behind()

    def _behind(self) -> bool:
        snap = self._snap
        return snap is not None and self._head > snap.version

    # ------------------------------------------------------------------ getting a snapshot
    def get(self, wait: bool = False) -> S:
        """The snapshot a selection answers from (see the module's docstring for the two modes)."""
        snap = self._snap
        if snap is None or wait:
            return self.sync()
        if time.monotonic() - self._checked_at >= self.poll_interval_s:  # a remote store's head moves without telling us
            if self.background:
                self._poll()  # on a thread of its own: a selection does not wait for a round trip to a busy store
            else:
                self.learn(self._read_head())
        if self._behind() and not self.background:
            return self.sync(self._head)
        return self._snap or snap

    def _poll(self) -> None:
        """Read the head on a thread of its own, one read at a time (background mode)."""
        with self._state:
            if self._polling or self._closed:
                return
            self._polling = True

        def run() -> None:
            try:
                self.learn(self._read_head())
            except Exception as e:  # the store is away: the snapshot keeps answering; asked again after an interval
                log.warning("reading the store's head failed: %s", e)
                with self._state:
                    self._checked_at = time.monotonic()
            finally:
                with self._state:
                    self._polling = False

        poller = threading.Thread(target=run, name="nfex-poll", daemon=True)
        try:
            poller.start()
        except BaseException:
            with self._state:
                self._polling = False
            raise
        self._poller = poller

    def sync(self, version: int | None = None) -> S:
        """A snapshot of ``version`` (default: the store's head, read now) or newer; compiles it in the caller
        unless the running compile brings it."""
        target = self._read_head() if version is None else version
        self._note(target)
        with self._compile:
            snap = self._snap
            if snap is not None and snap.version >= target:
                return snap
            return self._install(self._build())

    def _install(self, snap: S) -> S:
        with self._state:
            self.compiles += 1
            old = self._snap
            if old is None or snap.version >= old.version:
                self._snap = old = snap
                self._pending = [(v, t) for v, t in self._pending if v > snap.version]
                self._head = max(self._head, snap.version)
            return old

    # ------------------------------------------------------------------ the background compile
    def _kick(self) -> None:
        with self._state:
            if self._closed:
                return
            self._wanted = True
            if self._worker is None:
                self._worker = threading.Thread(target=self._run, name="nfex-compile", daemon=True)
                self._worker.start()

    def _run(self) -> None:
        """Compile until no commit is waiting, each compile after the first of a stream paced (the module's
        docstring); the thread ends when idle (``_kick`` starts another)."""
        follows = False  # this compile follows another without the thread going idle in between
        while True:
            with self._state:
                if not self._wanted or self._closed:
                    self._worker = None
                    return
                self._wanted = False
            if follows and self.pause > 0 and self._closing.wait(min(self._last_compile_s * self.pause, MAX_PAUSE_S)):
                with self._state:  # close() cut the pause short: no more compiles
                    self._worker = None
                return
            follows = False
            try:
                with self._compile:
                    if self._behind():  # a sync() may have built it meanwhile
                        started = time.monotonic()
                        self._install(self._build())
                        self._last_compile_s = time.monotonic() - started
                        follows = True  # only a compile that ran paces the next
                self.error = None
            except Exception as e:  # the stale snapshot keeps answering; the next commit or sync() retries
                self.error = e
                log.exception("background compile failed; the snapshot of version %s keeps answering",
                              getattr(self._snap, "version", None))

    def wait_idle(self, timeout: float | None = None) -> bool:
        """Wait until no background compile runs or is wanted (for shutdown and tests); False on timeout."""
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            with self._state:
                worker = self._worker
            if worker is None:
                return True
            left = None if deadline is None else deadline - time.monotonic()
            if left is not None and left <= 0:
                return False
            worker.join(left)

    def close(self, timeout: float = 30.0) -> bool:
        """No more background compiles; waits for the running one (the store is about to close). False when it
        was still running after ``timeout`` seconds."""
        with self._state:
            self._closed = True
            poller = self._poller
        self._closing.set()
        if poller is not None:  # a head read under way holds the store
            poller.join(timeout)
        return self.wait_idle(timeout)
