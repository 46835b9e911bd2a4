"""The compiled rule engine: per graph version, one lookup table from context to decision.

The condition space is finite — each dimension takes one of its values or is unknown — so the engine
evaluates every SPARQL pruning rule once for all contexts (one query per rule, see pruning.py) and
every DSL statement and context shape (shapes.py) for all contexts, and stores a ``Decision`` per context: the candidates, the pruned
extractors with the rules that pruned them, the parameter factors f_kj, the metric weights h_x, the
preference bonuses, the context shapes in force (``require`` statements are compiled to them), and the measured evidence per extractor. A
request then pays one dictionary lookup. Measurements are read once per compile (evidence/observations.py)
and only those the trust rule admits count (evidence/trust.py): the SPARQL rules run on the evidence view
(evidence/view.py), the evidence per extractor, the measured configurations and the cost model use the
admitted observations, each aggregated with the median (evidence/aggregate.py). The measured configurations of each extractor under a context
(``RuleTable.measured``: the graph's answer to "which Θ of α had the lowest median ATE here?") are ranked
on a context's first request and kept. ``compile_table`` runs again when the graph version changes.
The same step fits the cost model (nfex_core/cost.py) and reads the budget terms, so a request's
budget check (advisor/budget.py) costs arithmetic only.

Composition (paper §IV-A): several ``adjust`` statements on one parameter multiply
(w_k = Π_j f_kj(e_j)); several ``weight`` statements on one metric multiply (h_x(E), default 1);
``prefer`` bonuses add.
"""
from __future__ import annotations

import functools
import itertools
import logging
import threading
import time
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

from nfex_slam.motion import StepChecks
from rdflib.term import URIRef

from ..cost import BudgetTerms, CostModel, fit_cost_model
from ..errors import NfexError
from ..evidence import Admission, Observation, TrustPolicy, admit, robust
from ..evidence.index import ObservationIndex
from ..evidence.view import EvidenceView, evidence_view
from ..kg.terms import py
from ..kg.vocab import ExtractorSpec, Value
from ..motion import load_step_checks
from . import pruning
from .shapes import load_context_shapes
from .statements import CompiledStatement, load_statements
from .types import (
    DEFAULT_ESCALATIONS,
    AcceptRule,
    Citation,
    ContextKey,
    Decision,
    Evidence,
    Factor,
    MeasuredConfiguration,
    PairTest,
    Policy,
)

if TYPE_CHECKING:
    from ..kg.store import KnowledgeGraph

log = logging.getLogger("nfex.rules")
_TAKE = threading.Lock()  # RuleTable.take_view



def _citation(s: CompiledStatement) -> Citation:
    return Citation(str(s.iri), s.label, s.reason, s.kind, s.source)


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
    configurations: dict[str, dict[str, tuple[dict[str, Value], list[Observation]]]] = field(default_factory=dict)
    min_measurements: int = 3
    # extractor → condition set → admitted observations (the evidence per context, ``decide``)
    observed: dict[str, dict[frozenset[tuple[str, str]], list[Observation]]] = field(default_factory=dict)
    admission: Admission = field(default_factory=Admission)
    step_checks: dict[str, StepChecks] = field(default_factory=dict)  # agent → front-end checks (motion.py)
    index: ObservationIndex | None = field(default=None, repr=False)  # the observations read, for the next compile
    view: EvidenceView | None = field(default=None, repr=False, compare=False)  # the rules' view, for the next compile
    _measured: dict[ContextKey, dict[str, tuple[MeasuredConfiguration, ...]]] = field(default_factory=dict, repr=False)
    _evidenced: set[ContextKey] = field(default_factory=set, repr=False)

    def key(self, context: Mapping[str, str | None]) -> ContextKey:
        return tuple(context.get(d) for d in self.dimensions)

    def take_view(self) -> EvidenceView | None:
        """The evidence view, handed to one next compile only (which changes it in place)."""
        with _TAKE:
            view, self.view = self.view, None
        return view

    def decide(self, context: Mapping[str, str | None]) -> Decision:
        """The decision for a context (values must be checked against the vocabulary beforehand); its
        evidence is aggregated on the context's first request and kept."""
        key = self.key(context)
        decision = self.decisions[key]
        if key not in self._evidenced:
            known = {d: v for d, v in zip(self.dimensions, key, strict=True) if v is not None}
            decision = replace(decision, evidence=self._evidence(known))
            self.decisions[key] = decision
            self._evidenced.add(key)
        return decision

    def _evidence(self, known: dict[str, str]) -> dict[str, Evidence]:
        out: dict[str, Evidence] = {}
        if not known:
            return out
        for x, groups in self.observed.items():
            counted = [o for obs in groups.values() if obs[0].counts_under(known) for o in obs]
            if not counted:
                continue
            ates = [o.ate for o in counted if o.ate is not None]
            costs = [o.extraction_ms for o in counted if o.extraction_ms is not None]
            agg = robust(ates) if ates else None
            out[x] = Evidence(agg.value if agg else None, len(counted), robust(costs).value if costs else None,
                              agg.outliers if agg else 0, tuple(sorted({o.source for o in counted})))
        return out

    def measured(self, context: Mapping[str, str | None]) -> dict[str, tuple[MeasuredConfiguration, ...]]:
        """Per extractor, its measured configurations under ``context``, lowest median ATE first.

        A measurement counts when it is admitted (evidence/trust.py), shares at least one of the
        context's known condition values and contradicts none. A configuration is listed when at least
        ``nfex:minMeasurements`` counting windows have an ATE and none of them failed (a configuration
        that lost a window here is not a candidate for the best one)."""
        key = self.key(context)
        found = self._measured.get(key)
        if found is not None:
            return found
        known = {d: v for d, v in zip(self.dimensions, key, strict=True) if v is not None}
        found = {}
        for x, configurations in self.configurations.items():
            ranked = []
            for iri, (params, observations) in configurations.items():
                counted = [o for o in observations if o.counts_under(known)]
                ates = [o.ate for o in counted if o.ate is not None]
                if len(ates) < self.min_measurements or any(o.failed for o in counted):
                    continue
                agg = robust(ates, (o.source for o in counted))
                ranked.append(MeasuredConfiguration(iri, params, agg.value, agg.windows, agg.outliers, agg.sources))
            if ranked:
                found[x] = tuple(sorted(ranked, key=lambda c: (c.ate, c.iri)))
        self._measured[key] = found
        return found


def _configurations(
    observations: list[Observation], settings: Mapping[str, Mapping[str, Value]], extractors: Mapping[str, ExtractorSpec]
) -> dict[str, dict[str, tuple[dict[str, Value], list[Observation]]]]:
    """Per extractor and configuration: its full Θ (resolved against the graph's ranges once, here) and
    its observations. A configuration the current ranges no longer allow is left out."""
    out: dict[str, dict[str, tuple[dict[str, Value], list[Observation]]]] = {}
    invalid: set[str] = set()
    for m in observations:
        spec = extractors.get(m.extractor)
        if spec is None or m.configuration in invalid:
            continue
        entry = out.get(m.extractor, {}).get(m.configuration)
        if entry is None:
            try:
                theta = spec.resolve(settings.get(m.configuration, {}))
            except NfexError as e:
                log.warning("measured configuration %s left out: %s", m.configuration, e)
                invalid.add(m.configuration)
                continue
            entry = out.setdefault(m.extractor, {})[m.configuration] = (theta, [])
        entry[1].append(m)
    return out


def _measured_rule_enabled(kg: KnowledgeGraph) -> bool:
    rows = kg.select("SELECT ?e WHERE { nfex:rule_measured_configuration nfex:enabled ?e }").rows
    return not any(py(r["e"]) is False for r in rows)


def _min_measurements(kg: KnowledgeGraph) -> int:
    rows = kg.select("SELECT ?n WHERE { nfex:minMeasurements nfex:value ?n }").rows
    return int(py(rows[0]["n"])) if rows else 3


def compile_table(kg: KnowledgeGraph, previous: RuleTable | None = None) -> RuleTable:
    """Evaluate every rule and statement for every context of the graph's condition space. ``previous``: the
    table of an earlier version, whose observations are carried forward (evidence/index.py: only what the
    change since then can have touched is read again)."""
    t0 = time.perf_counter()
    version = kg.version
    vocab = kg.vocabulary()
    dims = tuple(vocab.dimensions)
    keys: list[ContextKey] = list(itertools.product(*[[*vocab.dimensions[d].values, None] for d in dims]))
    iris = [[vocab.dimensions[d].values[v].iri if v is not None else None for d, v in zip(dims, key, strict=True)] for key in keys]

    errors: list[str] = []
    rules = pruning.load_rules(kg)
    diff = functools.cache(kg.diff)  # the observation index and the evidence view read the same change once
    index = previous.index.advance(kg, diff) if previous is not None and previous.index is not None else ObservationIndex.read(kg)
    observations = index.all()
    admission = admit(observations, TrustPolicy.load(kg))
    evidence = admission.select(observations)
    value_iris = {(d, v): str(spec.iri) for d in dims for v, spec in vocab.dimensions[d].values.items()}
    extractor_iris = {x: str(e.iri) for x, e in vocab.extractors.items()}
    carried = previous.take_view() if previous is not None and rules else None
    made: EvidenceView | None = None
    if rules:
        made = carried.advance(kg, admission, evidence, extractor_iris, value_iris, diff) if carried is not None \
            else evidence_view(kg, admission, evidence, extractor_iris, value_iris)
    view = made.backend if made is not None else kg.backend
    pruned_by_rules: dict[int, list[tuple[str, Citation]]] = {}
    for rule in rules:
        try:
            hits = pruning.evaluate(view, rule, dims, iris)
        except Exception as e:  # a broken rule must not take selection down; it is reported
            errors.append(f"{rule.iri}: {e}")
            log.warning("pruning rule %s failed: %s", rule.iri, e)
            continue
        for i, found in hits.items():
            for x, reason in found:
                spec = vocab.by_iri.get(URIRef(x))
                if isinstance(spec, ExtractorSpec):
                    pruned_by_rules.setdefault(i, []).append((spec.name, Citation(str(rule.iri), rule.label, reason, "sparql", rule.source)))

    statements = load_statements(kg, vocab)
    shapes, shape_errors = load_context_shapes(kg, vocab, statements)
    errors += shape_errors
    absent = backend_citations(kg, vocab.extractors)
    decisions: dict[ContextKey, Decision] = {}
    for i, key in enumerate(keys):
        context = dict(zip(dims, key, strict=True))
        pruned: dict[str, list[Citation]] = {x: [cite] for x, cite in absent.items()}
        for name, cite in pruned_by_rules.get(i, []):
            pruned.setdefault(name, []).append(cite)
        factors: dict[str, dict[str, Factor]] = {}
        weights: dict[str, Factor] = {m: Factor(1.0) for m in vocab.metrics}
        bonuses: dict[str, Factor] = {}
        accept: list[AcceptRule] = []
        escalation: tuple[int, Citation] | None = None
        for s in statements:
            if not s.applies(context):
                continue
            cite = _citation(s)
            if s.kind == "prune" and s.extractor:
                pruned.setdefault(s.extractor, []).append(cite)
            elif s.kind == "adjust" and s.extractor and s.parameter and s.value is not None:
                old = factors.setdefault(s.extractor, {}).get(s.parameter, Factor(1.0))
                factors[s.extractor][s.parameter] = Factor(old.value * float(s.value), old.citations + (cite,))
            elif s.kind == "weight" and s.metric and s.value is not None:
                old = weights[s.metric]
                weights[s.metric] = Factor(old.value * float(s.value), old.citations + (cite,))
            elif s.kind == "prefer" and s.extractor and s.value is not None:
                old = bonuses.get(s.extractor, Factor(0.0))
                bonuses[s.extractor] = Factor(old.value + float(s.value), old.citations + (cite,))
            elif s.kind == "accept" and s.tests:
                accept.append(AcceptRule(tuple(PairTest(*t) for t in s.tests), s.atoms, cite))
            elif s.kind == "escalate" and s.value is not None and (escalation is None or int(s.value) < escalation[0]):
                escalation = (int(s.value), cite)  # the strictest in force
        in_force = tuple(sh for sh in shapes if sh.applies(context))
        for sh in in_force:  # a prohibition prunes here; bounds are checked per candidate Θ′
            if sh.bound is None:
                for name in vocab.extractors:
                    if sh.concerns(name):
                        pruned.setdefault(name, []).append(sh.citation)
        decisions[key] = Decision(
            context=context,
            candidates=tuple(x for x in vocab.extractors if x not in pruned),
            pruned={x: tuple(c) for x, c in pruned.items()},
            factors=factors,
            weights=weights,
            bonuses=bonuses,
            shapes=in_force,
            verification=Policy(tuple(accept), *(escalation or (DEFAULT_ESCALATIONS, None))),
        )
    settings = index.measured_settings()
    cost = fit_cost_model(kg, vocab.extractors, settings, evidence)
    budget_terms = BudgetTerms.load(kg)
    step_checks = load_step_checks(kg)
    configurations = _configurations(evidence, settings, vocab.extractors) if _measured_rule_enabled(kg) else {}
    observed: dict[str, dict[frozenset[tuple[str, str]], list[Observation]]] = {}
    for o in evidence:
        observed.setdefault(o.extractor, {}).setdefault(o.conditions, []).append(o)
    least = _min_measurements(kg)
    ms = (time.perf_counter() - t0) * 1000
    log.info("compiled %d contexts, %d rules, %d statements at graph version %d in %.0f ms (observations: %s in %.0f ms)",
             len(keys), len(rules), len(statements), version, ms,
             "read in full" if index.reread < 0 else f"{index.reread} re-read", index.ms)
    return RuleTable(version, dims, decisions, rules, statements, errors, ms, cost, budget_terms,
                     configurations, least, observed, admission, step_checks=step_checks, index=index, view=made)


BACKEND_RULE = "https://w3id.org/nfex#rule_backend_available"


def backend_citations(kg: KnowledgeGraph, extractors: Mapping[str, ExtractorSpec]) -> dict[str, Citation]:
    """Extractors whose backend cannot run in this process (a learned model without its extra or weights),
    each with the citation that prunes it in every context: the reason says what to install or set."""
    from ..vision.backends import unavailable  # no heavy import: it checks installed packages and files

    return {x: Citation(BACKEND_RULE, "Extractor backend installed", a.detail, "backend")
            for x, a in unavailable(extractors, kg.settings).items()}


class RuleEngine:
    """The compiled table for the graph's current version, rebuilt when a commit moves the version; each
    rebuild carries the last table's observations forward (compile_table's ``previous``)."""

    def __init__(self, kg: KnowledgeGraph) -> None:
        self.kg = kg
        self._last: RuleTable | None = None

    def table(self) -> RuleTable:
        table = self.kg.cached("rule-table", lambda: compile_table(self.kg, self._last))
        self._last = table
        return table
