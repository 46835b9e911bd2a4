"""Robust aggregation of windows: the median, with outliers flagged.

Every reader of evidence aggregates a set of windows (per extractor or configuration under a context,
per configuration and frame size for the cost model, per extractor and condition value for the
measured pruning rules) with ``robust``:

    value    = median(x_1 … x_n)
    outliers = #{ i : |x_i − median| > 3 · 1.4826 · MAD },   MAD = median |x_i − median|

The median ignores up to half of the windows being wrong — a few wild reports or a corrupted window move
it little — where the mean follows any single one; 1.4826·MAD estimates the standard deviation of
normal data, so "3 scaled MADs" flags what a 3-σ rule would on clean data, without the outliers
inflating their own yardstick. Outliers are counted and cited, not dropped (the median already
discounts them). With MAD = 0 (half the windows equal) nothing is flagged.
"""
from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

ROBUST = "median"
OUTLIER_SCALE = 3.0 * 1.4826


@dataclass(frozen=True)
class Aggregate:
    """A robust aggregate of windows and what stands behind it."""

    value: float
    windows: int
    outliers: int = 0
    sources: tuple[str, ...] = ()  # distinct sources (a sweep's run, a reporter), sorted

    def describe(self, unit: str = "m", what: str = "ATE") -> str:
        """"median ATE 0.412 m over 12 windows from 2 sources (1 outlier)"."""
        src = f" from {len(self.sources)} source{'s' if len(self.sources) != 1 else ''}" if self.sources else ""
        out = f" ({self.outliers} outlier{'s' if self.outliers != 1 else ''})" if self.outliers else ""
        return f"{ROBUST} {what} {self.value:.3f} {unit} over {self.windows} window{'s' if self.windows != 1 else ''}{src}{out}"


def robust(values: Sequence[float], sources: Iterable[str] = ()) -> Aggregate:
    """The median of ``values`` and its outliers (module docstring); ``values`` must not be empty."""
    x = np.asarray(values, dtype=float)
    med = float(np.median(x))
    mad = float(np.median(np.abs(x - med)))
    outliers = int(np.count_nonzero(np.abs(x - med) > OUTLIER_SCALE * mad)) if mad > 0 else 0
    return Aggregate(med, int(x.size), outliers, tuple(sorted(set(sources))))
