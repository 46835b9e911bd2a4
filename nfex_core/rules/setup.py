"""The configuration stage of a compile: what the rule table reads from the graph's configuration, and the
part of every context's decision that follows from it alone.

A compile (engine.py) has two inputs. The graph's *configuration* is the vocabulary, the DSL statements, the
context shapes, the SPARQL rules' text, the budget terms, the front-end checks, the trust policy and the
settings of the measured rule. Its *evidence* is the Measurements with their runs, configurations and
sequences. A ``Setup`` is everything the first determines, per context E:

    pruned(E)  = the extractors whose backend is missing, those a ``prune`` statement or a prohibiting
                 context shape names — each with its citations;
    f_kj(E), h_x(E), bonuses(E), shapes in force, the verification policy — as engine.py composes them.

The SPARQL rules read evidence (evidence/view.py), so their prunes are laid over this per version
(``Setup.decision``); everything else is carried. A feedback report changes evidence only, so a compile
keeps the last version's Setup when the change since then touches evidence nodes only
(``kg.changes.evidence_only``) and reads it again otherwise.
"""
from __future__ import annotations

import itertools
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

from nfex_slam.motion import StepChecks

from ..evidence import TrustPolicy
from ..evidence.cost import BudgetTerms
from ..kg.footprint import Footprint, footprint
from ..kg.terms import py
from ..kg.vocab import Vocabulary
from . import pruning
from .motion import load_step_checks
from .shapes import GraphShapes, load_context_shapes
from .statements import CompiledStatement, load_statements
from .types import (
    DEFAULT_ESCALATIONS,
    AcceptRule,
    Citation,
    CompiledShape,
    ConditionAtom,
    ContextKey,
    Decision,
    Factor,
    PairTest,
    Policy,
)

if TYPE_CHECKING:
    from ..kg.store import KnowledgeGraph


def _citation(s: CompiledStatement) -> Citation:
    return Citation(str(s.iri), s.label, s.reason, s.kind, s.source)


@dataclass(frozen=True)
class Setup:
    """The configuration of graph ``version`` as a compile reads it, and each context's decision before the
    SPARQL rules (``base``, in the order of ``keys``)."""

    version: int
    vocab: Vocabulary
    dimensions: tuple[str, ...]
    keys: tuple[ContextKey, ...]  # every context: each dimension's value or None (unknown)
    value_iris: Mapping[tuple[str, str], str]  # (dimension, value) → the condition value's IRI
    rules: tuple[pruning.SparqlRule, ...]
    queries: tuple[str | Exception, ...]  # each rule contextualised for every context (pruning.contextualise), or why it cannot be
    footprints: tuple[Footprint | None, ...]  # what each rule reads (kg/footprint.py)
    statements: tuple[CompiledStatement, ...]
    shapes: tuple[CompiledShape, ...]
    errors: tuple[str, ...]  # malformed shapes and requires (the rules' errors come with their evaluation)
    absent: Mapping[str, Citation]  # extractors whose backend cannot run here (engine.backend_citations)
    budget_terms: BudgetTerms
    step_checks: Mapping[str, StepChecks]
    policy: TrustPolicy
    min_measurements: int
    measured_rule: bool  # nfex:rule_measured_configuration is enabled
    base: tuple[Decision, ...]  # ``pruned`` holds the statements' and shapes' prunes only
    graph_shapes: GraphShapes  # the shapes graph's context shapes, compiled: kept by the next read where it can

    @classmethod
    def read(cls, kg: KnowledgeGraph, absent: Mapping[str, Citation], previous: Setup | None = None) -> Setup:
        """The configuration at the head; ``previous``: an earlier one, whose rules' contextualised queries and
        footprints are kept where a rule's text and the contexts are the same, and whose compiled context shapes
        are kept for the same shapes graph and vocabulary."""
        version = kg.version
        vocab = kg.vocabulary()
        dims = tuple(vocab.dimensions)
        keys = tuple(itertools.product(*[[*vocab.dimensions[d].values, None] for d in dims]))
        iris = [[*(spec.iri for spec in vocab.dimensions[d].values.values()), None] for d in dims]  # in the order of keys
        rules = tuple(pruning.load_rules(kg))
        value_iris = {(d, v): str(spec.iri) for d in dims for v, spec in vocab.dimensions[d].values.items()}
        known = {r.query: (q, f) for r, q, f in zip(previous.rules, previous.queries, previous.footprints, strict=True)} \
            if previous is not None and previous.dimensions == dims and previous.value_iris == value_iris else {}
        queries: list[str | Exception] = []
        footprints: list[Footprint | None] = []
        for rule in rules:
            if rule.query in known:
                queries.append(known[rule.query][0])
                footprints.append(known[rule.query][1])
                continue
            footprints.append(footprint(rule.query))
            try:
                queries.append(pruning.contextualise(rule.query, dims, iris))
            except Exception as e:  # a broken rule must not take selection down; each compile reports it
                queries.append(e)
        statements = load_statements(kg, vocab)
        g = kg.shapes().graph
        graph_shapes = previous.graph_shapes if previous is not None and previous.graph_shapes.of(g, vocab) \
            else GraphShapes.compile(g, vocab)
        shapes, shape_errors = load_context_shapes(graph_shapes, statements)
        base = _bases(keys, dims, vocab, statements, shapes)
        return cls(version, vocab, dims, keys, value_iris, rules, tuple(queries), tuple(footprints), tuple(statements), tuple(shapes),
                   tuple(shape_errors), dict(absent), BudgetTerms.load(kg), load_step_checks(kg),
                   TrustPolicy.load(kg), _min_measurements(kg), _measured_rule_enabled(kg), base, graph_shapes)

    def decision(self, i: int, ruled: Sequence[tuple[str, Citation]]) -> Decision:
        """Context ``keys[i]``'s decision with the SPARQL rules' prunes ``ruled`` (extractor, citation) laid over
        its base; citations in the order: missing backend, rules, statements, shapes."""
        base = self.base[i]
        pruned: dict[str, list[Citation]] = {x: [cite] for x, cite in self.absent.items()}
        for name, cite in ruled:
            pruned.setdefault(name, []).append(cite)
        for name, cites in base.pruned.items():
            pruned.setdefault(name, []).extend(cites)
        return Decision(
            context=base.context,
            candidates=tuple(x for x in self.vocab.extractors if x not in pruned),
            pruned={x: tuple(c) for x, c in pruned.items()},
            factors=base.factors, weights=base.weights, bonuses=base.bonuses, shapes=base.shapes,
            verification=base.verification,
        )


def _matching(keys: Sequence[ContextKey], dims: Sequence[str], vocab: Vocabulary, atoms: Sequence[ConditionAtom],
              position: Mapping[ContextKey, int]) -> list[int]:
    """The indices of the contexts where every atom holds (types.ConditionAtom.holds), in order: per dimension
    the values every atom on it admits (unknown never holds), the others free."""
    choices: list[list[str | None]] = []
    for d in dims:
        mine = [a for a in atoms if a.dimension == d]
        values: list[str | None] = [*vocab.dimensions[d].values, None]
        choices.append([v for v in values if all(a.holds({d: v}) for a in mine)] if mine else values)
    if any(a.dimension not in dims for a in atoms):
        return []
    return sorted(position[key] for key in itertools.product(*choices))


def _bases(keys: Sequence[ContextKey], dims: Sequence[str], vocab: Vocabulary, statements: Sequence[CompiledStatement],
           shapes: Sequence[CompiledShape]) -> tuple[Decision, ...]:
    """Each context's decision from the statements and shapes in force there (paper §IV-A; engine.py composes).
    Each statement and shape lists the contexts it applies in (``_matching``); contexts with the same ones in
    force share one composition (a few dozen among the 1,296 of the shipped vocabulary)."""
    position = {key: i for i, key in enumerate(keys)}
    in_force: list[list[int]] = [[] for _ in keys]  # statement indices, then len(statements) + shape index
    for j, atoms in enumerate([s.atoms for s in statements] + [sh.atoms for sh in shapes]):
        for i in _matching(keys, dims, vocab, atoms, position):
            in_force[i].append(j)
    composed: dict[tuple[int, ...], Decision] = {}
    cites = [_citation(s) for s in statements]
    out = []
    for i, key in enumerate(keys):
        signature = tuple(in_force[i])
        base = composed.get(signature)
        if base is None:
            base = composed[signature] = _compose(vocab, [(statements[j], cites[j]) for j in signature if j < len(statements)],
                                                  [shapes[j - len(statements)] for j in signature if j >= len(statements)])
        out.append(replace(base, context=dict(zip(dims, key, strict=True))))
    return tuple(out)


def _compose(vocab: Vocabulary, statements: Sequence[tuple[CompiledStatement, Citation]], shapes: Sequence[CompiledShape]) -> Decision:
    """The decision of a context where exactly ``statements`` (with their citations) and ``shapes`` are in force, in
    their order."""
    pruned: dict[str, list[Citation]] = {}
    factors: dict[str, dict[str, Factor]] = {}
    weights: dict[str, Factor] = {m: Factor(1.0) for m in vocab.metrics}
    bonuses: dict[str, Factor] = {}
    accept: list[AcceptRule] = []
    escalation: tuple[int, Citation] | None = None
    for s, cite in statements:
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
    for sh in shapes:  # a prohibition prunes here; bounds are checked per candidate Θ′
        if sh.bound is None:
            for name in vocab.extractors:
                if sh.concerns(name):
                    pruned.setdefault(name, []).append(sh.citation)
    return Decision(context={}, candidates=(), pruned={x: tuple(c) for x, c in pruned.items()}, factors=factors,
                    weights=weights, bonuses=bonuses, shapes=tuple(shapes),
                    verification=Policy(tuple(accept), *(escalation or (DEFAULT_ESCALATIONS, None))))


def _measured_rule_enabled(kg: KnowledgeGraph) -> bool:
    rows = kg.select("SELECT ?e WHERE { nfex:rule_measured_configuration nfex:enabled ?e }").rows
    return not any(py(r["e"]) is False for r in rows)


def _min_measurements(kg: KnowledgeGraph) -> int:
    rows = kg.select("SELECT ?n WHERE { nfex:minMeasurements nfex:value ?n }").rows
    return int(py(rows[0]["n"])) if rows else 3
