"""The flow's ``params`` stage: Θ′ for every candidate of C(E).

Θ′ comes from a declared chain of sources, tried in order; the first that has something to say sets it:

1. ``measured`` — the configuration of α with the lowest mean ATE measured under E, where the graph holds
   enough windows (``advisor.measured``; under a budget the best that fits);
2. ``paramnet`` — ParamNet(E, s), where the network is in use and learned α's parameters (``neural.serve``);
3. ``rules``   — the paper's g(Θ, E) = Θ·Π_j f_kj(e_j) (``fitness.adjust_params``); always answers.

Then the context shapes in force repair Θ′ (clamp a violated bound) or prune α (``rules.shape_check``).
Under a budget, the candidates a relative-accuracy rule pruned get a Θ′ too: the next stage, ``budget``
(``advisor.budget.settle``), fits or prunes every candidate and re-judges those. A new source of Θ′ is a
class with ``name`` and ``propose`` added to ``THETA_SOURCES`` at its place in the order.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Protocol

from ..evidence.cost import CostModel, Estimate
from ..kg.vocab import ExtractorSpec, Value, Vocabulary
from ..neural.serve import NeuralStep
from ..rules.fitness import adjust_params
from ..rules.shape_check import enforce
from ..rules.table import RuleTable
from ..rules.types import Adjustment, Citation, Decision, MeasuredConfiguration
from .budget import Budget
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


@dataclass(frozen=True)
class Parameters:
    """The stage's output: the candidates that kept a Θ′, in C(E)'s order, and what was cut on the way; under a
    budget, the candidates a relative-accuracy rule pruned, with their Θ′, for the budget stage to re-judge."""

    candidates: Mapping[str, Candidate]
    shaped_out: Mapping[str, tuple[Citation, ...]] = field(default_factory=dict)  # pruned by a context shape
    relative: Mapping[str, Candidate] = field(default_factory=dict)


def theta(
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
    candidates: dict[str, Candidate] = {}
    shaped_out: dict[str, tuple[Citation, ...]] = {}

    def admit(x: str, into: dict[str, Candidate]) -> None:
        spec = vocab.extractor(x)
        proposal = next(p for s in sources if (p := s.propose(spec, inputs)) is not None)
        shaped = enforce(spec, proposal.params, decision.shapes)
        if shaped.pruned:
            shaped_out[x] = shaped.pruned
            return
        into[x] = Candidate(x, shaped.params, (*proposal.adjustments, *shaped.adjustments), proposal)

    for x in decision.candidates:
        admit(x, candidates)
    relative: dict[str, Candidate] = {}
    if budget is not None:  # what a relative-accuracy rule pruned is re-judged against the best *affordable* extractor
        rules = table.budget_terms.relative_rules
        for x, cs in decision.pruned.items():
            if cs and all(c.rule in rules for c in cs):
                admit(x, relative)
    return Parameters(candidates, shaped_out, relative)
