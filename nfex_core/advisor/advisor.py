"""The advisor: one object that runs the flow of DESIGN.md for a frame and a context.

    frame + context ─► conditions: fill unknown dimensions from the frame (vision.context)
                    ─► symbolic: candidates C(E) with the rules that pruned the others (rules.engine)
                    ─► params: Θ′ per candidate = the best configuration measured under E (measured), else
                               ParamNet(E, s), else g(Θ, E); clamped to the graph's ranges, then repaired or
                               pruned by the context shapes in force (rules.shape_check)
                    ─► budget: expected cost per candidate at the frame's size; fit Θ′ or prune (budget)
                    ─► selection: α* = argmax over C(E) of F_metrics on the frame (fitness, vision) plus the
                                  measured accuracy (below), or of SelectorNet's probabilities masked to
                                  C(E) when its own first choice is a candidate (neural.serve)
                    ─► Selection {α*, Θ′, scores, pruned + reasons, context used, versions, timings}

It holds a snapshot — graph version, vocabulary, compiled rule table, extractor registry — and
rebuilds it when a commit moves the graph version: at once for commits made through the same
KnowledgeGraph, otherwise at the next check (``poll_interval_s``; a shared remote store is polled).
Without a frame it answers from the context alone: the rules' preferences and the graph's
measurements (mode "prior").

Measured accuracy (beyond the paper, in both modes): with A(x) = min_{y ∈ C} ATE(y) / ATE(x) ∈ (0, 1],
C the scored candidates with measured windows under E and ATE the extractor's median over them (the
Decision's evidence: admitted windows only, evidence/; an unmeasured candidate has A = 0), a frame is scored F_metrics(x) + H·A(x) with
H = Σ_x h_x(E), the most the metric terms of F_metrics can add: the measured outcome weighs as much as
all the frame's proxies together (on KITTI 01 under a 20 ms budget F_metrics prefers ORB to ORB_GRID on
every frame, while ORB_GRID's measured mean ATE is two thirds of ORB's and on the sequence ORB_GRID
default's ATE is 35 % below ORB default's — docs/cost.md). Without a frame the score is the
preference bonus + A(x).
"""
from __future__ import annotations

import os
import threading
import time
from collections.abc import Iterable, Mapping
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import BadInput, NoCandidate
from ..evidence import ROBUST
from ..fitness import Adjustment, adjust_params, f_metrics
from ..kg.vocab import ExtractorSpec, Value, Vocabulary
from ..neural.serve import ModelHolder, NeuralStep, frame_stats
from ..rules.engine import Citation, Decision, MeasuredConfiguration, RuleEngine, RuleTable
from ..rules.shape_check import enforce
from .budget import Budget, BudgetOutcome, resolve_budget, settle
from .measured import measured_params
from .selection import CandidateScore, ContextEntry, PrunedCandidate, Selection

if TYPE_CHECKING:
    from ..kg.store import KnowledgeGraph


MIN_FRAME_SIDE = 8


@dataclass
class Snapshot:
    version: int
    vocab: Vocabulary
    table: RuleTable
    programs: dict[str, int]
    taken_at: float = field(default_factory=time.monotonic)
    _registry: Any = None
    # context-only answers depend on the decision alone: computed once per context and snapshot
    _priors: dict[tuple[Any, ...], tuple[list[CandidateScore], Theta]] = field(default_factory=dict)

    @property
    def registry(self) -> Any:
        """The extractor registry for this vocabulary (built on first use: it imports cv2)."""
        if self._registry is None:
            from ..vision.registry import ExtractorRegistry

            self._registry = ExtractorRegistry.from_vocabulary(self.vocab)
        return self._registry


@dataclass
class Theta:
    """Θ′ per kept candidate, how it came about, the budget's outcome and what the shapes pruned."""

    params: dict[str, dict[str, Value]]
    adjustments: dict[str, list[Adjustment]]
    outcome: BudgetOutcome | None
    cut: dict[str, tuple[Citation, ...]]
    measured: dict[str, tuple[MeasuredConfiguration, Citation]]


@dataclass(frozen=True)
class FrameState:
    """What a stream keeps from one frame for the next: the scoring image and each candidate's features."""

    image: np.ndarray
    features: dict[str, Any]


SCORE_PIXELS = 320 * 240  # QVGA: the scoring copy's pixel count, whatever the aspect ratio (KITTI: 503×152)


def downscale(image: np.ndarray, pixels: int) -> np.ndarray:
    """``image`` scaled (INTER_AREA) to about ``pixels`` pixels, keeping its aspect ratio; never enlarged."""
    import cv2

    h, w = image.shape[:2]
    s = (pixels / (h * w)) ** 0.5
    if s >= 1.0:
        return image
    return cv2.resize(image, (max(1, round(w * s)), max(1, round(h * s))), interpolation=cv2.INTER_AREA)


class Advisor:
    """``neural``: symbolic | paramnet | selectornet | both (default: $NFEX_NEURAL or both; see neural.serve);
    ``models``: the model folder (default: Settings.models). Without a usable model the advisor is symbolic.
    ``score_pixels``: F_metrics is measured on a copy of the frame of about this many pixels (QVGA; bench/
    bench_service.py times a frame request against the earlier 640-px copy)."""

    def __init__(
        self,
        kg: KnowledgeGraph,
        *,
        score_pixels: int = SCORE_PIXELS,
        poll_interval_s: float = 1.0,
        neural: str | None = None,
        models: Path | str | None = None,
    ) -> None:
        self.kg = kg
        self.neural = ModelHolder(models, neural)
        self.engine = RuleEngine(kg)
        self.score_pixels = score_pixels
        self.poll_interval_s = poll_interval_s
        self._snapshot: Snapshot | None = None
        self._dirty = True
        self._lock = threading.Lock()
        kg.on_commit(lambda _version: self.invalidate())

    # ------------------------------------------------------------------ snapshot
    def invalidate(self) -> None:
        self._dirty = True

    def current_snapshot(self) -> Snapshot | None:
        """The snapshot built last (None before the first), without checking the graph version: for
        reporting (``/readyz``); ``snapshot()`` is what a selection uses."""
        return self._snapshot

    def is_fresh(self) -> bool:
        """Whether ``select`` will answer from the current snapshot without a store round trip or a rule
        compilation (the service then runs a context-only request on its event loop)."""
        snap = self._snapshot
        return snap is not None and not self._dirty and time.monotonic() - snap.taken_at < self.poll_interval_s

    def snapshot(self) -> Snapshot:
        if self.is_fresh():
            return self._snapshot  # type: ignore[return-value]
        with self._lock:
            if self.is_fresh():
                return self._snapshot  # type: ignore[return-value]
            self._dirty = False
            snap, version = self._snapshot, self.kg.version
            if snap is not None and snap.version == version:
                snap.taken_at = time.monotonic()
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
            if min(image.shape[:2]) < MIN_FRAME_SIDE:  # a 1-pixel frame broke OpenCV's pyramids (a 500, bench_fuzz)
                raise BadInput(f"the frame is {image.shape[1]}×{image.shape[0]} pixels; features need at least "
                               f"{MIN_FRAME_SIDE}×{MIN_FRAME_SIDE}")
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
        scored, state, mode, theta = self._score(snap, decision, values, budget, nn, image, previous)
        outcome, cut = theta.outcome, theta.cut
        if image is None:
            scored, decided = _by_network(nn, None, scored, scored)
            mode = "selectornet" if decided else mode
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

    def _theta(
        self,
        snap: Snapshot,
        decision: Decision,
        values: Mapping[str, str | None],
        budget: Budget | None,
        nn: NeuralStep,
        pixels: int | None,
    ) -> Theta:
        """Θ′ per candidate — the best configuration measured under E (advisor.measured), else ParamNet(E, s)
        where the neural step covers α, else g(Θ, E) — then the context shapes (repair or prune), then the
        budget's cost check (fit or prune) when one is in force."""
        theta: dict[str, dict[str, Value]] = {}
        adjustments: dict[str, list[Adjustment]] = {}
        cut: dict[str, tuple[Citation, ...]] = {}
        measured = snap.table.measured(values)
        used: dict[str, tuple[MeasuredConfiguration, Citation]] = {}
        conditions = ", ".join(f"{d} = {v}" for d, v in values.items() if v is not None)

        def admit(x: str) -> bool:
            spec = snap.vocab.extractor(x)
            if x in measured:
                params, adj, config, cite = measured_params(spec, measured[x], conditions, snap.table.cost, budget)
                used[x] = (config, cite)
            elif nn.covers(x):
                params, adj = nn.params(spec, pixels)
            else:
                params, adj = adjust_params(spec, decision.factors.get(x, {}), pixels=pixels)
            shaped = enforce(spec, params, decision.shapes)
            if shaped.pruned:
                cut[x] = shaped.pruned
                return False
            theta[x], adjustments[x] = shaped.params, [*adj, *shaped.adjustments]
            return True

        for x in decision.candidates:
            admit(x)
        if budget is None:
            return Theta(theta, adjustments, None, cut, used)
        terms = snap.table.budget_terms
        # what a relative-accuracy rule pruned is re-judged against the best *affordable* extractor
        relative = [x for x, cs in decision.pruned.items() if cs and all(c.rule in terms.relative_rules for c in cs)]
        relative = [x for x in relative if admit(x)]
        ates = {x: e.ate for x, e in decision.evidence.items() if e.ate}
        outcome = settle(snap.table.cost, terms, snap.vocab.extractors, ates, theta, relative, budget)
        for x, adj in outcome.adjustments.items():
            adjustments[x] = [*adjustments[x], *adj]
        kept = {x: outcome.params[x] for x in theta if x in outcome.params}
        return Theta(kept, adjustments, outcome, cut, {x: u for x, u in used.items() if x in kept})

    def _conditions(
        self,
        vocab: Vocabulary,
        given: dict[str, str],
        image: np.ndarray | None,
        previous: FrameState | None,
        stats: Mapping[str, float] | None,
    ) -> tuple[list[ContextEntry], dict[str, str | None]]:
        """Given dimensions win; estimable ones are estimated from the frame; the rest stay unknown."""
        if image is not None:
            from ..vision.context import estimate_context

            prev = previous.image if previous is not None else None
            entries = list(estimate_context(vocab, given, image, prev, stats=stats).entries())
        else:
            entries = [ContextEntry(d, given[d], "given", 1.0) if d in given else ContextEntry(d, None, "unknown")
                       for d in vocab.dimensions]
        return entries, {e.dimension: e.value for e in entries}

    def _score(
        self,
        snap: Snapshot,
        decision: Decision,
        values: Mapping[str, str | None],
        budget: Budget | None,
        nn: NeuralStep,
        image: np.ndarray | None,
        previous: FrameState | None,
    ) -> tuple[list[CandidateScore], FrameState | None, str, Theta]:
        vocab = snap.vocab
        if image is None:
            # the prior depends on the decision, the budget and (through ParamNet) the model in use
            key = (id(decision), None if budget is None else tuple(budget.as_dict().values()), nn.info.get("used"))
            cached = snap._priors.get(key)
            if cached is None:
                theta = self._theta(snap, decision, values, budget, nn, None)
                accuracy = measured_accuracy(decision, theta.params)
                priors = [self._prior(decision, x, theta, accuracy) for x in theta.params]
                cached = snap._priors[key] = (priors, theta)
            return list(cached[0]), None, "prior", cached[1]  # shared, frozen: read-only
        small = downscale(image, self.score_pixels)
        from ..vision.metrics import compute_metrics

        full_px = int(image.shape[0] * image.shape[1])
        theta = self._theta(snap, decision, values, budget, nn, full_px)
        accuracy = measured_accuracy(decision, theta.params)
        weight = sum(w.value for w in decision.weights.values())  # H: F_metrics' most without the bonus
        small_px = int(small.shape[0] * small.shape[1])

        def score(x: str) -> tuple[CandidateScore, Any]:
            params = theta.params[x]
            spec = vocab.extractor(x)
            # F_metrics is measured on the scoring image with this Θ′, count parameters scaled to its size
            feats = snap.registry.extract(x, small, _scaled(spec, params, small_px / full_px))
            prev = None
            if previous is not None and x in previous.features and previous.image.shape == small.shape:
                prev = (previous.features[x], previous.image)
            metrics = compute_metrics(feats, small, prev)
            bonus = decision.bonuses[x].value if x in decision.bonuses else 0.0
            f = f_metrics(metrics, decision.weights, vocab.metrics, bonus)
            return CandidateScore(
                extractor=x,
                params=params,
                score=f + weight * accuracy.get(x, 0.0),
                bonus=bonus,
                metrics={k: round(v, 6) for k, v in metrics.items()},
                adjustments=tuple(theta.adjustments[x]),
                keypoints=len(feats.xy),
                extraction_ms=round(feats.elapsed_ms, 3),
                evidence={**_evidence_dict(decision, x, theta), "f_metrics": f,
                          "measured_accuracy": round(accuracy.get(x, 0.0), 6)},
            ), feats

        def run(names: list[str]) -> list[tuple[CandidateScore, Any]]:
            # OpenCV releases the GIL: the candidates are extracted and scored side by side
            return list(_pool().map(score, names)) if len(names) > 1 else [score(x) for x in names]

        names = list(theta.params)
        known = nn.selector_extractors if nn.selectornet else None
        # SelectorNet is masked to what it was trained on: score those first; if it decides, the others
        # (probability 0 whatever their F_metrics) are not extracted at all
        first = [x for x in names if x in known] if known is not None else names
        done = run(first or names)
        scored = [c for c, _ in done]
        features = {c.extractor: feats for c, feats in done}
        if known is not None and first:
            everyone = scored + [self._unscored(decision, x, theta) for x in names if x not in first]
            ranked, decided = _by_network(nn, image, scored, everyone)
            if decided:
                return ranked, FrameState(small, features), "selectornet", theta
            more = run([x for x in names if x not in first])
            scored += [c for c, _ in more]
            features.update({c.extractor: feats for c, feats in more})
        return scored, FrameState(small, features), "metrics", theta

    def _unscored(self, decision: Decision, x: str, theta: Theta) -> CandidateScore:
        """A candidate SelectorNet was not trained on, listed (probability 0) but not extracted."""
        return CandidateScore(
            extractor=x,
            params=theta.params[x],
            score=None,
            adjustments=tuple(theta.adjustments[x]),
            evidence={**_evidence_dict(decision, x, theta),
                      "not_scored": "SelectorNet decided and was not trained on this extractor (probability 0)"},
        )

    def _prior(self, decision: Decision, x: str, theta: Theta, accuracy: Mapping[str, float]) -> CandidateScore:
        """Without a frame: the preference bonus plus the measured accuracy A(x)."""
        bonus = decision.bonuses[x].value if x in decision.bonuses else 0.0
        return CandidateScore(
            extractor=x,
            params=theta.params[x],
            score=bonus + accuracy.get(x, 0.0),
            bonus=bonus,
            adjustments=tuple(theta.adjustments[x]),
            evidence=_evidence_dict(decision, x, theta),
        )


def _by_network(
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
                    evidence={**c.evidence, "score_without_net": c.score} if c.score is not None else c.evidence)
            for c in everyone], True


def measured_accuracy(decision: Decision, candidates: Iterable[str]) -> dict[str, float]:
    """A(x) = min over the measured candidates of their median ATE / x's median ATE (module docstring)."""
    ates = {x: e.ate for x in candidates if (e := decision.evidence.get(x)) is not None and e.ate}
    best = min(ates.values(), default=None)
    return {x: best / ate for x, ate in ates.items()} if best else {}


_POOL: ThreadPoolExecutor | None = None
_POOL_LOCK = threading.Lock()


def _pool() -> ThreadPoolExecutor:
    """One small thread pool per process for scoring candidates side by side (``NFEX_SCORE_THREADS``,
    default the CPU count, at most 8)."""
    global _POOL
    if _POOL is None:
        with _POOL_LOCK:
            if _POOL is None:
                n = int(os.environ.get("NFEX_SCORE_THREADS") or min(8, os.cpu_count() or 1))
                _POOL = ThreadPoolExecutor(max(1, n), thread_name_prefix="nfex-score")
    return _POOL


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


def _evidence_dict(decision: Decision, x: str, theta: Theta | None = None) -> dict[str, Any]:
    e = decision.evidence.get(x)
    out: dict[str, Any] = {}
    if e is not None:
        out = e.as_dict()
    if theta is None:
        return out
    if x in theta.measured:
        config, cite = theta.measured[x]
        out["configuration"] = {"iri": config.iri, "ate_m": round(config.ate, 6), "aggregate": ROBUST,
                                "windows": config.windows, "outliers": config.outliers, "sources": len(config.sources),
                                "because": cite.as_dict()}
    if theta.outcome is not None and x in theta.outcome.estimates:
        est = theta.outcome.estimates[x]
        out["expected_ms"] = round(est.ms, 3) if est.ms is not None else None
        out["cost_source"] = est.source
    return out


def _cost(decision: Decision, c: CandidateScore) -> float:
    """Tie-break: the budget's expected time where known, else the measured mean extraction time."""
    if c.evidence.get("expected_ms") is not None:
        return float(c.evidence["expected_ms"])
    e = decision.evidence.get(c.extractor)
    return e.extraction_ms if e is not None and e.extraction_ms is not None else float("inf")
