"""The advisor: one object that runs the flow of DESIGN.md for a frame and a context.

    frame + context ─► conditions  E: what was given, the rest estimated from the frame   (conditions.py)
                    ─► symbolic    C(E) and what pruned the others: one lookup in the table
                                   compiled per graph version (rules.engine); the budget in force (budget.py)
                    ─► parameters  Θ′ per candidate: measured ▸ ParamNet ▸ g(Θ, E), then the
                                   context shapes, then the budget                          (params.py)
                    ─► scoring     F_metrics + H·A on the frame, SelectorNet masked to C(E), or the
                                   prior without a frame                                    (scoring.py)
                    ─► choice      α* and the candidates best first                          (choice.py)
                    ─► verification the proposals to try on the frame pair and the policy that judges
                                   their estimates, compiled per context            (nfex_core/verification.py)
                    ─► Selection   {α*, Θ′, scores, pruned + reasons, context, versions, timings} (selection.py)

It holds a snapshot — graph version, vocabulary, compiled rule table, extractor registry — and rebuilds
it when a commit moves the graph version: commits made through the same KnowledgeGraph are told at once,
others are seen at the next check (``poll_interval_s``; a shared remote store is polled). With
``background=True`` (the service) a stale snapshot answers while the next compiles on one background
thread, and each Selection says how stale it is; otherwise (the default: CLI, evaluations) a selection
after a commit waits for the new compile. ``snapshot(wait=True)``/``sync()`` ask for the head explicitly
(snapshots.py has the design and the staleness bound).
"""
from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import BadInput, NoCandidate
from ..kg.scope import EvidenceScope, scoped_graph
from ..kg.vocab import Vocabulary
from ..neural.serve import ModelHolder, NeuralStep, frame_stats
from ..rules.engine import RuleEngine, RuleTable
from ..rules.persisted import CompiledCache, store_key
from ..rules.types import Citation, Decision
from .budget import Budget, resolve_budget
from .choice import ranked
from .conditions import Conditions, read_conditions
from .params import Parameters, parameters
from .reuse import Decided, ReuseTerms, reusable
from .scoring import SCORE_PIXELS, FrameState, Scored, Scorer, by_network, downscale, prior_scores
from .selection import UNSCORED, CandidateScore, PrunedCandidate, Scoring, Selection
from .snapshots import Snapshots

if TYPE_CHECKING:
    from ..kg.store import KnowledgeGraph

CONSISTENCY = ("snapshot", "latest")


@dataclass
class Snapshot:
    version: int
    vocab: Vocabulary
    table: RuleTable
    programs: dict[str, int]
    reuse: ReuseTerms = field(default_factory=ReuseTerms)
    taken_at: float = field(default_factory=time.monotonic)
    _registry: Any = None
    # context-only answers depend on the decision alone: computed once per context and snapshot
    priors: dict[tuple[Any, ...], tuple[list[CandidateScore], Parameters]] = field(default_factory=dict)

    @property
    def registry(self) -> Any:
        """The extractor registry for this vocabulary (built on first use: it imports cv2)."""
        if self._registry is None:
            from ..vision.registry import ExtractorRegistry

            self._registry = ExtractorRegistry.from_vocabulary(self.vocab)
        return self._registry


class Advisor:
    """``neural``: symbolic | paramnet | selectornet | both (default: the settings'; see neural.serve);
    ``models``: the model folder (default: the settings'). Without a usable model the advisor is symbolic.
    ``score_pixels``: F_metrics is measured on a copy of the frame of about this many pixels (QQVGA, scoring.SCORE_PIXELS);
    ``score_threads``: candidates extracted side by side (default: the settings', else the CPU count);
    ``scope``: the evidence the advisor may read (kg.scope): the graph is read through it, and a model
    trained on a held-out sequence is not used.
    ``background``: compile new graph versions on a background thread while the last snapshot answers
    (snapshots.py); off, a selection after a commit waits for its compile (read-your-writes).
    ``compile_pause``: in background mode, how long a compile that follows another waits, as a multiple of the
    last one's duration (snapshots.py: compiles then take at most half of the process while commits stream in).
    ``exhaustive_scoring``: extract and score every candidate on a frame, not only those that can still win
    (scoring.Scorer; the same α* and Θ′, slower: for comparisons; default: the settings', NFEX_SCORE_ALL).
    ``compiled_cache``: a folder where the compiled rule table is kept across restarts (rules/persisted.py: the
    service's ``NFEX_COMPILED_CACHE``); not with a ``scope``, whose graph is not the store's."""

    def __init__(
        self,
        kg: KnowledgeGraph,
        *,
        score_pixels: int = SCORE_PIXELS,
        poll_interval_s: float = 1.0,
        neural: str | None = None,
        models: Path | str | None = None,
        score_threads: int | None = None,
        scope: EvidenceScope | None = None,
        background: bool = False,
        exhaustive_scoring: bool | None = None,
        compile_pause: float = 1.0,
        compiled_cache: Path | None = None,
    ) -> None:
        settings = kg.settings
        self.exhaustive_scoring = settings.score_all if exhaustive_scoring is None else exhaustive_scoring
        self.scope = scope or EvidenceScope()
        if not self.scope.empty and getattr(kg, "scope", None) != self.scope:
            kg = scoped_graph(kg, self.scope)  # every reader of measurements then honours the scope
        self.kg = kg
        self.neural = ModelHolder(models or settings.models, neural or settings.neural, held_out=self.scope.exclude_sequences)
        key = store_key(kg) if compiled_cache is not None and self.scope.empty else None
        cache = CompiledCache(compiled_cache, key) if compiled_cache is not None and key is not None else None
        self.engine = RuleEngine(kg, cache)
        self.scorer = Scorer(score_pixels, score_threads or settings.score_threads_or_cpus)
        self.snapshots: Snapshots[Snapshot] = Snapshots(self._build, lambda: self.kg.version,
                                                        poll_interval_s=poll_interval_s, background=background,
                                                        pause=compile_pause)
        kg.on_commit(self.snapshots.learn)

    @property
    def score_pixels(self) -> int:
        return self.scorer.score_pixels

    @property
    def poll_interval_s(self) -> float:
        return self.snapshots.poll_interval_s

    # ------------------------------------------------------------------ snapshot
    def invalidate(self) -> None:
        """Forget when the head was last read: the next ``snapshot()`` reads it."""
        self.snapshots.learn(-1, now=float("-inf"))

    def current_snapshot(self) -> Snapshot | None:
        """The snapshot built last (None before the first), without checking the graph version: for
        reporting (``/readyz``); ``snapshot()`` is what a selection uses."""
        return self.snapshots.current

    def is_fresh(self) -> bool:
        """Whether ``select`` will answer from the current snapshot without a store round trip or a rule
        compilation (the service then runs a context-only request on its event loop). In background mode a
        stale snapshot is fresh in this sense: its successor compiles elsewhere."""
        return self.snapshots.is_fresh()

    def snapshot(self, wait: bool = False) -> Snapshot:
        """The snapshot a selection answers from; ``wait``: of the store's head version (read-your-writes)."""
        return self.snapshots.get(wait)

    def sync(self) -> Snapshot:
        """Wait for (or make) the snapshot of the store's head version: after a write whose effect the caller
        must see in its next selection."""
        return self.snapshots.sync()

    def close(self) -> None:
        """Stop background compiles (waits for the running one) and keep the last compiled table where there is a
        ``compiled_cache``; call before closing the store."""
        if self.snapshots.close():  # a compile still running would be pickled as it changes: no table is kept then
            self.engine.save()

    def _build(self) -> Snapshot:
        vocab = self.kg.vocabulary()
        table = self.engine.table()
        programs: dict[str, int] = {}
        for s in table.statements:
            programs[s.program] = programs.get(s.program, 0) + 1
        return Snapshot(table.version, vocab, table, programs, ReuseTerms.load(self.kg))

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
        consistency: str = "snapshot",
        session: bool = False,
        verdict_held: bool = True,
    ) -> Selection:
        """The flow for one request. ``budget_ms`` (per-frame extraction time the client can afford) and
        ``compute`` (a compute class of the graph) may also come as context keys of those names;
        ``frame_size`` (W, H) sizes the cost check when no frame is sent. ``consistency``: ``snapshot``
        answers from the current snapshot (stale by at most the bound of snapshots.py in background mode),
        ``latest`` from the store's head version (it waits for that compile). ``session``: the frame belongs to a
        service session, whose decision is reused while its evidence holds (reuse.py; ``verdict_held``: the last
        verification verdict did not reject α*)."""
        if consistency not in CONSISTENCY:
            raise BadInput(f"consistency must be one of {', '.join(CONSISTENCY)}, got {consistency!r}")
        laps = _Laps()
        snap = self.snapshot(wait=consistency == "latest")
        ctx = dict(context or {})
        budget_ms = budget_number(ctx.pop("budget_ms", None) if budget_ms is None else budget_ms)
        compute = compute or ctx.pop("compute", None)
        ctx.pop("compute", None)
        given = snap.vocab.check_context(ctx)
        laps("snapshot")
        cond = read_conditions(snap.vocab, given, frame, previous)
        laps("conditions")
        decision = snap.table.decide(cond.values)
        if not decision.candidates:
            raise _no_candidate(decision.pruned)
        size = (int(cond.image.shape[1]), int(cond.image.shape[0])) if cond.image is not None else frame_size
        budget = resolve_budget(snap.table.budget_terms, snap.table.cost, cond.values, budget_ms, compute, size,
                                "frame" if cond.image is not None else "given")
        laps("symbolic")
        nn = self.neural.step(snap.vocab)
        if nn.active:
            nn.prepare(cond.values, frame_stats(cond.stats))
            laps("neural")
        # decision reuse (reuse.py) is off unless the graph allows it: then nothing of it runs per request
        key: tuple[Any, ...] | None = None
        estimate: tuple[tuple[str, str | None], ...] = ()
        if snap.reuse.limit(session) and cond.image is not None:
            # a session's decision rests on the given context and, separately, on the estimate (reuse.py)
            fixed = tuple(sorted((e.dimension, e.value) for e in cond.entries if e.source == "given"))
            estimate = tuple(sorted((e.dimension, e.value) for e in cond.entries if e.source != "given"))
            key = (snap.version, fixed if session else tuple(sorted(cond.values.items())),
                   budget.as_dict() if budget else None, nn.info.get("used"))
        if key is not None and previous is not None and previous.decided is not None:
            from ..vision.statistics import FRAME_KEYS

            carried = reusable(snap.reuse, previous.decided, key, cond.stats, FRAME_KEYS, session, verdict_held, estimate)
            if carried is not None:
                return self._reused(snap, carried, cond, previous, laps, session)
        params, scored = self._score(snap, decision, cond, budget, nn, previous)
        laps("selection")
        escalations = self._escalations(snap, decision, cond, budget, nn)
        answer = self._answer(snap, decision, cond, budget, nn, params, scored, laps.timings, escalations)
        if answer.state is not None:
            answer = replace(answer, state=replace(answer.state, analysis=cond.analysis))
        if key is not None and answer.state is not None and cond.stats is not None:  # what the next frames may reuse
            decided = Decided(key, dict(cond.stats), replace(answer, state=None), estimate=estimate)
            answer = replace(answer, state=replace(answer.state, decided=decided))
        return answer

    def _reused(self, snap: Snapshot, decided: Decided, cond: Conditions, previous: FrameState, laps: _Laps,
                session: bool) -> Selection:
        """The last scored answer for a frame whose evidence has not moved (reuse.py). The stream keeps this frame's
        image; in a session α* is extracted on it (one extraction), so the next decision's temporal metrics compare
        neighbouring frames with α*'s features at hand."""
        assert cond.image is not None
        small = downscale(cond.image, self.score_pixels)
        features: dict[str, Any] = {}
        alpha = decided.selection.extractor
        pixels = 0
        if session and alpha in previous.params and previous.image.shape == small.shape:
            features[alpha] = snap.registry.extract(alpha, small, previous.params[alpha])
            pixels = int(small.size)
        laps("reused")
        timings = dict(laps.timings, total=sum(laps.timings.values()))
        why = (f"the decision of {decided.reused} frame(s) ago reused: the "
               + ("condition estimate and the verification verdict have not moved" if session else
                  "context and the frame statistics have not moved"))
        if decided.differed:
            why += f" (the estimate has differed for {decided.differed} frame(s): a change re-decides once it holds)"
        return replace(decided.selection, context=cond.entries, timings_ms=timings, reused=decided.reused,
                       scoring=Scoring(UNSCORED, why, 1 if features else 0, pixels),
                       state=FrameState(small, features, dict(previous.params), decided, cond.analysis))

    def _escalations(self, snap: Snapshot, decision: Decision, cond: Conditions, budget: Budget | None,
                     nn: NeuralStep) -> tuple[CandidateScore, ...]:
        """Under a budget, with verification in force: the candidates that fit the per-frame cap
        (``nfex:verificationCap`` budgets), best first, Θ′ fitted to the cap — what a pair may escalate to where
        the affordable candidates fail (verification.BudgetWindow keeps the mean within the budget)."""
        cap = snap.table.budget_terms.verification_cap
        if budget is None or not decision.verification.active or cap <= 1.0:
            return ()
        wide = replace(budget, ms=budget.ms * cap, source=f"{budget.source} × verification cap {cap:g}")
        key = ("escalations", id(decision), tuple(wide.as_dict().values()), nn.info.get("used"))
        cached = snap.priors.get(key)
        if cached is None:
            params = parameters(snap.vocab, snap.table, decision, cond.values, wide, nn, None)
            cached = snap.priors[key] = (ranked(decision, prior_scores(decision, params)), params)
        return tuple(cached[0])

    def _score(
        self, snap: Snapshot, decision: Decision, cond: Conditions, budget: Budget | None, nn: NeuralStep,
        previous: FrameState | None,
    ) -> tuple[Parameters, Scored]:
        """Stages parameters and scoring (the prior without a frame is computed once per context and snapshot)."""
        if cond.image is None:
            # the prior depends on the decision, the budget and (through ParamNet) the model in use
            key = (id(decision), None if budget is None else tuple(budget.as_dict().values()), nn.info.get("used"))
            cached = snap.priors.get(key)
            if cached is None:
                params = parameters(snap.vocab, snap.table, decision, cond.values, budget, nn, None)
                cached = snap.priors[key] = (prior_scores(decision, params), params)
            listed, decided = by_network(nn, None, list(cached[0]), list(cached[0]))
            how = Scoring(UNSCORED, "no frame: " + ("SelectorNet's probabilities on the context" if decided else
                                                    "the preference bonus and the measured accuracy decide"))
            return cached[1], Scored(listed, None, "selectornet" if decided else "prior", how)
        pixels = int(cond.image.shape[0] * cond.image.shape[1])
        params = parameters(snap.vocab, snap.table, decision, cond.values, budget, nn, pixels)
        # verification tries the first proposals in order: those must be scored, not only the winner
        top = decision.verification.max_tries if decision.verification.active else 1
        return params, self.scorer.on_frame(snap.vocab, snap.registry, decision, params, nn, cond.image, previous,
                                            self.exhaustive_scoring, snap.table.cost, top)

    def _answer(
        self, snap: Snapshot, decision: Decision, cond: Conditions, budget: Budget | None, nn: NeuralStep,
        params: Parameters, scored: Scored, timings: dict[str, float], escalations: tuple[CandidateScore, ...] = (),
    ) -> Selection:
        """α*, the candidates best first and everything that was pruned on the way, as a Selection."""
        pruned: dict[str, tuple[Citation, ...]] = {**decision.pruned, **params.shaped_out}
        if not scored.candidates:
            raise _no_candidate(pruned)
        order = ranked(decision, scored.candidates)
        best = order[0]
        outcome = params.budget
        if outcome is not None:
            for x in outcome.readmitted:
                pruned.pop(x, None)
            pruned.update({x: cs for x, cs in outcome.pruned.items() if x != best.extractor})
        spec = snap.vocab.extractor(best.extractor)
        head, stale_ms = self.snapshots.staleness(snap)
        timings["total"] = sum(timings.values())
        return Selection(
            extractor=best.extractor,
            params=dict(best.params),
            mode=scored.mode,
            candidates=tuple(order),
            pruned=tuple(PrunedCandidate(x, cs) for x, cs in sorted(pruned.items())),
            context=cond.entries,
            weights=dict(decision.weights),
            versions={"graph": snap.version, "graph_head": head, "stale_ms": stale_ms, "programs": snap.programs, "rules": len(snap.table.rules), "model": nn.info},
            timings_ms=timings,
            opencv=spec.opencv(best.params),
            recipe=lambda x, p: snap.vocab.extractor(x).opencv(p),
            state=scored.state,
            budget=budget.as_dict() if budget is not None else None,
            warnings=tuple(outcome.warnings) if outcome is not None else (),
            verification=decision.verification,
            escalations=escalations,
            scoring=scored.scoring,
        )


class _Laps:
    """Milliseconds per stage of one request."""

    def __init__(self) -> None:
        self.timings: dict[str, float] = {}
        self._t = time.perf_counter()

    def __call__(self, name: str) -> None:
        now = time.perf_counter()
        self.timings[name] = (now - self._t) * 1000
        self._t = now


def _no_candidate(pruned: Mapping[str, tuple[Citation, ...]]) -> NoCandidate:
    return NoCandidate(
        "every extractor is pruned in this context: "
        + "; ".join(f"{x}: {cs[0].reason} [{cs[0].label}]" for x, cs in pruned.items()),
        pruned=[PrunedCandidate(x, tuple(cs)).as_dict() for x, cs in pruned.items()],
    )


def budget_number(value: Any) -> float | None:
    """A request's ``budget_ms``: a positive, finite number of milliseconds, or None."""
    if value is None:
        return None
    try:
        ms = float(value)
    except (TypeError, ValueError):
        raise BadInput(f"budget_ms must be a number of milliseconds, got {value!r}") from None
    if not ms > 0 or ms == float("inf"):
        raise BadInput(f"budget_ms must be a positive number of milliseconds, got {value!r}")
    return ms
