"""Work counted, not timed: how many extractions ran and how many pixels they processed.

The registry counts every extraction it runs (``ExtractorRegistry.work``) and the scoring stage counts a request's
own; the tests assert how much a selection extracts with these counts, which are the same on any machine,
so a change that extracts more fails CI instead of waiting for a benchmark.
"""
from __future__ import annotations

import threading


class Work:
    """The extractions a registry has run and the pixels they processed: work counted, not timed (the tests
    assert how much a selection extracts with it)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self.extractions = 0
        self.pixels = 0

    def add(self, pixels: int) -> None:
        with self._lock:
            self.extractions += 1
            self.pixels += pixels

    def totals(self) -> tuple[int, int]:
        """(extractions, pixels) so far."""
        with self._lock:
            return self.extractions, self.pixels
