"""The advisor: one object that runs the flow of DESIGN.md for a frame and a context.

    frame + context ─► conditions    E: what was given, the rest estimated from the frame          (conditions.py)
                    ─► symbolic      C(E) and what pruned the others: one lookup in the table compiled per
                                     graph version (rules.engine); the budget in force; a stream's decision
                                     carried while its evidence holds                        (budget.py, reuse.py)
                    ─► params        Θ′ per candidate: measured ▸ ParamNet ▸ g(Θ, E), then the context shapes
                                                                                                  (params.py)
                    ─► budget        the cost check: fit Θ′ or prune; re-admit what was pruned relative to an
                                     unaffordable best                                            (budget.py)
                    ─► scoring       F_metrics + H·A on the frame, SelectorNet masked to C(E), or the prior
                                     without a frame; ranked best first                (scoring.py, choice.py)
                    ─► verification  the policy that judges a frame pair's estimates, compiled per context, and
                                     under a budget the escalations               (nfex_core/verification/)
                    ─► answer        Selection {α*, Θ′, scores, pruned + reasons, context, versions, timings}
                                                                                               (selection.py)

Each stage is a function from a typed input record to a typed output record (stages.py), run in order by ``PIPELINE`` (pipeline.py);
``select`` runs them in order and times each under its name.

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
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import BadInput
from ..kg.scope import EvidenceScope, scoped_graph
from ..kg.vocabulary.vocab import Vocabulary
from ..neural.serve import ModelHolder
from ..rules.engine import RuleEngine
from ..rules.persisted import CompiledCache, store_key
from ..rules.table import RuleTable
from .pipeline import PIPELINE, Flow, Request
from .ranges import MetricRanges
from .reuse import ReuseTerms
from .scoring import SCORE_PIXELS, FrameState, Scorer
from .selection import Selection
from .snapshots import Snapshots
from .stages import Memo

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
    ranges: MetricRanges = field(default_factory=MetricRanges)  # measured metric ranges (ranges.py)
    taken_at: float = field(default_factory=time.monotonic)
    _registry: Any = None
    # context-only answers depend on the decision alone: computed once per context and snapshot (stages.py)
    priors: Memo = field(default_factory=Memo)

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
        return Snapshot(table.version, vocab, table, programs, ReuseTerms.load(self.kg),
                        MetricRanges.load(self.kg, self.scope.exclude_sequences))

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
        """The flow for one request: ``PIPELINE``'s stages in order (pipeline.py). ``budget_ms`` (per-frame extraction
        time the client can afford) and ``compute`` (a compute class of the graph) may also come as context keys of
        those names; ``frame_size`` (W, H) sizes the cost check when no frame is sent. ``consistency``: ``snapshot``
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
        request = Request(
            vocab=snap.vocab, table=snap.table, version=snap.version, programs=snap.programs, reuse=snap.reuse, ranges=snap.ranges,
            registry=lambda: snap.registry, memo=snap.priors, context=ctx, frame=frame, previous=previous,
            budget_ms=budget_ms, compute=compute, frame_size=frame_size, neural=self.neural.step(snap.vocab),
            scorer=self.scorer, exhaustive=self.exhaustive_scoring, session=session, verdict_held=verdict_held,
            staleness=self.snapshots.staleness(snap), timings=laps.timings,
        )
        flow = Flow(request)
        for stage in PIPELINE:
            if flow.carried and not stage.on_reuse:
                laps.skip(stage.name)
                continue
            stage(flow)
            laps(stage.name)
        assert flow.answer is not None
        laps.timings["total"] = sum(laps.timings.values())  # the answer's timings_ms: the runner's, filled in last
        return flow.answer


class _Laps:
    """Milliseconds per stage of one request."""

    def __init__(self) -> None:
        self.timings: dict[str, float] = {}
        self._t = time.perf_counter()

    def __call__(self, name: str) -> None:
        now = time.perf_counter()
        self.timings[name] = (now - self._t) * 1000
        self._t = now

    def skip(self, name: str) -> None:
        self.timings[name] = 0.0


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
