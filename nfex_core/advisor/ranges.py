"""Measured metric ranges: the evidence that narrows a candidate's score bounds below the sound [0, 1] per metric.

bounds.py bounds a candidate's score before extraction with every metric m_x ∈ [0, 1] — sound, and wide: a car's
SIFT and XFEAT intervals overlap by more than the measured accuracy separates them, so α* takes two extractions.
The graph may hold what the metrics have been *measured* to be at the scoring size (``nfex:MetricRange``,
ontology/measurements/metric-ranges.ttl, written by bench/bench_metric_ranges.py):

    single:  m_x(α) ∈ [lo, hi]                              over the calibration frames,
    paired:  m_x(α) − m_x(β) ∈ [lo, hi]  on the same frame   (nfex:relativeTo β),

each the least and the most value seen, widened by the calibration's own margin. Before α is extracted its metric
m_x lies, by this evidence, in the single range intersected with m_x(β) + the paired range for every β already
extracted on the frame; a metric without a range keeps [0, 1]. This is evidence, not a proof: a frame unlike the
calibration frames can have a metric outside its range. So the ranges are used only while they hold on the frame
— every extracted candidate's metrics inside their single ranges, and no intersection empty —; where one does
not, the request falls back to the sound bounds (``Scorer``). The answer says which bounds settled it.
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from ..kg.store import KnowledgeGraph

Span = tuple[float, float]


@dataclass(frozen=True)
class MetricRanges:
    """The graph's measured metric ranges (module docstring): raw metric values, as vision.metrics computes them."""

    single: Mapping[tuple[str, str], Span] = field(default_factory=dict)  # (extractor, metric) → (lo, hi)
    paired: Mapping[tuple[str, str, str], Span] = field(default_factory=dict)  # (α, β, metric) → range of m(α) − m(β)
    source: str = ""  # what they were measured on, in words

    def __bool__(self) -> bool:
        return bool(self.single or self.paired)

    @classmethod
    def load(cls, kg: KnowledgeGraph, held_out: frozenset[str] = frozenset()) -> MetricRanges:
        """The graph's ranges, less those measured on a sequence in ``held_out`` (IRIs: an evidence scope's
        excluded sequences, so an evaluation does not narrow its bounds by what it evaluates)."""
        from ..kg.rdf.terms import py

        rows = kg.select("""SELECT ?x ?m ?y ?lo ?hi ?src (GROUP_CONCAT(STR(?seq)) AS ?seqs) WHERE {
            ?r a nfex:MetricRange ; nfex:rangeExtractor/nfex:token ?x ; nfex:rangeMetric/nfex:token ?m ;
               nfex:rangeLow ?lo ; nfex:rangeHigh ?hi .
            OPTIONAL { ?r nfex:relativeTo/nfex:token ?y } OPTIONAL { ?r nfex:measuredOn ?src }
            OPTIONAL { ?r nfex:rangeSequence ?seq } } GROUP BY ?r ?x ?m ?y ?lo ?hi ?src""").rows
        single: dict[tuple[str, str], Span] = {}
        paired: dict[tuple[str, str, str], Span] = {}
        sources = set()
        for r in rows:
            if held_out & set(str(py(r["seqs"])).split() if r.get("seqs") is not None else ()):
                continue
            span = (float(py(r["lo"])), float(py(r["hi"])))
            if r.get("y") is None:
                single[(str(py(r["x"])), str(py(r["m"])))] = span
            else:
                paired[(str(py(r["x"])), str(py(r["y"])), str(py(r["m"])))] = span
            if r.get("src") is not None:
                sources.add(str(py(r["src"])))
        return cls(single, paired, "; ".join(sorted(sources)))

    def span(self, extractor: str, metric: str, extracted: Mapping[str, Mapping[str, float]]) -> Span | None:
        """The range of ``metric`` for ``extractor`` on a frame where ``extracted`` (extractor → metrics) are known,
        or None where the evidence contradicts itself (an empty intersection: the frame is unlike the calibration)."""
        lo, hi = self.single.get((extractor, metric), (0.0, 1.0))
        for other, metrics in extracted.items():
            d = self.paired.get((extractor, other, metric))
            if d is not None and metric in metrics:
                lo, hi = max(lo, metrics[metric] + d[0]), min(hi, metrics[metric] + d[1])
        lo, hi = max(lo, 0.0), min(hi, 1.0)
        return (lo, hi) if lo <= hi else None

    def holds(self, extracted: Mapping[str, Mapping[str, float]]) -> bool:
        """Whether every measured metric of ``extracted`` lies in its single range (the evidence holds on the frame)."""
        for x, metrics in extracted.items():
            for m, v in metrics.items():
                lo, hi = self.single.get((x, m), (0.0, 1.0))
                if not lo <= v <= hi:
                    return False
        return True
