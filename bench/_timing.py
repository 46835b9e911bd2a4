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
