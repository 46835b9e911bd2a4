"""The flow as code: ``PIPELINE``, the advisor's stages in order, and the ``Flow`` of one request through them.

    conditions ─► symbolic ─► params ─► budget ─► scoring ─► verification ─► answer          (``STAGES``)

``Advisor.select`` makes a ``Flow`` of one ``Request`` and runs ``PIPELINE`` in order: each ``Stage`` takes its
input record from the request and the outputs before it (``take``), and its ``run`` (stages.py) returns its own
output record, which the flow keeps under the stage's name. The Selection's ``timings_ms`` are keyed by the stages'
names (and ``total``, their sum); a stage that does not run for a carried decision (``on_reuse``) reports 0 ms.
"""
from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Generic, TypeVar

import numpy as np

from ..kg.vocabulary.vocab import Vocabulary
from ..neural.serve import NeuralStep
from .conditions import Conditions
from .params import Parameters
from .ranges import MetricRanges
from .reuse import ReuseTerms
from .scoring import FrameState, Scored, Scorer
from .selection import Selection
from .stages import (
    AnswerIn,
    BudgetIn,
    ConditionsIn,
    Memo,
    ParamsIn,
    ScoringIn,
    Settled,
    Symbolic,
    SymbolicIn,
    Verification,
    VerificationIn,
    answer,
    budget,
    conditions,
    params,
    scoring,
    symbolic,
    verification,
)

if TYPE_CHECKING:
    from ..rules.table import RuleTable

I = TypeVar("I")  # noqa: E741  (a stage's input record)
O = TypeVar("O")  # noqa: E741  (a stage's output record)


@dataclass(frozen=True)
class Request:
    """One call of ``Advisor.select``: the snapshot it answers from and what the caller sent."""

    vocab: Vocabulary
    table: RuleTable
    version: int
    programs: Mapping[str, int]
    reuse: ReuseTerms
    ranges: MetricRanges  # the snapshot's measured metric ranges (ranges.py)
    registry: Callable[[], Any]  # the snapshot's extractor registry (built on first use: it imports cv2)
    memo: Memo  # the snapshot's per-context answers (what does not depend on a frame)
    context: Mapping[str, Any]  # the client's context, without ``budget_ms`` and ``compute``
    frame: np.ndarray | None
    previous: FrameState | None
    budget_ms: float | None
    compute: str | None
    frame_size: tuple[int, int] | None
    neural: NeuralStep
    scorer: Scorer
    exhaustive: bool = False
    session: bool = False
    verdict_held: bool = True
    staleness: tuple[int, float] = (0, 0.0)  # (the store's head version, how stale the snapshot is in ms)
    timings: dict[str, float] = field(default_factory=dict)  # ms per stage, the runner's: the answer's ``timings_ms``


@dataclass(slots=True)
class Flow:
    """One request and the output of every stage that has run, under the stage's name: the runner's record, each
    member set once, by its stage (``Stage.__call__``); the outputs themselves are frozen records."""

    request: Request
    conditions: Conditions | None = None
    symbolic: Symbolic | None = None
    params: Parameters | None = None
    budget: Settled | None = None
    scoring: Scored | None = None
    verification: Verification | None = None
    answer: Selection | None = None

    @property
    def carried(self) -> bool:
        return self.symbolic is not None and self.symbolic.carried is not None


@dataclass(frozen=True)
class Stage(Generic[I, O]):
    """A named stage: ``take`` reads its input record off the flow, ``run`` makes its output record.
    ``on_reuse``: whether it runs when ``symbolic`` carries a decision from an earlier frame."""

    name: str
    take: Callable[[Flow], I]
    run: Callable[[I], O]
    on_reuse: bool = True

    def __call__(self, flow: Flow) -> Flow:
        setattr(flow, self.name, self.run(self.take(flow)))
        return flow


def _need(value: O | None) -> O:
    assert value is not None, "a stage ran before the stage it reads"
    return value


def _take_conditions(f: Flow) -> ConditionsIn:
    r = f.request
    return ConditionsIn(r.vocab, r.context, r.frame, r.previous)


def _take_symbolic(f: Flow) -> SymbolicIn:
    r = f.request
    return SymbolicIn(r.table, _need(f.conditions), r.budget_ms, r.compute, r.frame_size, r.reuse, r.version,
                      r.neural.info.get("used"), r.previous.decided if r.previous is not None else None, r.session,
                      r.verdict_held)


def _take_params(f: Flow) -> ParamsIn:
    r, cond, sym = f.request, _need(f.conditions), _need(f.symbolic)
    pixels = int(cond.image.shape[0] * cond.image.shape[1]) if cond.image is not None else None
    return ParamsIn(r.vocab, r.table, sym.decision, cond.values, sym.budget, r.neural, pixels, cond.stats,
                    r.memo if cond.image is None else None)


def _take_budget(f: Flow) -> BudgetIn:
    r, sym = f.request, _need(f.symbolic)
    return BudgetIn(r.table.cost, r.table.budget_terms, r.vocab.extractors, sym.decision, _need(f.params), sym.budget,
                    r.memo if _need(f.conditions).image is None else None)


def _take_scoring(f: Flow) -> ScoringIn:
    r, cond, sym = f.request, _need(f.conditions), _need(f.symbolic)
    candidates = _need(f.budget).candidates if sym.carried is None else {}
    return ScoringIn(r.vocab, r.registry, sym.decision, candidates, r.neural, cond.image, r.previous, r.scorer,
                     r.table.cost, r.exhaustive, r.memo if cond.image is None else None, sym.carried, r.session,
                     r.ranges, sym.refresh)


def _take_verification(f: Flow) -> VerificationIn:
    r, sym = f.request, _need(f.symbolic)
    return VerificationIn(r.vocab, r.table, sym.decision, _need(f.conditions).values, sym.budget, r.neural, r.memo)


def _take_answer(f: Flow) -> AnswerIn:
    r, sym = f.request, _need(f.symbolic)
    head, stale_ms = r.staleness
    versions = {"graph": r.version, "graph_head": head, "stale_ms": stale_ms, "programs": r.programs,
                "rules": len(r.table.rules), "model": r.neural.info}
    return AnswerIn(r.vocab, sym.decision, _need(f.conditions), sym, f.budget, _need(f.scoring), f.verification, versions,
                    r.timings)


PIPELINE: tuple[Stage[Any, Any], ...] = (
    Stage("conditions", _take_conditions, conditions),
    Stage("symbolic", _take_symbolic, symbolic),
    Stage("params", _take_params, params, on_reuse=False),
    Stage("budget", _take_budget, budget, on_reuse=False),
    Stage("scoring", _take_scoring, scoring),
    Stage("verification", _take_verification, verification, on_reuse=False),
    Stage("answer", _take_answer, answer),
)
STAGES: tuple[str, ...] = tuple(s.name for s in PIPELINE)
