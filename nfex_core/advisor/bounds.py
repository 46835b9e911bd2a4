"""Bounds on a candidate's frame score before it is extracted, and which extraction narrows them most per ms.

A candidate's score on a frame is score(α) = bonus(α) + Σ_x h_x(E)·m_x + H·A(α) (scoring.py), and every metric
m_x lies in [0, 1] (vision.metrics; oriented so that 1 is best, fitness.oriented). Before α is extracted its
score therefore lies in

    low(α)  = bonus(α) + Σ_{x ∈ M(α)} min(0, h_x) + H·A(α),
    high(α) = bonus(α) + Σ_{x ∈ M(α)} max(0, h_x) + H·A(α),

M(α) the metrics α will have on this frame (the single-frame ones, and the temporal ones where the previous
frame holds α); an unweighted metric weighs 1, as in fitness.f_metrics. Where the graph holds measured metric
ranges (ranges.py), ``score_bounds`` with ``spans`` replaces each [0, 1] by the measured range [lo_x, hi_x] of the oriented
metric: low(α) = bonus + Σ min(h_x·lo_x, h_x·hi_x) + H·A(α), high likewise with max — evidence, not a proof. Once α is extracted, low = high = its
score. α* is settled when one candidate's low exceeds every other candidate's high by SCORE_MARGIN — then
nothing more is extracted, possibly nothing at all — or when every candidate that can still reach the leader's
low has been scored (the tie-break of choice.py decides among equal scores).

Until then one candidate is extracted at a time: the one whose extraction is expected to narrow the gap

    G = max_{r ≠ L, high(r) ≥ low(L)} high(r) − low(L),   L = argmax low,

most per expected millisecond. Extracting c replaces its interval by its score, expected at the interval's
midpoint: the leader's extraction raises low(L) and narrows the gap to every rival at once; a rival's lowers
only its own high, and narrows G only if it is the highest. The expected time is the cost model's at the
scoring size (nfex_core/cost.py), doubled where the previous frame still owes the candidate's features.
"""
from __future__ import annotations

import math
from collections.abc import Iterable, Mapping

from ..kg.vocabulary.vocab import MetricSpec
from ..rules.types import Decision

SCORE_MARGIN = 1e-9  # a bound decides only by more than rounding


def score_bounds(decision: Decision, specs: Mapping[str, MetricSpec], metric_names: Iterable[str], extractor: str,
                 accuracy: float, weight: float, spans: Mapping[str, tuple[float, float]] | None = None
                 ) -> tuple[float, float]:
    """(low, high) of F_metrics + H·A for ``extractor`` before extraction, over the ``metric_names`` it will have
    that the graph knows (``specs``), each metric's raw value in its ``spans`` entry (default [0, 1], the sound
    bound), oriented as fitness.oriented turns it (module docstring)."""
    bonus = decision.bonus(extractor)
    low = high = bonus + weight * accuracy
    for m in metric_names:
        if m not in specs:
            continue
        lo, hi = (spans or {}).get(m, (0.0, 1.0))
        if not specs[m].higher_is_better:
            lo, hi = 1.0 - hi, 1.0 - lo
        w = decision.weights[m].value if m in decision.weights else 1.0
        low += min(w * lo, w * hi)
        high += max(w * lo, w * hi)
    return low, high


def leader(intervals: Mapping[str, tuple[float, float]]) -> str:
    """The candidate with the highest low bound (then the highest high)."""
    return max(intervals, key=lambda x: intervals[x])


def contenders(intervals: Mapping[str, tuple[float, float]]) -> tuple[str, list[str]]:
    """The leader and the others that can still reach its low bound."""
    top = leader(intervals)
    low = intervals[top][0]
    return top, [x for x, (_, high) in intervals.items() if x != top and high >= low - SCORE_MARGIN]


def out_of_top(intervals: Mapping[str, tuple[float, float]], x: str, k: int) -> bool:
    """Whether ``k`` other candidates certainly score more than ``x``."""
    high = intervals[x][1]
    return sum(1 for y, (low, _) in intervals.items() if y != x and low > high + SCORE_MARGIN) >= k


def next_extraction(intervals: Mapping[str, tuple[float, float]], open_: Iterable[str],
                    ms: Mapping[str, float], k: int = 1) -> str | None:
    """The candidate to extract next, or None when α* is settled (module docstring). ``intervals``: every
    candidate's (low, high), equal for the scored; ``open_``: those not extracted yet; ``ms``: expected times.
    ``k`` > 1 (a verified pair tries the first k proposals in order): every candidate that may be among the
    first k is extracted, the most promising (highest high bound) first, so their order is exact."""
    if k > 1:
        pending = [x for x in open_ if not out_of_top(intervals, x, k)]
        return max(pending, key=lambda x: (intervals[x][1], -ms.get(x, math.inf))) if pending else None
    top, rivals = contenders(intervals)
    pending = [x for x in (top, *rivals) if x in set(open_)]
    if not rivals or not pending:
        return None
    low = intervals[top][0]
    gap = max(intervals[r][1] for r in rivals) - low

    def value(c: str) -> tuple[float, float, float]:
        mid = sum(intervals[c]) / 2
        if c == top:
            after = max(intervals[r][1] for r in rivals) - mid
        else:
            after = max([intervals[r][1] for r in rivals if r != c] + [mid]) - low
        narrowing = gap - max(after, 0.0)
        cost = ms.get(c, math.inf)
        per_ms = narrowing / cost if 0 < cost < math.inf else 0.0
        return per_ms, narrowing, intervals[c][1]

    return max(pending, key=value)


def settled_reason(intervals: Mapping[str, tuple[float, float]], alpha: str, evidence: str = "") -> str:
    """Why ``alpha`` is α* without being extracted: its low bound against every other high bound (``evidence``: the
    measured metric ranges the bounds rest on, where they do)."""
    low = intervals[alpha][0]
    others = [(h, x) for x, (_, h) in intervals.items() if x != alpha]
    high, best = max(others, default=(-math.inf, "no other candidate"))
    within = f"with its metrics in the ranges measured on {evidence}" if evidence else "whatever its metrics"
    return (f"settled by bounds: its score is at least {low:.4f} {within} and no other candidate's can "
            f"exceed {high:.4f} ({best}); not extracted, its score is that least value")
