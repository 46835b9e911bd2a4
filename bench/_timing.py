"""Helpers shared by the bench scripts: timing calls, a free loopback port, waiting for a server process."""
from __future__ import annotations

import socket
import statistics
import subprocess
import time
from collections.abc import Callable, Iterable, Sequence
from typing import Any, TypeVar

T = TypeVar("T")


def call_ms(fn: Callable[[], T], n: int) -> tuple[T, list[float]]:
    """Call ``fn()`` ``n`` times; the last result and each call's wall time in ms."""
    out = []
    result: Any = None
    for _ in range(n):
        t = time.perf_counter()
        result = fn()
        out.append((time.perf_counter() - t) * 1000)
    return result, out


def per_call_us(fn: Callable[[Any], object], items: Sequence[Any] | Iterable[Any], repeat: int = 3) -> float:
    """Median over ``repeat`` passes of the mean time per call of fn(item) over ``items``, in µs."""
    items = list(items)
    runs = []
    for _ in range(repeat):
        t = time.perf_counter()
        for it in items:
            fn(it)
        runs.append((time.perf_counter() - t) / len(items) * 1e6)
    return statistics.median(runs)


def free_port() -> int:
    """A free TCP port on the loopback interface."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def wait_ok(url: str, proc: subprocess.Popen[bytes], timeout: float = 60.0) -> None:
    """Wait until ``url`` answers 200; exit with a message if ``proc`` dies first or the time runs out."""
    import httpx

    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            raise SystemExit(f"the process (pid {proc.pid}) exited with {proc.returncode} before {url} answered")
        try:
            if httpx.get(url, timeout=2).status_code == 200:
                return
        except httpx.HTTPError:
            pass
        time.sleep(0.1)
    raise SystemExit(f"{url} did not answer 200 within {timeout} s")


def cpu_seconds(pid: int, thread: str | None = None) -> float | None:
    """The CPU time (user + system) process ``pid`` has used so far, from /proc; ``thread``: of its threads of that
    name only (e.g. RocksDB's compaction threads, ``rocksdb:low``). None where that cannot be read."""
    import os

    def used(stat: str) -> float:
        with open(stat) as f:
            fields = f.read().rsplit(")", 1)[1].split()  # after the command name, which may hold spaces
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")  # utime, stime (fields 14 and 15)

    try:
        if thread is None:
            return used(f"/proc/{pid}/stat")
        total = 0.0
        for task in os.listdir(f"/proc/{pid}/task"):
            try:
                with open(f"/proc/{pid}/task/{task}/comm") as f:
                    if f.read().strip() == thread:
                        total += used(f"/proc/{pid}/task/{task}/stat")
            except OSError:  # the thread ended meanwhile
                pass
        return total
    except (OSError, ValueError, IndexError):
        return None


def settle(pid: int, idle: float = 0.05, window: float = 1.0, timeout: float = 600.0,
           thread: str | None = None) -> tuple[float, float, float] | None:
    """Wait until process ``pid`` (its threads named ``thread``) uses less than ``idle`` of a core over ``window``
    seconds (a database's start-up or compaction work done): the seconds until the end of the last window with
    work (0 when the first had none: the time it worked, to within a window), the seconds waited in all, and the
    CPU seconds used meanwhile; None where its CPU time cannot be read (not Linux) and nothing was waited for."""
    first = cpu_seconds(pid, thread)
    if first is None:
        return None
    last = first
    t0 = time.monotonic()
    busy = 0.0
    now: float | None = first
    while time.monotonic() - t0 < timeout:
        time.sleep(window)
        now = cpu_seconds(pid, thread)
        if now is None or now - last < idle * window:
            break
        last, busy = now, time.monotonic() - t0
    return busy, time.monotonic() - t0, (last if now is None else now) - first
