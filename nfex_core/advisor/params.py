"""Stage 3 of the flow, parameters: Θ′ for every candidate of C(E).

Θ′ comes from a declared chain of sources, tried in order; the first that has something to say sets it:

1. ``measured`` — the configuration of α with the lowest mean ATE measured under E, where the graph holds
   enough windows (``advisor.measured``; under a budget the best that fits);
2. ``paramnet`` — ParamNet(E, s), where the network is in use and learned α's parameters (``neural.serve``);
3. ``rules``   — the paper's g(Θ, E) = Θ·Π_j f_kj(e_j) (``fitness.adjust_params``); always answers.

Then the context shapes in force repair Θ′ (clamp a violated bound) or prune α (``rules.shape_check``),
and then, under a budget, the cost check fits Θ′ (fewer features or levels) or prunes α
(``advisor.budget.settle``). A new source of Θ′ is a class with ``name`` and ``propose`` added to
``THETA_SOURCES`` at its place in the order.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Protocol

from ..cost import CostModel, Estimate
from ..fitness import adjust_params
from ..kg.vocab import ExtractorSpec, Value, Vocabulary
from ..neural.serve import NeuralStep
from ..rules.engine import RuleTable
from ..rules.shape_check import enforce
from ..rules.types import Adjustment, Citation, Decision, MeasuredConfiguration
from .budget import Budget, BudgetOutcome, settle
from .measured import measured_params


@dataclass(frozen=True)
class ThetaInputs:
    """What every source of Θ′ may read for one request."""

    decision: Decision
    measured: Mapping[str, Sequence[MeasuredConfiguration]]  # RuleTable.measured(E)
    conditions: str  # E as text, for the reasons
    cost: CostModel
    budget: Budget | None
    neural: NeuralStep
    pixels: int | None  # the frame's pixel count (count parameters scale with it); None without a frame


@dataclass(frozen=True)
class Proposal:
    """Θ′ for one extractor from one source, with what it changed from the defaults and why."""

    params: dict[str, Value]
    adjustments: tuple[Adjustment, ...]
    source: str
    configuration: MeasuredConfiguration | None = None
    because: Citation | None = None


class ThetaSource(Protocol):
    name: str

    def propose(self, spec: ExtractorSpec, inputs: ThetaInputs) -> Proposal | None: ...


class Measured:
    name = "measured"

    def propose(self, spec: ExtractorSpec, inputs: ThetaInputs) -> Proposal | None:
        ranked = inputs.measured.get(spec.name)
        if not ranked:
            return None
        params, adj, config, cite = measured_params(spec, ranked, inputs.conditions, inputs.cost, inputs.budget)
        return Proposal(params, tuple(adj), self.name, config, cite)


class ParamNet:
    name = "paramnet"

    def propose(self, spec: ExtractorSpec, inputs: ThetaInputs) -> Proposal | None:
        if not inputs.neural.covers(spec.name):
            return None
        params, adj = inputs.neural.params(spec, inputs.pixels)
        return Proposal(params, tuple(adj), self.name)


class Rules:
    name = "rules"

    def propose(self, spec: ExtractorSpec, inputs: ThetaInputs) -> Proposal | None:
        params, adj = adjust_params(spec, inputs.decision.factors.get(spec.name, {}), pixels=inputs.pixels)
        return Proposal(params, tuple(adj), self.name)


THETA_SOURCES: tuple[ThetaSource, ...] = (Measured(), ParamNet(), Rules())


@dataclass(frozen=True)
class Candidate:
    """A candidate α with its Θ′ after the chain, the shapes and the budget."""

    extractor: str
    params: dict[str, Value]
    adjustments: tuple[Adjustment, ...]
    proposal: Proposal  # where Θ′ came from
    cost: Estimate | None = None  # expected extraction time, under a budget


@dataclass
class Parameters:
    """The stage's output: the candidates that kept a Θ′, in C(E)'s order, and what was cut on the way."""

    candidates: dict[str, Candidate]
    shaped_out: dict[str, tuple[Citation, ...]] = field(default_factory=dict)  # pruned by a context shape
    budget: BudgetOutcome | None = None


def parameters(
    vocab: Vocabulary,
    table: RuleTable,
    decision: Decision,
    values: Mapping[str, str | None],
    budget: Budget | None,
    neural: NeuralStep,
    pixels: int | None,
    sources: Sequence[ThetaSource] = THETA_SOURCES,
) -> Parameters:
    """Θ′ per candidate of ``decision`` (module docstring)."""
    inputs = ThetaInputs(decision, table.measured(values), ", ".join(f"{d} = {v}" for d, v in values.items() if v is not None),
                         table.cost, budget, neural, pixels)
    out = Parameters({})

    def admit(x: str) -> bool:
        spec = vocab.extractor(x)
        proposal = next(p for s in sources if (p := s.propose(spec, inputs)) is not None)
        shaped = enforce(spec, proposal.params, decision.shapes)
        if shaped.pruned:
            out.shaped_out[x] = shaped.pruned
            return False
        out.candidates[x] = Candidate(x, shaped.params, (*proposal.adjustments, *shaped.adjustments), proposal)
        return True

    for x in decision.candidates:
        admit(x)
    if budget is None:
        return out
    terms = table.budget_terms
    # what a relative-accuracy rule pruned is re-judged against the best *affordable* extractor
    relative = [x for x, cs in decision.pruned.items() if cs and all(c.rule in terms.relative_rules for c in cs)]
    relative = [x for x in relative if admit(x)]
    ates = {x: e.ate for x, e in decision.evidence.items() if e.ate}
    theta = {x: c.params for x, c in out.candidates.items()}
    outcome = settle(table.cost, terms, vocab.extractors, ates, theta, relative, budget)
    out.budget = outcome
    out.candidates = {
        x: replace(c, params=outcome.params[x], adjustments=(*c.adjustments, *outcome.adjustments.get(x, ())),
                   cost=outcome.estimates.get(x))
        for x, c in out.candidates.items() if x in outcome.params
    }
    return out
