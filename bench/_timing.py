"""Timing helpers shared by the bench scripts."""
from __future__ import annotations

import statistics
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
