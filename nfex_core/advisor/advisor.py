"""The advisor: one object that runs the flow of DESIGN.md for a frame and a context.

    frame + context ─► conditions: fill unknown dimensions from the frame (vision.context)
                    ─► symbolic: candidates C(E) with the rules that pruned the others (rules.engine)
                    ─► params: Θ′ per candidate = g(Θ, E) or ParamNet(E, s), clamped to the graph's ranges,
                               repaired or pruned by the context shapes in force (rules.shape_check)
                    ─► selection: α* = argmax over C(E) of F_metrics on the frame (fitness, vision),
                                  or of SelectorNet's probabilities masked to C(E) (neural.serve)
                    ─► Selection {α*, Θ′, scores, pruned + reasons, context used, versions, timings}

It holds a snapshot — graph version, vocabulary, compiled rule table, extractor registry — and
rebuilds it when a commit moves the graph version: at once for commits made through the same
KnowledgeGraph, otherwise at the next check (``poll_interval_s``; a shared remote store is polled).
Without a frame it answers from the context alone: the rules' preferences and the graph's
measurements (mode "prior").
"""
from __future__ import annotations

import threading
import time
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import NoCandidate
from ..fitness import adjust_params, f_metrics
from ..kg.vocab import ExtractorSpec, Value, Vocabulary
from ..neural.serve import ModelHolder, NeuralStep, frame_stats
from ..rules.engine import Citation, Decision, RuleEngine, RuleTable
from ..rules.shape_check import enforce
from .selection import CandidateScore, ContextEntry, PrunedCandidate, Selection

if TYPE_CHECKING:
    from ..kg.store import KnowledgeGraph


@dataclass
class Snapshot:
    version: int
    vocab: Vocabulary
    table: RuleTable
    programs: dict[str, int]
    taken_at: float = field(default_factory=time.monotonic)
    _registry: Any = None
    # context-only answers depend on the decision alone: computed once per context and snapshot
    _priors: dict[int, tuple[list[CandidateScore], dict[str, tuple[Citation, ...]]]] = field(default_factory=dict)

    @property
    def registry(self) -> Any:
        """The extractor registry for this vocabulary (built on first use: it imports cv2)."""
        if self._registry is None:
            from ..vision.registry import ExtractorRegistry

            self._registry = ExtractorRegistry.from_vocabulary(self.vocab)
        return self._registry


@dataclass(frozen=True)
class FrameState:
    """What a stream keeps from one frame for the next: the scoring image and each candidate's features."""

    image: np.ndarray
    features: dict[str, Any]


def downscale(image: np.ndarray, max_side: int) -> np.ndarray:
    import cv2

    h, w = image.shape[:2]
    s = max_side / max(h, w)
    if s >= 1.0:
        return image
    return cv2.resize(image, (max(1, round(w * s)), max(1, round(h * s))), interpolation=cv2.INTER_AREA)


class Advisor:
    """``neural``: symbolic | paramnet | selectornet | both (default: $NFEX_NEURAL or both; see neural.serve);
    ``models``: the model folder (default: Settings.models). Without a usable model the advisor is symbolic."""

    def __init__(
        self,
        kg: KnowledgeGraph,
        *,
        score_max_side: int = 640,
        poll_interval_s: float = 1.0,
        neural: str | None = None,
        models: Path | str | None = None,
    ) -> None:
        self.kg = kg
        self.neural = ModelHolder(models, neural)
        self.engine = RuleEngine(kg)
        self.score_max_side = score_max_side
        self.poll_interval_s = poll_interval_s
        self._snapshot: Snapshot | None = None
        self._dirty = True
        self._lock = threading.Lock()
        kg.on_commit(lambda _version: self.invalidate())

    # ------------------------------------------------------------------ snapshot
    def invalidate(self) -> None:
        self._dirty = True

    def snapshot(self) -> Snapshot:
        snap = self._snapshot
        now = time.monotonic()
        if snap is not None and not self._dirty and now - snap.taken_at < self.poll_interval_s:
            return snap
        with self._lock:
            snap = self._snapshot
            if snap is not None and not self._dirty and now - snap.taken_at < self.poll_interval_s:
                return snap
            self._dirty = False
            version = self.kg.version
            if snap is not None and snap.version == version:
                snap.taken_at = now
                return snap
            self._snapshot = snap = self._build()
            return snap

    def _build(self) -> Snapshot:
        vocab = self.kg.vocabulary()
        table = self.engine.table()
        programs: dict[str, int] = {}
        for s in table.statements:
            programs[s.program] = programs.get(s.program, 0) + 1
        return Snapshot(table.version, vocab, table, programs)

    # ------------------------------------------------------------------ the flow
    def select(
        self,
        context: Mapping[str, str | None] | None = None,
        frame: np.ndarray | None = None,
        previous: FrameState | None = None,
    ) -> Selection:
        timings: dict[str, float] = {}
        t = time.perf_counter()

        def lap(name: str) -> None:
            nonlocal t
            now = time.perf_counter()
            timings[name] = (now - t) * 1000
            t = now

        snap = self.snapshot()
        given = snap.vocab.check_context(context or {})
        image = None
        if frame is not None:
            from ..vision.registry import as_grey_u8  # imports cv2: only when a frame comes

            image = as_grey_u8(frame)
        lap("snapshot")
        entries, values = self._conditions(snap.vocab, given, image, previous)
        lap("conditions")
        decision = snap.table.decide(values)
        if not decision.candidates:
            raise NoCandidate(
                "every extractor is pruned in this context: "
                + "; ".join(f"{x}: {cs[0].reason} [{cs[0].label}]" for x, cs in decision.pruned.items()),
                pruned=[PrunedCandidate(x, cs).as_dict() for x, cs in decision.pruned.items()],
            )
        lap("symbolic")
        nn = self.neural.step(snap.vocab)
        if nn.active:
            nn.prepare(values, frame_stats(image))
            lap("neural")
        scored, state, mode, cut = self._score(snap, decision, image, previous, nn)
        if nn.selectornet and scored:
            probs = nn.probabilities(image, {c.extractor: c.metrics for c in scored}, tuple(c.extractor for c in scored))
            if probs:  # else no candidate is one the network was trained on: F_metrics decides
                scored = [replace(c, score=probs.get(c.extractor, 0.0), evidence={**c.evidence, "f": c.score}) for c in scored]
                mode = "selectornet"
        lap("selection")
        pruned = {**decision.pruned, **cut}
        if not scored:
            raise NoCandidate(
                "every extractor is pruned in this context: "
                + "; ".join(f"{x}: {cs[0].reason} [{cs[0].label}]" for x, cs in pruned.items()),
                pruned=[PrunedCandidate(x, cs).as_dict() for x, cs in pruned.items()],
            )
        best = max(scored, key=lambda c: (c.score if c.score is not None else -np.inf, -_cost(decision, c.extractor)))
        spec = snap.vocab.extractor(best.extractor)
        timings["total"] = sum(timings.values())
        return Selection(
            extractor=best.extractor,
            params=dict(best.params),
            mode=mode,
            candidates=tuple(sorted(scored, key=lambda c: -(c.score if c.score is not None else -np.inf))),
            pruned=tuple(PrunedCandidate(x, cs) for x, cs in sorted(pruned.items())),
            context=tuple(entries),
            weights=dict(decision.weights),
            versions={"graph": snap.version, "programs": snap.programs, "rules": len(snap.table.rules), "model": nn.info},
            timings_ms=timings,
            constructor=spec.constructor,
            norm=spec.norm_for(best.params),
            state=state,
        )

    def _conditions(
        self, vocab: Vocabulary, given: dict[str, str], image: np.ndarray | None, previous: FrameState | None
    ) -> tuple[list[ContextEntry], dict[str, str | None]]:
        """Given dimensions win; estimable ones are estimated from the frame; the rest stay unknown."""
        estimates: dict[str, ContextEntry] = {}
        if image is not None:
            from ..vision.context import estimate_context

            prev = previous.image if previous is not None else None
            ctx = estimate_context(vocab, given, downscale(image, self.score_max_side), prev)
            for e in ctx.entries():
                estimates[e.dimension] = ContextEntry(e.dimension, e.value, e.source, e.confidence, e.evidence)
        entries: list[ContextEntry] = []
        values: dict[str, str | None] = {}
        for dim in vocab.dimensions:
            if dim in given:
                entry = ContextEntry(dim, given[dim], "given", 1.0)
            elif dim in estimates and estimates[dim].value is not None:
                entry = estimates[dim]
            else:
                entry = ContextEntry(dim, None, "unknown")
            entries.append(entry)
            values[dim] = entry.value
        return entries, values

    def _theta(
        self, spec: Any, decision: Decision, nn: NeuralStep, pixels: int | None = None
    ) -> tuple[dict[str, Any], list[Any]]:
        """Θ′ = ParamNet(E, s) when the neural step has it, else g(Θ, E); clamped to the graph either way."""
        if nn.covers(spec.name):
            return nn.params(spec, pixels)
        return adjust_params(spec, decision.factors.get(spec.name, {}), pixels=pixels)

    def _candidate(
        self, spec: ExtractorSpec, decision: Decision, nn: NeuralStep, pixels: int | None
    ) -> tuple[dict[str, Value], list[Any], tuple[Citation, ...]]:
        """Θ′ checked against the context shapes: repaired Θ′, every adjustment, or why α is pruned."""
        params, adjustments = self._theta(spec, decision, nn, pixels)
        outcome = enforce(spec, params, decision.shapes)
        return outcome.params, [*adjustments, *outcome.adjustments], outcome.pruned

    def _score(
        self, snap: Snapshot, decision: Decision, image: np.ndarray | None, previous: FrameState | None, nn: NeuralStep
    ) -> tuple[list[CandidateScore], FrameState | None, str, dict[str, tuple[Citation, ...]]]:
        vocab = snap.vocab
        cut: dict[str, tuple[Citation, ...]] = {}
        if image is None:
            cached = snap._priors.get(id(decision))
            if cached is None:
                prior: list[CandidateScore] = []
                for x in decision.candidates:
                    got = self._prior(snap, decision, x, nn)
                    if isinstance(got, CandidateScore):
                        prior.append(got)
                    else:
                        cut[x] = got
                cached = snap._priors[id(decision)] = (prior, cut)
            return list(cached[0]), None, "prior", dict(cached[1])  # shared, frozen CandidateScores: read-only
        small = downscale(image, self.score_max_side)
        from ..vision.metrics import compute_metrics

        out: list[CandidateScore] = []
        features: dict[str, Any] = {}
        for x in decision.candidates:
            spec = vocab.extractor(x)
            params, adjustments, because = self._candidate(spec, decision, nn, int(image.shape[0] * image.shape[1]))
            if because:
                cut[x] = because
                continue
            # F_metrics is measured on the scoring image, with count parameters scaled to its size
            score_params, _, _ = self._candidate(spec, decision, nn, int(small.shape[0] * small.shape[1]))
            feats = snap.registry.extract(x, small, score_params)
            features[x] = feats
            prev = None
            if previous is not None and x in previous.features and previous.image.shape == small.shape:
                prev = (previous.features[x], previous.image)
            metrics = compute_metrics(feats, small, prev)
            bonus = decision.bonuses[x].value if x in decision.bonuses else 0.0
            out.append(
                CandidateScore(
                    extractor=x,
                    params=params,
                    score=f_metrics(metrics, decision.weights, vocab.metrics, bonus),
                    bonus=bonus,
                    metrics={k: round(v, 6) for k, v in metrics.items()},
                    adjustments=tuple(adjustments),
                    keypoints=len(feats.xy),
                    extraction_ms=round(feats.elapsed_ms, 3),
                    evidence=_evidence_dict(decision, x),
                )
            )
        return out, FrameState(small, features), "metrics", cut

    def _prior(self, snap: Snapshot, decision: Decision, x: str, nn: NeuralStep) -> CandidateScore | tuple[Citation, ...]:
        """Without a frame: the preference bonus plus measured accuracy (best mean ATE / this one's)."""
        spec = snap.vocab.extractor(x)
        params, adjustments, because = self._candidate(spec, decision, nn, None)
        if because:
            return because
        bonus = decision.bonuses[x].value if x in decision.bonuses else 0.0
        measured = [e.mean_ate for e in decision.evidence.values() if e.mean_ate]
        own = decision.evidence.get(x)
        accuracy = (min(measured) / own.mean_ate) if (own and own.mean_ate and measured) else 0.0
        return CandidateScore(
            extractor=x,
            params=params,
            score=bonus + accuracy,
            bonus=bonus,
            adjustments=tuple(adjustments),
            evidence=_evidence_dict(decision, x),
        )


def _evidence_dict(decision: Decision, x: str) -> dict[str, Any]:
    e = decision.evidence.get(x)
    if e is None:
        return {}
    return {"mean_ate_m": e.mean_ate, "windows": e.windows, "extraction_ms": e.extraction_ms}


def _cost(decision: Decision, x: str) -> float:
    e = decision.evidence.get(x)
    return e.extraction_ms if e is not None and e.extraction_ms is not None else float("inf")
