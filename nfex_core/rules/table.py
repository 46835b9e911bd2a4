"""The compiled rule table: what a request reads, per graph version, once published; and apart from it, the state
the next compile carries (``CompileState``), which no request reads.

``RuleTable.decide`` is one dictionary lookup from a context to its Decision (rules/engine.py compiles the table:
its module docstring has the composition and what a compile carries); ``RuleTable.measured`` ranks the measured
configurations of each extractor under a context. What a context's first request derives (the decision's evidence,
the rankings) is computed apart and published into the table's ``ContextMemo`` (rules/memo.py), never into the
fields a request reads: those do not change once the table is published. ``CompileState``
holds the observations read, their grouping and what was made of each group, the rules' evidence view and hits,
the decisions before evidence and the configuration stage: ``compile_table`` of the next version takes them over
where the change since cannot have touched them (docs/architecture.md).
"""
from __future__ import annotations

import logging
import threading
from collections.abc import Callable, Hashable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any, TypeVar

from nfex_slam.motion import StepChecks

from ..errors import NfexError
from ..evidence import Admission, Aggregate, Observation, robust
from ..evidence.cost import BudgetTerms, CostModel
from ..evidence.groups import Grouped
from ..evidence.index import ObservationIndex
from ..evidence.view import EvidenceView
from ..kg.vocabulary.vocab import ExtractorSpec, Value
from . import pruning
from .memo import ContextMemo
from .setup import Setup
from .statements import CompiledStatement
from .types import Citation, ContextKey, Decision, Evidence, MeasuredConfiguration

log = logging.getLogger("nfex.rules")
V = TypeVar("V")
_TAKE = threading.Lock()  # CompileState.take_view


@dataclass
class CompileState:
    """What one compile leaves for the next (engine.compile_table's ``previous``); no request reads it. Its own
    object: the table a request reads does not change when the next compile takes the view (``take_view``)."""

    setup: Setup  # the configuration stage
    index: ObservationIndex  # the observations read
    view: EvidenceView | None  # the rules' view of the evidence (None once taken)
    # per (rule, its contextualised query): the contexts it prunes in, with the extractors and citations
    hits: dict[tuple[pruning.SparqlRule, str], dict[int, list[tuple[str, Citation]]]]
    ruled: dict[int, tuple[tuple[str, Citation], ...]]  # rule prunes per context
    plain: dict[ContextKey, Decision]  # decisions before evidence (``RuleTable.decide``)
    # the admitted observations grouped (evidence/groups.py), and what was made of each group
    grouped: Grouped
    summary_lines: dict[Any, tuple[str, ...]] = field(default_factory=dict)
    cost_groups: dict[Any, Aggregate] = field(default_factory=dict)
    measured_groups: dict[Any, Any] = field(default_factory=dict)

    def take_view(self) -> EvidenceView | None:
        """The evidence view, handed to one next compile only (which changes it in place)."""
        with _TAKE:
            view, self.view = self.view, None
        return view


@dataclass
class RuleTable:
    version: int
    dimensions: tuple[str, ...]
    decisions: dict[ContextKey, Decision]
    rules: list[pruning.SparqlRule]
    statements: list[CompiledStatement]
    errors: list[str]
    compile_ms: float
    cost: CostModel = field(default_factory=CostModel)
    budget_terms: BudgetTerms = field(default_factory=BudgetTerms)
    # extractor → configuration IRI → (its full Θ, its admitted observations); see ``measured``
    configurations: dict[str, dict[str, tuple[dict[str, Value], Sequence[Observation]]]] = field(default_factory=dict)
    min_measurements: int = 3
    # extractor → condition set → admitted observations (the evidence per context, ``decide``)
    observed: dict[str, dict[frozenset[tuple[str, str]], Sequence[Observation]]] = field(default_factory=dict)
    admission: Admission = field(default_factory=Admission)
    step_checks: dict[str, StepChecks] = field(default_factory=dict)  # agent → front-end checks (motion.py)
    carry: CompileState | None = field(default=None, repr=False, compare=False)  # for the next compile only
    kept_in: str | None = field(default=None, repr=False, compare=False)  # the file it was read from (persisted.py), not compiled here
    # what requests derived per context (``decide``'s evidence, ``measured``'s rankings, what was made of each group);
    # ``made_before`` is the last table's, from which what the same groups give is taken (``_made``)
    memo: ContextMemo = field(default_factory=ContextMemo, repr=False, compare=False)
    made_before: ContextMemo | None = field(default=None, repr=False, compare=False)

    def _made(self, key: tuple[Hashable, ...], source: object, make: Callable[[], V], fresh: dict[Hashable, Any]) -> V:
        """``make()``, or what this table or the last one made of the same ``source`` (the very object: a group a
        compile carried untouched, engine._per_group) under the same ``key``. Selections after each report then cost
        what the report changed, not a pass over every measured configuration. What is made goes into ``fresh``,
        which the caller publishes once (``ContextMemo.publish``)."""
        hit = self.memo.made.get(key)
        if hit is None and self.made_before is not None:
            hit = self.made_before.made.get(key)
        value: V = hit[1] if hit is not None and hit[0] is source else make()
        fresh[key] = (source, value)
        return value

    def key(self, context: Mapping[str, str | None]) -> ContextKey:
        return tuple(context.get(d) for d in self.dimensions)

    def decide(self, context: Mapping[str, str | None]) -> Decision:
        """The decision for a context (values must be checked against the vocabulary beforehand), with its evidence:
        aggregated on the context's first request into the memo, never into ``decisions``."""
        key = self.key(context)
        hit = self.memo.decided.get(key)
        if hit is not None:
            return hit
        known = {d: v for d, v in zip(self.dimensions, key, strict=True) if v is not None}
        fresh: dict[Hashable, Any] = {}
        decision = replace(self.decisions[key], evidence=self._evidence(key, known, fresh))
        return self.memo.publish(self.memo.decided, key, decision, fresh)

    def _evidence(self, key: ContextKey, known: dict[str, str], fresh: dict[Hashable, Any]) -> dict[str, Evidence]:
        out: dict[str, Evidence] = {}
        if not known:
            return out
        for x, groups in self.observed.items():
            found = self._made((key, x), groups, lambda groups=groups: _evidence(groups, known), fresh)  # type: ignore[misc]
            if found is not None:
                out[x] = found
        return out

    def measured(self, context: Mapping[str, str | None]) -> dict[str, tuple[MeasuredConfiguration, ...]]:
        """Per extractor, its measured configurations under ``context``, lowest median ATE first.

        A measurement counts when it is admitted (evidence/trust.py), shares at least one of the
        context's known condition values and contradicts none. A configuration is listed when at least
        ``nfex:minMeasurements`` counting windows have an ATE and none of them failed (a configuration
        that lost a window here is not a candidate for the best one)."""
        key = self.key(context)
        hit = self.memo.measured.get(key)
        if hit is not None:
            return hit
        known = {d: v for d, v in zip(self.dimensions, key, strict=True) if v is not None}
        found: dict[str, tuple[MeasuredConfiguration, ...]] = {}
        fresh: dict[Hashable, Any] = {}
        for x, configurations in self.configurations.items():
            ranked = []
            for iri, found_here in configurations.items():
                params, observations = found_here
                one = self._made((key, x, iri), found_here,
                                 lambda iri=iri, p=params, obs=observations: _ranked(iri, p, obs, known, self.min_measurements),  # type: ignore[misc]
                                 fresh)
                if one is not None:
                    ranked.append(one)
            if ranked:
                found[x] = tuple(sorted(ranked, key=lambda c: (c.ate, c.iri)))
        return self.memo.publish(self.memo.measured, key, found, fresh)


def _evidence(groups: Mapping[frozenset[tuple[str, str]], Sequence[Observation]], known: dict[str, str]) -> Evidence | None:
    """An extractor's evidence under the ``known`` values, from its observations grouped by condition set."""
    counted = [o for obs in groups.values() if obs[0].counts_under(known) for o in obs]
    if not counted:
        return None
    ates = [o.ate for o in counted if o.ate is not None]
    costs = [o.extraction_ms for o in counted if o.extraction_ms is not None]
    agg = robust(ates) if ates else None
    return Evidence(agg.value if agg else None, len(counted), robust(costs).value if costs else None,
                    agg.outliers if agg else 0, tuple(sorted({o.source for o in counted})))


def _counting(observations: Sequence[Observation], known: dict[str, str]) -> list[Observation]:
    """The observations that count under the ``known`` values (``Observation.counts_under``), asked once per
    condition set: a configuration's windows share a few."""
    verdicts: dict[frozenset[tuple[str, str]], bool] = {}
    out = []
    for o in observations:
        verdict = verdicts.get(o.conditions)
        if verdict is None:
            verdict = verdicts[o.conditions] = o.counts_under(known)
        if verdict:
            out.append(o)
    return out


def _ranked(iri: str, params: dict[str, Value], observations: Sequence[Observation], known: dict[str, str],
            min_measurements: int) -> MeasuredConfiguration | None:
    """A measured configuration under the ``known`` values, or None where it is not listed (``RuleTable.measured``)."""
    counted = _counting(observations, known)
    ates = [o.ate for o in counted if o.ate is not None]
    if len(ates) < min_measurements or any(o.failed for o in counted):
        return None
    agg = robust(ates, (o.source for o in counted))
    return MeasuredConfiguration(iri, params, agg.value, agg.windows, agg.outliers, agg.sources)


def _measured_configuration(key: tuple[str, str], observations: tuple[Observation, ...], settings: Mapping[str, Mapping[str, Value]],
                            extractors: Mapping[str, ExtractorSpec]) -> tuple[dict[str, Value], tuple[Observation, ...]] | None:
    """A measured configuration's full Θ (resolved against the graph's ranges once, here) and its admitted
    observations; None for an extractor the graph does not have or a Θ its ranges no longer allow."""
    x, cfg = key
    spec = extractors.get(x)
    if spec is None:
        return None
    try:
        return spec.resolve(settings.get(cfg, {})), observations
    except NfexError as e:
        log.warning("measured configuration %s left out: %s", cfg, e)
        return None
