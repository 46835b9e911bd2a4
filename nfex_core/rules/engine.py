"""The compiled rule engine: per graph version, one lookup table from context to decision.

The condition space is finite — each dimension takes one of its values or is unknown — so the engine
evaluates every SPARQL pruning rule once for all contexts (one query per rule, see pruning.py) and
every DSL statement and context shape (shapes.py) for all contexts, and stores a ``Decision`` per context: the candidates, the pruned
extractors with the rules that pruned them, the parameter factors f_kj, the metric weights h_x, the
preference bonuses, the context shapes in force (``require`` statements are compiled to them), and the measured evidence per extractor. A
request then pays one dictionary lookup. The measured configurations of each extractor under a context
(``RuleTable.measured``: the graph's answer to "which Θ of α had the lowest mean ATE here?") are ranked
on a context's first request and kept. ``compile_table`` runs again when the graph version changes.
The same step fits the cost model (nfex_core/cost.py) and reads the budget terms, so a request's
budget check (advisor/budget.py) costs arithmetic only.

Composition (paper §IV-A): several ``adjust`` statements on one parameter multiply
(w_k = Π_j f_kj(e_j)); several ``weight`` statements on one metric multiply (h_x(E), default 1);
``prefer`` bonuses add.
"""
from __future__ import annotations

import itertools
import logging
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from rdflib.term import URIRef

from ..cost import BudgetTerms, CostModel, fit_cost_model, measured_settings
from ..errors import NfexError
from ..kg.terms import py
from ..kg.vocab import ExtractorSpec, Value
from . import pruning
from .shapes import load_context_shapes
from .statements import CompiledStatement, load_statements
from .types import Citation, ContextKey, Decision, Evidence, Factor, MeasuredConfiguration

if TYPE_CHECKING:
    from ..kg.store import KnowledgeGraph

log = logging.getLogger("nfex.rules")


@dataclass(frozen=True)
class _Measured:
    """One Measurement as the engine reads it (once per graph version, ``_measurements``)."""

    extractor: str
    configuration: str
    conditions: frozenset[tuple[str, str]]  # (dimension, value) of every condition the measurement was under
    ate: float | None  # None: the window failed
    extraction_ms: float | None


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
    # extractor → configuration IRI → (its full Θ, its measurements); see ``measured``
    configurations: dict[str, dict[str, tuple[dict[str, Value], list[_Measured]]]] = field(default_factory=dict)
    min_measurements: int = 3
    _measured: dict[ContextKey, dict[str, tuple[MeasuredConfiguration, ...]]] = field(default_factory=dict, repr=False)

    def key(self, context: Mapping[str, str | None]) -> ContextKey:
        return tuple(context.get(d) for d in self.dimensions)

    def decide(self, context: Mapping[str, str | None]) -> Decision:
        """The decision for a context (values must be checked against the vocabulary beforehand)."""
        return self.decisions[self.key(context)]

    def measured(self, context: Mapping[str, str | None]) -> dict[str, tuple[MeasuredConfiguration, ...]]:
        """Per extractor, its measured configurations under ``context``, lowest mean ATE first.

        A measurement counts when it shares at least one of the context's known condition values and
        contradicts none (a window measured under light = dark says nothing about a bright frame). A
        configuration is listed when at least ``nfex:minMeasurements`` measurements count and none of
        them failed (a configuration that lost a window here is not a candidate for the best one)."""
        key = self.key(context)
        found = self._measured.get(key)
        if found is not None:
            return found
        known = {d: v for d, v in zip(self.dimensions, key, strict=True) if v is not None}
        found = {}
        for x, configurations in self.configurations.items():
            ranked = []
            for iri, (params, measurements) in configurations.items():
                ates: list[float | None] = [
                    m.ate for m in measurements
                    if any(known.get(d) == v for d, v in m.conditions) and all(known.get(d, v) == v for d, v in m.conditions)
                ]
                if len(ates) < self.min_measurements or any(a is None for a in ates):
                    continue
                ranked.append(MeasuredConfiguration(iri, params, sum(ates) / len(ates), len(ates)))  # type: ignore[arg-type]
            if ranked:
                found[x] = tuple(sorted(ranked, key=lambda c: (c.mean_ate, c.iri)))
        self._measured[key] = found
        return found


def _measurements(kg: KnowledgeGraph) -> list[_Measured]:
    """Every Measurement: extractor, configuration, conditions, ATE (absent: failed), extraction ms."""
    per: dict[str, tuple[str, str, set[tuple[str, str]], float | None, float | None]] = {}
    for r in kg.select(
        """SELECT ?xname ?cfg ?m ?dim ?val ?ate ?ms WHERE {
            ?m a nfex:Measurement ; sosa:usedProcedure ?cfg .
            ?cfg nfex:ofExtractor/nfex:token ?xname .
            OPTIONAL { ?m nfex:underCondition ?c . ?c nfex:token ?val ; nfex:inDimension/nfex:token ?dim . }
            OPTIONAL { ?m nfex:ateRmse ?ate } OPTIONAL { ?m nfex:extractionMs ?ms }
        }"""
    ).rows:
        entry = per.setdefault(str(r["m"]), (
            str(r["xname"]), str(r["cfg"]), set(),
            float(py(r["ate"])) if "ate" in r else None, float(py(r["ms"])) if "ms" in r else None,
        ))
        if "dim" in r:
            entry[2].add((str(r["dim"]), str(r["val"])))
    return [_Measured(x, cfg, frozenset(conds), ate, ms) for x, cfg, conds, ate, ms in per.values()]


def _evidence(measurements: list[_Measured]) -> dict[tuple[str, str, str], tuple[float | None, int, float | None]]:
    """(extractor, dimension, value) → (mean ATE, windows, mean extraction ms) over the measurements under
    that value; the means over those that have one (a failed window has no ATE)."""
    sums: dict[tuple[str, str, str], list[float]] = {}
    for m in measurements:
        for d, v in m.conditions:
            acc = sums.setdefault((m.extractor, d, v), [0, 0.0, 0, 0.0, 0])
            acc[0] += 1
            if m.ate is not None:
                acc[1] += m.ate
                acc[2] += 1
            if m.extraction_ms is not None:
                acc[3] += m.extraction_ms
                acc[4] += 1
    return {k: (a[1] / a[2] if a[2] else None, int(a[0]), a[3] / a[4] if a[4] else None) for k, a in sums.items()}


def _configurations(
    measurements: list[_Measured], settings: Mapping[str, Mapping[str, Value]], extractors: Mapping[str, ExtractorSpec]
) -> dict[str, dict[str, tuple[dict[str, Value], list[_Measured]]]]:
    """Per extractor and configuration: its full Θ (resolved against the graph's ranges once, here) and
    its measurements. A configuration the current ranges no longer allow is left out."""
    out: dict[str, dict[str, tuple[dict[str, Value], list[_Measured]]]] = {}
    invalid: set[str] = set()
    for m in measurements:
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


def _combine(items: list[tuple[float | None, int, float | None]]) -> Evidence:
    n = sum(w for _, w, _ in items)
    ates = [(m, w) for m, w, _ in items if m is not None]
    costs = [(c, w) for _, w, c in items if c is not None]
    mean = sum(m * w for m, w in ates) / sum(w for _, w in ates) if ates else None
    cost = sum(c * w for c, w in costs) / sum(w for _, w in costs) if costs else None
    return Evidence(mean, n, cost)


def compile_table(kg: KnowledgeGraph) -> RuleTable:
    """Evaluate every rule and statement for every context of the graph's condition space."""
    t0 = time.perf_counter()
    version = kg.version
    vocab = kg.vocabulary()
    dims = tuple(vocab.dimensions)
    keys: list[ContextKey] = list(itertools.product(*[[*vocab.dimensions[d].values, None] for d in dims]))
    iris = [[vocab.dimensions[d].values[v].iri if v is not None else None for d, v in zip(dims, key, strict=True)] for key in keys]

    errors: list[str] = []
    rules = pruning.load_rules(kg)
    pruned_by_rules: dict[int, list[tuple[str, Citation]]] = {}
    for rule in rules:
        try:
            hits = pruning.evaluate(kg, rule, dims, iris)
        except Exception as e:  # a broken rule must not take selection down; it is reported
            errors.append(f"{rule.iri}: {e}")
            log.warning("pruning rule %s failed: %s", rule.iri, e)
            continue
        for i, found in hits.items():
            for x, reason in found:
                spec = vocab.by_iri.get(URIRef(x))
                if spec is not None:
                    pruned_by_rules.setdefault(i, []).append((spec.name, Citation(str(rule.iri), rule.label, reason, "sparql", rule.source)))

    statements = load_statements(kg, vocab)
    shapes, shape_errors = load_context_shapes(kg, vocab, statements)
    errors += shape_errors
    measurements = _measurements(kg)
    evidence = _evidence(measurements)
    decisions: dict[ContextKey, Decision] = {}
    for i, key in enumerate(keys):
        context = dict(zip(dims, key, strict=True))
        pruned: dict[str, list[Citation]] = {}
        for name, cite in pruned_by_rules.get(i, []):
            pruned.setdefault(name, []).append(cite)
        factors: dict[str, dict[str, Factor]] = {}
        weights: dict[str, Factor] = {m: Factor(1.0) for m in vocab.metrics}
        bonuses: dict[str, Factor] = {}
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
        in_force = tuple(sh for sh in shapes if sh.applies(context))
        for sh in in_force:  # a prohibition prunes here; bounds are checked per candidate Θ′
            if sh.bound is None:
                for x in vocab.extractors:
                    if sh.concerns(x):
                        pruned.setdefault(x, []).append(sh.citation)
        known = [(d, v) for d, v in context.items() if v is not None]
        ev = {
            x: _combine([evidence[(x, d, v)] for d, v in known if (x, d, v) in evidence])
            for x in vocab.extractors
        }
        decisions[key] = Decision(
            context=context,
            candidates=tuple(x for x in vocab.extractors if x not in pruned),
            pruned={x: tuple(c) for x, c in pruned.items()},
            factors=factors,
            weights=weights,
            bonuses=bonuses,
            evidence={x: e for x, e in ev.items() if e.windows},
            shapes=in_force,
        )
    settings = measured_settings(kg)
    cost = fit_cost_model(kg, vocab.extractors, settings)
    budget_terms = BudgetTerms.load(kg)
    configurations = _configurations(measurements, settings, vocab.extractors) if _measured_rule_enabled(kg) else {}
    least = _min_measurements(kg)
    ms = (time.perf_counter() - t0) * 1000
    log.info("compiled %d contexts, %d rules, %d statements at graph version %d in %.0f ms", len(keys), len(rules), len(statements), version, ms)
    return RuleTable(version, dims, decisions, rules, statements, errors, ms, cost, budget_terms,
                     configurations, least)


class RuleEngine:
    """The compiled table for the graph's current version, rebuilt when a commit moves the version."""

    def __init__(self, kg: KnowledgeGraph) -> None:
        self.kg = kg

    def table(self) -> RuleTable:
        return self.kg.cached("rule-table", lambda: compile_table(self.kg))
