"""The advisor: one object that runs the flow of DESIGN.md for a frame and a context.

    frame + context ─► conditions: fill unknown dimensions from the frame (vision.context)
                    ─► symbolic: candidates C(E) with the rules that pruned the others (rules.engine)
                    ─► params: Θ′ per candidate = g(Θ, E) or ParamNet(E, s), clamped to the graph's ranges,
                               repaired or pruned by the context shapes in force (rules.shape_check)
                    ─► budget: expected cost per candidate at the frame's size; fit Θ′ or prune (budget)
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

from ..errors import BadInput, NoCandidate
from ..fitness import Adjustment, adjust_params, f_metrics
from ..kg.vocab import ExtractorSpec, Value, Vocabulary
from ..neural.serve import ModelHolder, NeuralStep, frame_stats
from ..rules.engine import Citation, Decision, RuleEngine, RuleTable
from ..rules.shape_check import enforce
from .budget import Budget, BudgetOutcome, resolve_budget, settle
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
    _priors: dict[tuple[Any, ...], tuple[list[CandidateScore], BudgetOutcome | None, dict[str, tuple[Citation, ...]]]] = field(
        default_factory=dict
    )

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
        context: Mapping[str, Any] | None = None,
        frame: np.ndarray | None = None,
        previous: FrameState | None = None,
        *,
        budget_ms: float | None = None,
        compute: str | None = None,
        frame_size: tuple[int, int] | None = None,
    ) -> Selection:
        """The flow for one request. ``budget_ms`` (per-frame extraction time the client can afford) and
        ``compute`` (a compute class of the graph) may also come as context keys of those names;
        ``frame_size`` (W, H) sizes the cost check when no frame is sent."""
        timings: dict[str, float] = {}
        t = time.perf_counter()

        def lap(name: str) -> None:
            nonlocal t
            now = time.perf_counter()
            timings[name] = (now - t) * 1000
            t = now

        snap = self.snapshot()
        ctx = dict(context or {})
        budget_ms = _budget_number(ctx.pop("budget_ms", None) if budget_ms is None else budget_ms)
        compute = compute or ctx.pop("compute", None)
        ctx.pop("compute", None)
        given = snap.vocab.check_context(ctx)
        image = stats = None
        if frame is not None:
            from ..vision.registry import as_grey_u8  # imports cv2: only when a frame comes
            from ..vision.statistics import frame_statistics

            image = as_grey_u8(frame)
        lap("snapshot")
        if image is not None:  # once per request: context estimation and ParamNet both read them
            stats = frame_statistics(image, previous.image if previous is not None else None)
        entries, values = self._conditions(snap.vocab, given, image, previous, stats)
        lap("conditions")
        decision = snap.table.decide(values)
        if not decision.candidates:
            raise NoCandidate(
                "every extractor is pruned in this context: "
                + "; ".join(f"{x}: {cs[0].reason} [{cs[0].label}]" for x, cs in decision.pruned.items()),
                pruned=[PrunedCandidate(x, cs).as_dict() for x, cs in decision.pruned.items()],
            )
        size = (int(image.shape[1]), int(image.shape[0])) if image is not None else frame_size
        budget = resolve_budget(snap.table.budget_terms, snap.table.cost, values, budget_ms, compute, size,
                                "frame" if image is not None else "given")
        lap("symbolic")
        nn = self.neural.step(snap.vocab)
        if nn.active:
            nn.prepare(values, frame_stats(stats))
            lap("neural")
        scored, state, mode, outcome, cut = self._score(snap, decision, budget, nn, image, previous)
        if nn.selectornet and scored:
            probs = nn.probabilities(image, {c.extractor: c.metrics for c in scored}, tuple(c.extractor for c in scored))
            if probs:  # else no candidate is one the network was trained on: F_metrics decides
                scored = [replace(c, score=probs.get(c.extractor, 0.0), evidence={**c.evidence, "f": c.score}) for c in scored]
                mode = "selectornet"
        lap("selection")
        pruned = {x: tuple(cs) for x, cs in decision.pruned.items()}
        pruned.update(cut)
        if not scored:
            raise NoCandidate(
                "every extractor is pruned in this context: "
                + "; ".join(f"{x}: {cs[0].reason} [{cs[0].label}]" for x, cs in pruned.items()),
                pruned=[PrunedCandidate(x, cs).as_dict() for x, cs in pruned.items()],
            )
        best = max(scored, key=lambda c: (c.score if c.score is not None else -np.inf, -_cost(decision, c)))
        spec = snap.vocab.extractor(best.extractor)
        timings["total"] = sum(timings.values())
        if outcome is not None:
            for x in outcome.readmitted:
                pruned.pop(x, None)
            pruned.update({x: cs for x, cs in outcome.pruned.items() if x != best.extractor})
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
            budget=budget.as_dict() if budget is not None else None,
            warnings=tuple(outcome.warnings) if outcome is not None else (),
        )

    def _candidate(
        self, spec: ExtractorSpec, decision: Decision, nn: NeuralStep, pixels: int | None
    ) -> tuple[dict[str, Value], list[Adjustment], tuple[Citation, ...]]:
        """Θ′ = ParamNet(E, s) where the neural step covers α, else g(Θ, E); then the context shapes:
        the repaired Θ′, every adjustment, or (non-empty) the shapes that prune α."""
        if nn.covers(spec.name):
            params, adjustments = nn.params(spec, pixels)
        else:
            params, adjustments = adjust_params(spec, decision.factors.get(spec.name, {}), pixels=pixels)
        outcome = enforce(spec, params, decision.shapes)
        return outcome.params, [*adjustments, *outcome.adjustments], outcome.pruned

    def _theta(
        self, snap: Snapshot, decision: Decision, budget: Budget | None, nn: NeuralStep, pixels: int | None
    ) -> tuple[dict[str, dict[str, Value]], dict[str, list[Adjustment]], BudgetOutcome | None, dict[str, tuple[Citation, ...]]]:
        """Θ′ per candidate (``_candidate``), then the budget's cost check (fit or prune) when one is in force.
        Returns Θ′ and adjustments per kept candidate, the budget outcome and what the shapes pruned."""
        theta: dict[str, dict[str, Value]] = {}
        adjustments: dict[str, list[Adjustment]] = {}
        cut: dict[str, tuple[Citation, ...]] = {}

        def admit(x: str) -> bool:
            params, adj, because = self._candidate(snap.vocab.extractor(x), decision, nn, pixels)
            if because:
                cut[x] = because
                return False
            theta[x], adjustments[x] = params, adj
            return True

        for x in decision.candidates:
            admit(x)
        if budget is None:
            return theta, adjustments, None, cut
        terms = snap.table.budget_terms
        # what a relative-accuracy rule pruned is re-judged against the best *affordable* extractor
        relative = [x for x, cs in decision.pruned.items() if cs and all(c.rule in terms.relative_rules for c in cs)]
        relative = [x for x in relative if admit(x)]
        ates = {x: e.mean_ate for x, e in decision.evidence.items() if e.mean_ate}
        outcome = settle(snap.table.cost, terms, snap.vocab.extractors, ates, theta, relative, budget)
        for x, adj in outcome.adjustments.items():
            adjustments[x] = [*adjustments[x], *adj]
        return {x: outcome.params[x] for x in theta if x in outcome.params}, adjustments, outcome, cut

    def _conditions(
        self,
        vocab: Vocabulary,
        given: dict[str, str],
        image: np.ndarray | None,
        previous: FrameState | None,
        stats: Mapping[str, float] | None,
    ) -> tuple[list[ContextEntry], dict[str, str | None]]:
        """Given dimensions win; estimable ones are estimated from the frame; the rest stay unknown."""
        estimates: dict[str, ContextEntry] = {}
        if image is not None:
            from ..vision.context import estimate_context

            prev = previous.image if previous is not None else None
            ctx = estimate_context(vocab, given, image, prev, stats=stats)
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

    def _score(
        self,
        snap: Snapshot,
        decision: Decision,
        budget: Budget | None,
        nn: NeuralStep,
        image: np.ndarray | None,
        previous: FrameState | None,
    ) -> tuple[list[CandidateScore], FrameState | None, str, BudgetOutcome | None, dict[str, tuple[Citation, ...]]]:
        vocab = snap.vocab
        if image is None:
            # the prior depends on the decision, the budget and (through ParamNet) the model in use
            key = (id(decision), None if budget is None else tuple(budget.as_dict().values()), nn.info.get("used"))
            cached = snap._priors.get(key)
            if cached is None:
                theta, adjustments, outcome, cut = self._theta(snap, decision, budget, nn, None)
                priors = [self._prior(snap, decision, x, theta[x], adjustments[x], outcome) for x in theta]
                cached = snap._priors[key] = (priors, outcome, cut)
            return list(cached[0]), None, "prior", cached[1], dict(cached[2])  # shared, frozen: read-only
        small = downscale(image, self.score_max_side)
        from ..vision.metrics import compute_metrics

        full_px = int(image.shape[0] * image.shape[1])
        theta, adjustments, outcome, cut = self._theta(snap, decision, budget, nn, full_px)
        out: list[CandidateScore] = []
        features: dict[str, Any] = {}
        for x, params in theta.items():
            spec = vocab.extractor(x)
            # F_metrics is measured on the scoring image with this Θ′, count parameters scaled to its size
            score_params = _scaled(spec, params, int(small.shape[0] * small.shape[1]) / full_px)
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
                    adjustments=tuple(adjustments[x]),
                    keypoints=len(feats.xy),
                    extraction_ms=round(feats.elapsed_ms, 3),
                    evidence=_evidence_dict(decision, x, outcome),
                )
            )
        return out, FrameState(small, features), "metrics", outcome, cut

    def _prior(
        self,
        snap: Snapshot,
        decision: Decision,
        x: str,
        params: dict[str, Value],
        adjustments: list[Adjustment],
        outcome: BudgetOutcome | None,
    ) -> CandidateScore:
        """Without a frame: the preference bonus plus measured accuracy (best mean ATE / this one's)."""
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
            evidence=_evidence_dict(decision, x, outcome),
        )


def _scaled(spec: ExtractorSpec, params: Mapping[str, Value], ratio: float) -> dict[str, Value]:
    """Θ′ for an image ``ratio`` times as many pixels: count parameters scaled, everything else as is."""
    if ratio >= 1.0:
        return dict(params)
    out = dict(params)
    for name, value in params.items():
        p = spec.parameters[name]
        if p.scales_with_resolution and not isinstance(value, bool) and float(value) > 0:
            out[name] = p.clamp(float(value) * ratio)
    return out


def _budget_number(value: Any) -> float | None:
    if value is None:
        return None
    try:
        ms = float(value)
    except (TypeError, ValueError):
        raise BadInput(f"budget_ms must be a number of milliseconds, got {value!r}") from None
    if not ms > 0 or ms == float("inf"):
        raise BadInput(f"budget_ms must be a positive number of milliseconds, got {value!r}")
    return ms


def _evidence_dict(decision: Decision, x: str, outcome: BudgetOutcome | None = None) -> dict[str, Any]:
    e = decision.evidence.get(x)
    out: dict[str, Any] = {}
    if e is not None:
        out = {"mean_ate_m": e.mean_ate, "windows": e.windows, "extraction_ms": e.extraction_ms}
    if outcome is not None and x in outcome.estimates:
        est = outcome.estimates[x]
        out["expected_ms"] = round(est.ms, 3) if est.ms is not None else None
        out["cost_source"] = est.source
    return out


def _cost(decision: Decision, c: CandidateScore) -> float:
    """Tie-break: the budget's expected time where known, else the measured mean extraction time."""
    if c.evidence.get("expected_ms") is not None:
        return float(c.evidence["expected_ms"])
    e = decision.evidence.get(c.extractor)
    return e.extraction_ms if e is not None and e.extraction_ms is not None else float("inf")
