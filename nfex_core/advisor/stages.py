"""The advisor's stages, each a function from a typed input record (``…In``) to a typed output record.

    conditions ─► symbolic ─► params ─► budget ─► scoring ─► verification ─► answer

pipeline.py runs them in this order (``PIPELINE``) and builds each input record from the request and the outputs
before it; a stage reads only its input record and returns a new output record, never changing another's.

A session's decision that ``symbolic`` carries from an earlier frame (reuse.py) skips ``params``, ``budget`` and
``verification``: ``scoring`` then extracts α* alone and ``answer`` answers the carried Selection. Without a frame,
``params``, ``budget`` and the prior scores are computed once per context and snapshot (the ``memo`` of their input
records), as are the escalations in ``verification``.
"""
from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any, TypeVar

import numpy as np

from ..errors import NoCandidate
from ..evidence.cost import BudgetTerms, CostModel
from ..kg.vocabulary.vocab import ExtractorSpec, Vocabulary
from ..neural.serve import NeuralStep, frame_stats
from ..rules.types import Citation, Decision, Policy
from .budget import Budget, BudgetOutcome, resolve_budget, settle
from .choice import ranked
from .conditions import Conditions, read_conditions
from .params import Candidate, Parameters, theta
from .ranges import MetricRanges
from .reuse import Decided, ReuseTerms, refreshed, reusable
from .scoring import FrameState, Scored, Scorer, by_network, downscale, prior_scores
from .selection import UNSCORED, CandidateScore, PrunedCandidate, Scoring, Selection

if TYPE_CHECKING:
    from ..rules.table import RuleTable

V = TypeVar("V")
MEMO_LIMIT = 20_000  # entries of a snapshot's Memo: contexts × budgets × frame sizes × models asked


class Memo:
    """A snapshot's answers that do not depend on a frame, per key; at most ``limit`` kept (past it an answer is
    computed each time: a client's budgets and frame sizes cannot grow it without bound). A key may name objects by
    ``id``; those objects are kept with the answer and a hit requires the same objects, so a reused id never
    answers for another."""

    def __init__(self, limit: int = MEMO_LIMIT) -> None:
        self.limit = limit
        self._kept: dict[tuple[Any, ...], tuple[tuple[object, ...], Any]] = {}

    def __len__(self) -> int:
        return len(self._kept)

    def get(self, key: tuple[Any, ...], make: Callable[[], V], *owners: object) -> V:
        """The answer under ``key`` (whose ids name ``owners``), made by ``make`` where none is kept."""
        hit = self._kept.get(key)
        if hit is not None and len(hit[0]) == len(owners) and all(a is b for a, b in zip(hit[0], owners, strict=True)):
            return hit[1]
        value = make()
        if len(self._kept) < self.limit:
            self._kept[key] = (owners, value)
        return value


# ---------------------------------------------------------------- conditions
@dataclass(frozen=True)
class ConditionsIn:
    vocab: Vocabulary
    context: Mapping[str, Any]
    frame: np.ndarray | None
    previous: FrameState | None


def conditions(i: ConditionsIn) -> Conditions:
    """E: the context checked against the vocabulary, the rest estimated from the frame (conditions.py)."""
    return read_conditions(i.vocab, i.vocab.check_context(i.context), i.frame, i.previous)


# ---------------------------------------------------------------- symbolic
@dataclass(frozen=True)
class SymbolicIn:
    table: RuleTable
    conditions: Conditions
    budget_ms: float | None = None
    compute: str | None = None
    frame_size: tuple[int, int] | None = None
    reuse: ReuseTerms = field(default_factory=ReuseTerms)
    version: int = 0
    model: str | None = None  # the network in use (NeuralStep.info["used"]): a decision is reused under the same one
    last: Decided | None = None  # the decision the stream's previous frame kept
    session: bool = False
    verdict_held: bool = True


@dataclass(frozen=True)
class Symbolic:
    """C(E) with what pruned the others, the budget in force, and the key a later frame may reuse this decision
    under (None: reuse is off) — or the decision carried from an earlier frame."""

    decision: Decision
    budget: Budget | None
    key: tuple[Any, ...] | None = None
    estimate: tuple[tuple[str, str | None], ...] = ()
    carried: Decided | None = None
    refresh: Decided | None = None  # a session's decision due again while its evidence holds (reuse.refreshed)


def symbolic(i: SymbolicIn) -> Symbolic:
    """One lookup in the compiled table (rules/engine.py), the budget in force (budget.py), decision reuse (reuse.py)."""
    cond = i.conditions
    decision = i.table.decide(cond.values)
    if not decision.candidates:
        raise no_candidate(decision.pruned)
    size = (int(cond.image.shape[1]), int(cond.image.shape[0])) if cond.image is not None else i.frame_size
    budget = resolve_budget(i.table.budget_terms, i.table.cost, cond.values, i.budget_ms, i.compute, size,
                            "frame" if cond.image is not None else "given")
    if not (i.reuse.limit(i.session) and cond.image is not None):  # reuse is off unless the graph allows it
        return Symbolic(decision, budget)
    # a session's decision rests on the given context and, separately, on the estimate (reuse.py)
    fixed = tuple(sorted((e.dimension, e.value) for e in cond.entries if e.source == "given"))
    estimate = tuple(sorted((e.dimension, e.value) for e in cond.entries if e.source != "given"))
    key = (i.version, fixed if i.session else tuple(sorted(cond.values.items())),
           budget.as_dict() if budget else None, i.model)
    carried = None
    if i.last is not None:
        from ..vision.statistics import FRAME_KEYS

        confidence = {e.dimension: e.confidence for e in cond.entries if e.source != "given"}
        carried = reusable(i.reuse, i.last, key, cond.stats, FRAME_KEYS, i.session, i.verdict_held, estimate, confidence)
        if carried is None and i.session:
            refresh = refreshed(i.reuse, i.last, key, cond.stats, FRAME_KEYS, i.verdict_held, estimate, confidence)
            return Symbolic(decision, budget, key, estimate, None, refresh)
    return Symbolic(decision, budget, key, estimate, carried)


# ---------------------------------------------------------------- params
@dataclass(frozen=True)
class ParamsIn:
    vocab: Vocabulary
    table: RuleTable
    decision: Decision
    values: Mapping[str, str | None]
    budget: Budget | None
    neural: NeuralStep
    pixels: int | None = None  # the frame's pixel count; None without a frame
    stats: Mapping[str, float] | None = None  # the frame statistics (ParamNet's input)
    memo: Memo | None = None  # without a frame: Θ′ once per context and snapshot


def params(i: ParamsIn) -> Parameters:
    """Θ′ per candidate (params.py); the network's inputs are encoded once here for ParamNet and SelectorNet."""
    if i.neural.active:
        i.neural.prepare(i.values, frame_stats(i.stats))
    if i.memo is None:
        return theta(i.vocab, i.table, i.decision, i.values, i.budget, i.neural, i.pixels)
    return i.memo.get(("params", id(i.decision), i.budget, i.neural.info.get("used")),
                      lambda: theta(i.vocab, i.table, i.decision, i.values, i.budget, i.neural, i.pixels), i.decision)


# ---------------------------------------------------------------- budget
@dataclass(frozen=True)
class BudgetIn:
    cost: CostModel
    terms: BudgetTerms
    specs: Mapping[str, ExtractorSpec]
    decision: Decision
    params: Parameters
    budget: Budget | None
    memo: Memo | None = None  # without a frame: once per context and snapshot


@dataclass(frozen=True)
class Settled:
    """The candidates after the cost check (Θ′ fitted where adjusted), everything pruned so far with its reasons
    (the table's, the context shapes', the budget's; re-admitted ones taken out), and the check's outcome."""

    candidates: Mapping[str, Candidate]
    pruned: Mapping[str, tuple[Citation, ...]]
    outcome: BudgetOutcome | None = None


def settle_budget(i: BudgetIn) -> Settled:
    """Under a budget, fit or prune each candidate and re-judge those a relative-accuracy rule pruned against the
    best affordable extractor (budget.py ``settle``); without one, the candidates as they are."""
    pruned: dict[str, tuple[Citation, ...]] = {**i.decision.pruned, **i.params.shaped_out}
    if i.budget is None:
        return Settled(dict(i.params.candidates), pruned)
    everyone = {**i.params.candidates, **i.params.relative}
    ates = {x: e.ate for x, e in i.decision.evidence.items() if e.ate}
    outcome = settle(i.cost, i.terms, i.specs, ates, {x: c.params for x, c in everyone.items()}, list(i.params.relative),
                     i.budget)
    candidates = {
        x: replace(c, params=outcome.params[x], adjustments=(*c.adjustments, *outcome.adjustments.get(x, ())),
                   cost=outcome.estimates.get(x))
        for x, c in everyone.items() if x in outcome.params
    }
    for x in outcome.readmitted:
        pruned.pop(x, None)
    pruned.update(outcome.pruned)
    return Settled(candidates, pruned, outcome)


def budget(i: BudgetIn) -> Settled:
    """The stage: ``settle_budget``, once per context and snapshot without a frame (``memo``)."""
    if i.memo is None:
        return settle_budget(i)
    return i.memo.get(("budget", id(i.params)), lambda: settle_budget(i), i.params)  # one decision, budget, model


# ---------------------------------------------------------------- scoring
@dataclass(frozen=True)
class ScoringIn:
    vocab: Vocabulary
    registry: Callable[[], Any]
    decision: Decision
    candidates: Mapping[str, Candidate]
    neural: NeuralStep
    image: np.ndarray | None
    previous: FrameState | None
    scorer: Scorer
    cost: CostModel
    exhaustive: bool = False
    memo: Memo | None = None  # without a frame: the prior scores once per context and snapshot
    carried: Decided | None = None
    session: bool = False
    ranges: MetricRanges | None = None  # measured metric ranges: evidence that narrows the bounds (ranges.py)
    refresh: Decided | None = None  # a session's decision due again while its evidence holds (Symbolic.refresh)


def scoring(i: ScoringIn) -> Scored:
    """Scores on the frame (scoring.Scorer), or the prior without one, ranked best first (choice.py); for a carried
    decision, α*'s features on this frame (in a session) and why nothing was scored."""
    if i.carried is not None:
        return _carried(i, i.carried)
    if i.image is None:
        def prior() -> list[CandidateScore]:
            return prior_scores(i.decision, Parameters(dict(i.candidates)))

        hit = prior() if i.memo is None else \
            i.memo.get(("prior", id(i.decision), id(i.candidates)), prior, i.decision, i.candidates)
        listed, decided = by_network(i.neural, None, list(hit), list(hit))
        how = Scoring(UNSCORED, "no frame: " + ("SelectorNet's probabilities on the context" if decided else
                                                "the preference bonus and the measured accuracy decide"))
        return Scored(ranked(i.decision, listed), None, "selectornet" if decided else "prior", how)
    # verification tries the first proposals in order: those must be scored, not only the winner
    top = i.decision.verification.max_tries if i.decision.verification.active else 1
    first: Scoring | None = None  # a refreshed decision's single answer, where α* came out another
    if i.refresh is not None and top > 1 and not i.exhaustive:
        kept, first = _refreshed(i, i.refresh)
        if kept is not None:
            return kept
    scored = i.scorer.on_frame(i.vocab, i.registry(), i.decision, Parameters(dict(i.candidates)), i.neural, i.image,
                               i.previous, i.exhaustive, i.cost, top, i.ranges)
    if first is not None and scored.scoring is not None:  # the answer counts all the work it took
        scored = replace(scored, scoring=replace(
            scored.scoring, extractions=scored.scoring.extractions + first.extractions,
            pixels=scored.scoring.pixels + first.pixels,
            reason=f"{scored.scoring.reason} (after α* alone came out other than the decision due again)"))
    return replace(scored, candidates=ranked(i.decision, scored.candidates))


def _refreshed(i: ScoringIn, due: Decided) -> tuple[Scored | None, Scoring | None]:
    """A session's decision due again while its evidence held (its verdicts accepted α*, its estimate unchanged):
    α* is scored on this frame as a single answer; where it is the decision's α* again, the proposals after it keep
    the order that decision scored them in (the pair has confirmed it since), so the others are not extracted.
    Where α* changed: (None, what that single answer took); the frame is then scored for every proposal (a rare
    case, whose extractions on this frame run again)."""
    assert i.image is not None
    scored = i.scorer.on_frame(i.vocab, i.registry(), i.decision, Parameters(dict(i.candidates)), i.neural, i.image,
                               i.previous, False, i.cost, 1, i.ranges)
    order = ranked(i.decision, scored.candidates)
    before = [c.extractor for c in due.selection.candidates]
    if not order or order[0].extractor != due.selection.extractor:
        return None, scored.scoring
    rest = sorted(order[1:], key=lambda c: before.index(c.extractor) if c.extractor in before else len(before))
    assert scored.scoring is not None
    how = replace(scored.scoring, reason=f"{scored.scoring.reason}; the proposals after {order[0].extractor} in the "
                  f"order the decision of {due.reused + 1} frame(s) ago scored them: its α* again, and its verdicts held")
    return replace(scored, candidates=[order[0], *rest], scoring=how), None


def _carried(i: ScoringIn, decided: Decided) -> Scored:
    """A reused decision (reuse.py). The stream keeps this frame's image; in a session α* is extracted on it (one
    extraction), so the next decision's temporal metrics compare neighbouring frames with α*'s features at hand."""
    assert i.image is not None and i.previous is not None
    small = downscale(i.image, i.scorer.score_pixels)
    features: dict[str, Any] = {}
    carried: Selection = decided.selection
    alpha = carried.extractor
    pixels = 0
    if i.session and alpha in i.previous.params and i.previous.image.shape == small.shape:
        features[alpha] = i.registry().extract(alpha, small, i.previous.params[alpha])
        pixels = int(small.size)
    why = (f"the decision of {decided.reused} frame(s) ago reused: the "
           + ("condition estimate and the verification verdict have not moved" if i.session else
              "context and the frame statistics have not moved"))
    if decided.differed:
        why += f" (the estimate has differed for {decided.differed} frame(s): a change re-decides once it holds)"
    return Scored(list(carried.candidates), FrameState(small, features, dict(i.previous.params), decided),
                  carried.mode, Scoring(UNSCORED, why, 1 if features else 0, pixels))


# ---------------------------------------------------------------- verification
@dataclass(frozen=True)
class VerificationIn:
    vocab: Vocabulary
    table: RuleTable
    decision: Decision
    values: Mapping[str, str | None]
    budget: Budget | None
    neural: NeuralStep
    memo: Memo


@dataclass(frozen=True)
class Verification:
    """How a frame pair's estimate is judged here (the compiled policy, nfex_core/verification/judge.py) and, under a
    budget, what a pair may escalate to beyond the affordable candidates."""

    policy: Policy
    escalations: tuple[CandidateScore, ...] = ()


def verification(i: VerificationIn) -> Verification:
    """The policy in force and, under a budget with verification in force, the candidates that fit the per-frame cap
    (``nfex:verificationCap`` budgets), best first, Θ′ fitted to the cap (verification.BudgetWindow keeps the mean
    within the budget); computed once per context and snapshot."""
    policy = i.decision.verification
    cap = i.table.budget_terms.verification_cap
    if i.budget is None or not policy.active or cap <= 1.0:
        return Verification(policy)
    wide = replace(i.budget, ms=i.budget.ms * cap, source=f"{i.budget.source} × verification cap {cap:g}")

    def escalations() -> tuple[CandidateScore, ...]:
        p = theta(i.vocab, i.table, i.decision, i.values, wide, i.neural, None)
        settled = settle_budget(BudgetIn(i.table.cost, i.table.budget_terms, i.vocab.extractors, i.decision, p, wide))
        return tuple(ranked(i.decision, prior_scores(i.decision, Parameters(dict(settled.candidates)))))

    return Verification(policy, i.memo.get(("escalations", id(i.decision), wide, i.neural.info.get("used")),
                                           escalations, i.decision))


# ---------------------------------------------------------------- answer
@dataclass(frozen=True)
class AnswerIn:
    vocab: Vocabulary
    decision: Decision
    conditions: Conditions
    symbolic: Symbolic
    settled: Settled | None  # None for a carried decision
    scored: Scored
    verification: Verification | None  # None for a carried decision
    versions: Mapping[str, Any] = field(default_factory=dict)
    timings: dict[str, float] = field(default_factory=dict)  # the runner's ms per stage, filled in as the flow runs


def answer(i: AnswerIn) -> Selection:
    """α* (the first of the ranked candidates), the candidates best first and everything pruned on the way, as a
    Selection; a carried decision's Selection with this frame's context and state. ``timings_ms`` is the runner's
    ``timings`` (it times this stage after it returns)."""
    state = i.scored.state
    if state is not None:
        state = replace(state, analysis=i.conditions.analysis)
    carried = i.symbolic.carried
    if carried is not None:
        return replace(carried.selection, context=i.conditions.entries, timings_ms=i.timings, reused=carried.reused,
                       scoring=i.scored.scoring, state=state)
    assert i.settled is not None and i.verification is not None
    order = i.scored.candidates
    if not order:
        raise no_candidate(i.settled.pruned)
    best = order[0]
    outcome = i.settled.outcome
    spec = i.vocab.extractor(best.extractor)
    vocab = i.vocab
    sel = Selection(
        extractor=best.extractor,
        params=dict(best.params),
        mode=i.scored.mode,
        candidates=tuple(order),
        pruned=tuple(PrunedCandidate(x, cs) for x, cs in sorted(i.settled.pruned.items()) if x != best.extractor),
        context=i.conditions.entries,
        weights=dict(i.decision.weights),
        versions=dict(i.versions),
        timings_ms=i.timings,
        opencv=spec.opencv(best.params),
        recipe=lambda x, p: vocab.extractor(x).opencv(p),
        budget=i.symbolic.budget.as_dict() if i.symbolic.budget is not None else None,
        warnings=tuple(outcome.warnings) if outcome is not None else (),
        verification=i.verification.policy,
        escalations=i.verification.escalations,
        scoring=i.scored.scoring,
    )
    stats = i.conditions.stats
    if state is None:
        return sel
    if i.symbolic.key is not None and stats is not None:  # what the next frames may reuse (the answer without its state)
        state = replace(state, decided=Decided(i.symbolic.key, dict(stats), sel, estimate=i.symbolic.estimate))
    return replace(sel, state=state)


def no_candidate(pruned: Mapping[str, tuple[Citation, ...]]) -> NoCandidate:
    return NoCandidate(
        "every extractor is pruned in this context: "
        + "; ".join(f"{x}: {cs[0].reason} [{cs[0].label}]" for x, cs in pruned.items()),
        pruned=[PrunedCandidate(x, tuple(cs)).as_dict() for x, cs in pruned.items()],
    )
