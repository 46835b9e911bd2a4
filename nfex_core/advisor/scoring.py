"""Stage 4 of the flow, scoring: a score per candidate, from the frame or, without one, from the graph.

On a frame (paper §IV-A, step 2, extended by measured accuracy): each candidate is extracted with its Θ′
on a QVGA-sized copy of the frame (count parameters scaled to its size) and scored

    score(α) = F_metrics(α | Θ′, E) + H·A(α),   F_metrics = Σ_x h_x(E)·m_x (+ bonus),   H = Σ_x h_x(E),

A(α) = min_{y ∈ C} ATE(y) / ATE(α) ∈ (0, 1] over the candidates C with measured windows under E, ATE the
median over the admitted windows (the Decision's evidence, nfex_core/evidence/; an unmeasured candidate has A = 0): the measured outcome weighs as much as all the
frame's proxies together. Where SelectorNet is in use its probabilities, masked to C(E), replace the
scores when its own first choice is a candidate; the candidates it was not trained on are then listed
with probability 0 and not extracted at all.

Without a frame (mode ``prior``): score(α) = bonus + A(α), computed once per context and snapshot.
"""
from __future__ import annotations

import threading
from collections.abc import Iterable, Mapping
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from ..fitness import f_metrics
from ..kg.vocab import ExtractorSpec, Value, Vocabulary
from ..neural.serve import NeuralStep
from ..rules.types import Decision
from .params import Candidate, Parameters
from .selection import CandidateEvidence, CandidateScore

SCORE_PIXELS = 320 * 240  # QVGA: the scoring copy's pixel count, whatever the aspect ratio (KITTI: 503×152)


@dataclass(frozen=True)
class FrameState:
    """What a stream keeps from one frame for the next: the scoring image and each candidate's features."""

    image: np.ndarray
    features: dict[str, Any]


@dataclass
class Scored:
    """The stage's output: every candidate with its score (None: listed, not scored), the stream state
    for the next frame, and how the scores were made (``metrics`` | ``selectornet`` | ``prior``)."""

    candidates: list[CandidateScore]
    state: FrameState | None
    mode: str


@dataclass
class Scorer:
    """Scores candidates on frames; ``threads`` extract them side by side (OpenCV releases the GIL)."""

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
    ) -> Scored:
        """Score every candidate of ``params`` on ``image`` (module docstring)."""
        from ..vision.metrics import compute_metrics

        small = downscale(image, self.score_pixels)
        full_px = int(image.shape[0] * image.shape[1])
        small_px = int(small.shape[0] * small.shape[1])
        accuracy = measured_accuracy(decision, params.candidates)
        weight = sum(w.value for w in decision.weights.values())  # H: F_metrics' most without the bonus

        def score(c: Candidate) -> tuple[CandidateScore, Any]:
            spec = vocab.extractor(c.extractor)
            feats = registry.extract(c.extractor, small, scaled(spec, c.params, small_px / full_px))
            prev = None
            if previous is not None and c.extractor in previous.features and previous.image.shape == small.shape:
                prev = (previous.features[c.extractor], previous.image)
            metrics = compute_metrics(feats, small, prev)
            bonus = decision.bonuses[c.extractor].value if c.extractor in decision.bonuses else 0.0
            f = f_metrics(metrics, decision.weights, vocab.metrics, bonus)
            a = accuracy.get(c.extractor, 0.0)
            return CandidateScore(
                extractor=c.extractor, params=c.params, score=f + weight * a, bonus=bonus,
                metrics={k: round(v, 6) for k, v in metrics.items()}, adjustments=c.adjustments,
                keypoints=len(feats.xy), extraction_ms=round(feats.elapsed_ms, 3),
                evidence=replace(evidence_of(decision, c), f_metrics=f, measured_accuracy=a),
            ), feats

        def run(cs: list[Candidate]) -> list[tuple[CandidateScore, Any]]:
            return list(self.pool().map(score, cs)) if len(cs) > 1 else [score(c) for c in cs]

        everything = list(params.candidates.values())
        known = nn.selector_extractors if nn.selectornet else None
        # SelectorNet is masked to what it was trained on: score those first; if it decides, the others
        # (probability 0 whatever their F_metrics) are not extracted at all
        first = [c for c in everything if c.extractor in known] if known is not None else everything
        done = run(first or everything)
        scored = [s for s, _ in done]
        features = {s.extractor: feats for s, feats in done}
        if known is not None and first:
            rest = [unscored(decision, c) for c in everything if c.extractor not in known]
            ranked, decided = by_network(nn, image, scored, scored + rest)
            if decided:
                return Scored(ranked, FrameState(small, features), "selectornet")
            more = run([c for c in everything if c.extractor not in known])
            scored += [s for s, _ in more]
            features.update({s.extractor: feats for s, feats in more})
        return Scored(scored, FrameState(small, features), "metrics")


def prior_scores(decision: Decision, params: Parameters) -> list[CandidateScore]:
    """Without a frame: the preference bonus plus the measured accuracy A(α) (module docstring)."""
    accuracy = measured_accuracy(decision, params.candidates)
    out = []
    for c in params.candidates.values():
        bonus = decision.bonuses[c.extractor].value if c.extractor in decision.bonuses else 0.0
        out.append(CandidateScore(extractor=c.extractor, params=c.params, score=bonus + accuracy.get(c.extractor, 0.0),
                                  bonus=bonus, adjustments=c.adjustments, evidence=evidence_of(decision, c)))
    return out


def evidence_of(decision: Decision, c: Candidate) -> CandidateEvidence:
    """What the graph and the Θ′ chain say about candidate ``c`` before it is scored."""
    return CandidateEvidence(measured=decision.evidence.get(c.extractor), params_source=c.proposal.source,
                             configuration=c.proposal.configuration, configuration_because=c.proposal.because,
                             cost=c.cost)


def unscored(decision: Decision, c: Candidate) -> CandidateScore:
    """A candidate SelectorNet was not trained on, listed (probability 0) but not extracted."""
    return CandidateScore(
        extractor=c.extractor, params=c.params, score=None, adjustments=c.adjustments,
        evidence=replace(evidence_of(decision, c),
                         not_scored="SelectorNet decided and was not trained on this extractor (probability 0)"),
    )


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
