"""The flow's ``scoring`` stage: a score per candidate, from the frame or, without one, from the graph.

On a frame (paper §IV-A, step 2, extended by measured accuracy): each candidate is extracted with its Θ′
on a QQVGA-sized copy of the frame (``SCORE_PIXELS``; count parameters scaled to its size) and scored

    score(α) = F_metrics(α | Θ′, E) + H·A(α),   F_metrics = Σ_x h_x(E)·m_x (+ bonus),   H = Σ_x h_x(E),

A(α) = min_{y ∈ C} ATE(y) / ATE(α) ∈ (0, 1] over the candidates C with measured windows under E, ATE the
median over the admitted windows (the Decision's evidence, nfex_core/evidence/; an unmeasured candidate has A = 0): the measured outcome weighs as much as all the
frame's proxies together. Where SelectorNet is in use its probabilities, masked to C(E), replace the
scores when its own first choice is a candidate; the candidates it was not trained on are then listed
with probability 0 and not extracted at all.

Only what can still win is extracted (Scorer): SelectorNet's choice is settled by interval bounds over the
metrics not yet measured, and under F_metrics every score is bounded from both sides before extraction
(bounds.py; each metric's [0, 1] narrowed by the graph's measured metric ranges while they hold on the frame,
ranges.py) and only what can narrow the leader's margin is extracted — nothing, where the bounds alone settle
α*; α* and Θ′ are those of scoring every candidate (over the measured ranges: where the frame's metrics lie in them). The Selection's ``scoring`` says which (scored, settled,
unscored) and how many extractions and pixels it took.

Without a frame (mode ``prior``): score(α) = bonus + A(α), computed once per context and snapshot.
"""
from __future__ import annotations

import math
import threading
from collections.abc import Iterable, Mapping
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from ..evidence.cost import CostModel
from ..kg.vocabulary.vocab import ExtractorSpec, Value, Vocabulary
from ..neural.serve import BoundedChoice, NeuralStep
from ..rules.fitness import f_metrics
from ..rules.types import Decision
from ..vision.work import Work
from .bounds import contenders, next_extraction, score_bounds, settled_reason
from .params import Candidate, Parameters
from .ranges import MetricRanges
from .reuse import Decided
from .selection import SCORED, SETTLED, CandidateEvidence, CandidateScore, Scoring

# QQVGA: the scoring copy's pixel count, whatever the aspect ratio (KITTI: 251×76). bench/bench_resolution.py
# (docs/results/resolution.json): on 71 frames of the shared sequences × 6 contexts, α* at 160×120 equals α* at
# 320×240, at half and at a quarter of the frame's side on all 426 selections (each 96.2 % of α* on the full frame)
SCORE_PIXELS = 160 * 120


@dataclass(frozen=True)
class FrameState:
    """What a stream keeps from one frame for the next: the scoring image, the Θ′ (at the scoring size) of every
    candidate exhaustive scoring would have extracted on it, the features of those actually extracted — the next
    frame extracts the others from ``image`` only if its temporal metrics need them —, the decision a next frame
    may reuse (reuse.py) and the copy of the frame its statistics were computed on (the next frame's motion)."""

    image: np.ndarray
    features: dict[str, Any]
    params: dict[str, dict[str, Value]] = field(default_factory=dict)
    decided: Decided | None = None
    analysis: np.ndarray | None = None  # the frame statistics' copy of this frame: the next frame's motion reads it

    @property
    def owed(self) -> dict[str, dict[str, Value]]:
        """The candidates skipped on this frame that a next frame's temporal metrics may still need."""
        return {x: p for x, p in self.params.items() if x not in self.features}

    def has(self, extractor: str) -> bool:
        return extractor in self.features or extractor in self.params

    def previous(self, extractor: str, shape: tuple[int, ...], registry: Any) -> tuple[Any, np.ndarray] | None:
        """``(features, image)`` of ``extractor`` on this frame for the temporal metrics of a frame of ``shape``."""
        if self.image.shape != shape:
            return None
        if extractor not in self.features and extractor in self.params:
            self.features[extractor] = registry.extract(extractor, self.image, self.params[extractor])
        feats = self.features.get(extractor)
        return None if feats is None else (feats, self.image)


@dataclass
class Scored:
    """The stage's output: every candidate with its score (None: listed, not scored), the stream state
    for the next frame, and how the scores were made (``metrics`` | ``selectornet`` | ``prior``)."""

    candidates: list[CandidateScore]
    state: FrameState | None
    mode: str
    scoring: Scoring | None = None


@dataclass
class Scorer:
    """Scores candidates on frames; ``threads`` extract them side by side (OpenCV releases the GIL).

    Only what can still win is extracted (``exhaustive=False``, the default). Where SelectorNet is in use,
    the candidates it knows are extracted cheapest first until its choice is settled whatever the metrics
    of the rest (``NeuralStep.bounded_choice``: interval bounds over their [0, 1] range). Where F_metrics
    decides, every candidate's score is bounded from both sides before anything is extracted (bounds.py: the
    bonus, H·A and the range of each metric it will have); a candidate is extracted only while the leader's low
    bound is below another's high bound, one at a time, the one whose extraction narrows that gap most per
    expected ms; the graph's measured metric ranges narrow those bounds while they hold on the
    frame (ranges.py). When the bounds settle α* nothing is extracted. α*, Θ′ and the order of the scored candidates
    are those of exhaustive scoring; candidates not extracted are listed with the reason (α*, when settled by
    bounds, with its least score). Where a verified pair tries the first ``top`` proposals, every candidate
    that may be among them is scored, so their order is exact. ``exhaustive=True`` scores every candidate."""

    score_pixels: int = SCORE_PIXELS
    threads: int = 2
    _pool: ThreadPoolExecutor | None = field(default=None, repr=False)
    _lock: threading.Lock = field(default_factory=threading.Lock, repr=False)

    def pool(self) -> ThreadPoolExecutor:
        if self._pool is None:
            with self._lock:
                if self._pool is None:
                    self._pool = ThreadPoolExecutor(max(1, self.threads), thread_name_prefix="nfex-score")
        return self._pool

    def on_frame(
        self,
        vocab: Vocabulary,
        registry: Any,
        decision: Decision,
        params: Parameters,
        nn: NeuralStep,
        image: np.ndarray,
        previous: FrameState | None,
        exhaustive: bool = False,
        cost: CostModel | None = None,
        top: int = 1,
        ranges: MetricRanges | None = None,
    ) -> Scored:
        """Score the candidates of ``params`` on ``image`` that can still win (class docstring); ``cost`` gives each
        candidate's expected extraction time at the scoring size (the order of extraction, bounds.py); ``top``: how
        many of the first candidates must be in exact order (a verified pair's proposals); ``ranges``: the graph's
        measured metric ranges, which narrow the bounds while they hold on the frame (ranges.py)."""
        from ..vision.metrics import SINGLE_FRAME, TEMPORAL, compute_metrics

        small = downscale(image, self.score_pixels)
        ratio = (small.shape[0] * small.shape[1]) / (image.shape[0] * image.shape[1])
        accuracy = measured_accuracy(decision, params.candidates)
        weight = sum(w.value for w in decision.weights.values())  # H: F_metrics' most without the bonus
        at_scale = {x: scaled(vocab.extractor(x), c.params, ratio) for x, c in params.candidates.items()}
        done: dict[str, tuple[CandidateScore, Any]] = {}
        tally = _Tally()

        def score(c: Candidate, alone: bool = False) -> tuple[CandidateScore, Any]:
            owed = previous is not None and c.extractor not in previous.features and temporal(c.extractor)
            # the previous frame's owed extraction runs beside this frame's (OpenCV releases the GIL); only when this
            # candidate is scored alone, so a pool busy with a wave never waits on itself
            beside = self.pool().submit(previous.previous, c.extractor, small.shape, registry) \
                if owed and alone and previous is not None and self.threads > 1 else None
            feats = registry.extract(c.extractor, small, at_scale[c.extractor])
            tally.add(small.size)
            if beside is not None:
                prev = beside.result()
            else:
                prev = previous.previous(c.extractor, small.shape, registry) if previous is not None else None
            if owed and prev is not None:
                tally.add(prev[1].size)
            metrics = compute_metrics(feats, small, prev)
            bonus = decision.bonus(c.extractor)
            f = f_metrics(metrics, decision.weights, vocab.metrics, bonus)
            a = accuracy.get(c.extractor, 0.0)
            return CandidateScore(
                extractor=c.extractor, params=c.params, score=f + weight * a, bonus=bonus,
                metrics={k: round(v, 6) for k, v in metrics.items()}, adjustments=c.adjustments,
                keypoints=len(feats.xy), extraction_ms=round(feats.elapsed_ms, 3),
                evidence=replace(evidence_of(decision, c), f_metrics=f, measured_accuracy=a),
            ), feats

        def run(cs: list[Candidate]) -> None:
            out = list(self.pool().map(score, cs)) if len(cs) > 1 else [score(c, alone=True) for c in cs]
            done.update((s.extractor, (s, feats)) for s, feats in out)

        def state(extracted_by_exhaustive: Iterable[str]) -> FrameState:
            features = {x: feats for x, (_, feats) in done.items()}
            return FrameState(small, features, {x: at_scale[x] for x in {*extracted_by_exhaustive, *done}})

        def temporal(x: str) -> bool:
            return previous is not None and previous.image.shape == small.shape and previous.has(x)

        def will_have(x: str) -> tuple[str, ...]:
            """The metrics candidate ``x`` will have once extracted on this frame."""
            return (*SINGLE_FRAME, *TEMPORAL) if temporal(x) else SINGLE_FRAME

        everything = list(params.candidates.values())
        known = nn.selector_extractors if nn.selectornet else frozenset()
        first = sorted((c for c in everything if c.extractor in known), key=lambda c: expected_ms(decision, c))
        if first and (exhaustive or top > 1):  # SelectorNet's candidates; the rest below if it does not decide
            run(first)
        elif exhaustive:
            run(everything)
        # SelectorNet is masked to what it was trained on: its candidates are scored first; if it decides, the
        # others (probability 0 whatever their F_metrics) are not extracted at all
        while first:
            todo = [c for c in first if c.extractor not in done]
            if todo:
                unknown = {c.extractor: will_have(c.extractor) for c in todo}
                bound = nn.bounded_choice(image, {x: s.metrics for x, (s, _) in done.items()}, unknown, list(params.candidates))
                if bound is not None and bound.allowed:
                    listed = settled(decision, params, bound, known, done)
                    return Scored(listed, state(c.extractor for c in first), "selectornet", tally.scoring(
                        SCORED if bound.extractor in done else SETTLED,
                        "SelectorNet's choice, settled by interval bounds over the metrics not measured"))
                if bound is None:
                    run(todo[:1])  # cheapest first: each extraction may settle the choice
                    continue
            else:
                scored = [done[c.extractor][0] for c in everything if c.extractor in done]
                rest = [unscored(decision, c) for c in everything if c.extractor not in known]
                ranked, decided = by_network(nn, image, scored, scored + rest)
                if decided:
                    return Scored(ranked, state(done), "selectornet", tally.scoring(SCORED, "SelectorNet's probabilities"))
            break  # SelectorNet declines: F_metrics and the measured accuracy decide among all candidates
        by_name = {c.extractor: c for c in everything}
        bounds = {x: score_bounds(decision, vocab.metrics, will_have(x), x, accuracy.get(x, 0.0), weight) for x in by_name}
        evidence = ranges if ranges and not exhaustive else None
        held = [evidence is not None]  # whether the measured ranges held on this frame so far

        def narrowed(x: str, extracted: Mapping[str, Mapping[str, float]]) -> tuple[float, float] | None:
            assert evidence is not None
            spans = {}
            for m in will_have(x):
                span = evidence.span(x, m, extracted)
                if span is None:
                    return None
                spans[m] = span
            return score_bounds(decision, vocab.metrics, will_have(x), x, accuracy.get(x, 0.0), weight, spans)
        ms = {x: extraction_ms(cost, vocab, x, at_scale[x], small.shape, decision, by_name[x]) * (1 + (
            previous is not None and temporal(x) and x not in previous.features)) for x in by_name}

        def intervals() -> dict[str, tuple[float, float]]:
            out = dict(bounds)
            if held[0] and evidence is not None:
                extracted = {x: s.metrics for x, (s, _) in done.items()}
                tight = {x: narrowed(x, extracted) for x in by_name if x not in done}
                held[0] = evidence.holds(extracted) and all(b is not None for b in tight.values())
                if held[0]:
                    out.update(tight)  # type: ignore[arg-type]
            for x, (s, _) in done.items():
                out[x] = (s.score, s.score) if s.score is not None else out[x]
            return out

        if exhaustive:
            run([c for c in everything if c.extractor not in done])
        while (pick := next_extraction(intervals(), [x for x in by_name if x not in done], ms, top)) is not None:
            run([by_name[pick]])
        final = intervals()
        alpha, _ = contenders(final)
        within = (f"with its metrics in the ranges measured on {evidence.source}" if held[0] and evidence is not None
                  else "whatever its metrics")
        skipped: dict[str, str] = {}
        for x in by_name:
            if x in done:
                continue
            if x == alpha:
                skipped[x] = settled_reason(final, x, evidence.source if held[0] and evidence is not None else "")
            elif top > 1:
                skipped[x] = (f"cannot be among the first {top} proposals: {top} candidates score more than its "
                              f"most, {final[x][1]:.4f}, {within}")
            else:
                skipped[x] = (f"cannot overtake {alpha} ({final[alpha][0]:.4f}): its score is at most "
                              f"{final[x][1]:.4f} {within}")
        # listed in the order exhaustive scoring lists them (SelectorNet's first), which breaks exact ties
        order = sorted(everything, key=lambda c: c.extractor not in known)
        listed = []
        for c in order:
            if c.extractor in done:
                listed.append(done[c.extractor][0])
            elif c.extractor == alpha:
                low = final[alpha][0]
                base = unscored(decision, c, skipped[alpha])
                listed.append(replace(base, score=low, bonus=decision.bonus(alpha),
                                      evidence=replace(base.evidence, measured_accuracy=accuracy.get(alpha, 0.0))))
            else:
                listed.append(unscored(decision, c, skipped[c.extractor]))
        if alpha in done:
            how = tally.scoring(SCORED, f"F_metrics + H·A on the frame; {len(done)} of {len(by_name)} candidates "
                                f"extracted, the others cannot overtake {alpha} "
                                + ("within their measured metric ranges" if held[0] else "whatever their metrics"))
        else:
            how = tally.scoring(SETTLED, f"{alpha} {skipped[alpha]}")
        return Scored(listed, state(params.candidates), "metrics", how)


class _Tally(Work):
    """The extractions one request ran and their pixels (FrameState's owed extractions included)."""

    def scoring(self, outcome: str, reason: str) -> Scoring:
        return Scoring(outcome, reason, self.extractions, self.pixels)


def extraction_ms(cost: CostModel | None, vocab: Vocabulary, extractor: str, params: Mapping[str, Value],
                  shape: tuple[int, ...], decision: Decision, c: Candidate) -> float:
    """A candidate's expected extraction time at the scoring size: the cost model's, else the budget's or the
    measured mean (bounds.py orders extractions by it; unknown: infinite, extracted last among equals)."""
    if cost is not None:
        est = cost.expected(vocab.extractor(extractor), params, int(shape[1]), int(shape[0]))
        if est.ms is not None and est.ms > 0:
            return est.ms
    return expected_ms(decision, c)


def expected_ms(decision: Decision, c: Candidate) -> float:
    """The order in which SelectorNet's candidates are extracted: the budget's expected time, else the measured
    mean extraction time, else last."""
    if c.cost is not None and c.cost.ms is not None:
        return c.cost.ms
    e = decision.evidence.get(c.extractor)
    return e.extraction_ms if e is not None and e.extraction_ms is not None else math.inf


def settled(decision: Decision, params: Parameters, bound: BoundedChoice, known: frozenset[str],
            done: Mapping[str, tuple[CandidateScore, Any]]) -> list[CandidateScore]:
    """The candidates when SelectorNet's choice is settled by bounds: α* scored with its probability's least value
    over the unmeasured metrics, the others it knows without a score and why (those extracted keep their metrics),
    the ones it does not know as ``unscored``."""
    out = []
    for x, c in params.candidates.items():
        base = done[x][0] if x in done else unscored(decision, c)
        if x == bound.extractor:
            why = None if x in done else (
                f"SelectorNet's choice whatever the unmeasured metrics (interval bounds: its logit ≥ {bound.logit_low:.3f}, "
                f"every other ≤ {bound.rival_high:.3f}); not extracted, its score is its least probability")
            out.append(replace(base, score=bound.p_low, evidence=replace(base.evidence, not_scored=why, score_without_net=base.score)))
        elif x in known:
            why = (f"cannot overtake {bound.extractor}: SelectorNet's logit ≤ {bound.rival_high:.3f} < {bound.logit_low:.3f} "
                   "whatever the unmeasured metrics")
            out.append(replace(base, score=None, evidence=replace(base.evidence, not_scored=why, score_without_net=base.score)))
        else:
            out.append(replace(base, score=0.0))  # not trained on: probability 0, as by_network lists it
    return out


def prior_scores(decision: Decision, params: Parameters) -> list[CandidateScore]:
    """Without a frame: the preference bonus plus the measured accuracy A(α) (module docstring)."""
    accuracy = measured_accuracy(decision, params.candidates)
    out = []
    for c in params.candidates.values():
        bonus = decision.bonus(c.extractor)
        out.append(CandidateScore(extractor=c.extractor, params=c.params, score=bonus + accuracy.get(c.extractor, 0.0),
                                  bonus=bonus, adjustments=c.adjustments, evidence=evidence_of(decision, c)))
    return out


def evidence_of(decision: Decision, c: Candidate) -> CandidateEvidence:
    """What the graph and the Θ′ chain say about candidate ``c`` before it is scored."""
    return CandidateEvidence(measured=decision.evidence.get(c.extractor), params_source=c.proposal.source,
                             configuration=c.proposal.configuration, configuration_because=c.proposal.because,
                             cost=c.cost)


UNTRAINED = "SelectorNet decided and was not trained on this extractor (probability 0)"


def unscored(decision: Decision, c: Candidate, why: str = UNTRAINED) -> CandidateScore:
    """A candidate listed but not extracted, and why (by default: one SelectorNet was not trained on)."""
    return CandidateScore(extractor=c.extractor, params=c.params, score=None, adjustments=c.adjustments,
                          evidence=replace(evidence_of(decision, c), not_scored=why))


def by_network(
    nn: NeuralStep, image: np.ndarray | None, scored: list[CandidateScore], everyone: list[CandidateScore]
) -> tuple[list[CandidateScore], bool]:
    """SelectorNet's probabilities over ``everyone`` (its inputs: the metrics of ``scored``), or ``scored``
    unchanged and False when it is off, declined (nn.info says why) or knows no candidate."""
    if not (nn.selectornet and scored):
        return scored, False
    probs = nn.probabilities(image, {c.extractor: c.metrics for c in scored}, tuple(c.extractor for c in everyone))
    if not probs:
        return scored, False
    return [replace(c, score=probs.get(c.extractor, 0.0),
                    evidence=replace(c.evidence, score_without_net=c.score) if c.score is not None else c.evidence)
            for c in everyone], True


def measured_accuracy(decision: Decision, candidates: Iterable[str]) -> dict[str, float]:
    """A(x) = min over the measured candidates of their median ATE / x's median ATE (module docstring)."""
    ates = {x: e.ate for x in candidates if (e := decision.evidence.get(x)) is not None and e.ate}
    best = min(ates.values(), default=None)
    return {x: best / ate for x, ate in ates.items()} if best else {}


def downscale(image: np.ndarray, pixels: int) -> np.ndarray:
    """``image`` scaled (INTER_AREA) to about ``pixels`` pixels, keeping its aspect ratio; never enlarged."""
    import cv2

    h, w = image.shape[:2]
    s = (pixels / (h * w)) ** 0.5
    if s >= 1.0:
        return image
    return cv2.resize(image, (max(1, round(w * s)), max(1, round(h * s))), interpolation=cv2.INTER_AREA)


def scaled(spec: ExtractorSpec, params: Mapping[str, Value], ratio: float) -> dict[str, Value]:
    """Θ′ for an image ``ratio`` times as many pixels: count parameters scaled, everything else as is."""
    if ratio >= 1.0:
        return dict(params)
    out = dict(params)
    for name, value in params.items():
        p = spec.parameters[name]
        if p.scales_with_resolution and not isinstance(value, bool) and float(value) > 0:
            out[name] = p.clamp(float(value) * ratio)
    return out
