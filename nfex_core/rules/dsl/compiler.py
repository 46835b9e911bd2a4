"""Programs to graph triples and back (docs/dsl.md, ontology/dsl.ttl).

A program becomes an ``nfex:Program`` individual; each statement an individual of
``nfex:PruneStatement`` | ``AdjustStatement`` | ``WeightStatement`` | ``PreferStatement`` |
``RequireStatement`` | ``AcceptStatement`` (its tests as ``nfex:PairTest`` nodes: ``nfex:signal``,
``nfex:testComparator``, ``nfex:threshold``) | ``EscalateStatement`` (``nfex:maxEscalations``) with
``nfex:inProgram``, ``rdfs:label`` (its canonical text, what selections cite), ``nfex:reason``, ``nfex:order`` and ``nfex:line``, and one ``nfex:ConditionAtom`` per
``dimension is [not] value(s)`` (``nfex:dimension``, ``nfex:oneOf``, ``nfex:negated``). Names become
the IRIs of the graph's extractors, parameters, metrics and condition values, so SPARQL can join rules
with the ontology and with measurements. ``decompile`` reads the triples back into the same AST:
``parse(render(decompile(compile(p)))) == p``.

Statement IRIs are derived from the program name and the statement's canonical text, so re-applying
an edited program keeps the IRIs (and the citations) of the statements that did not change.
"""
from __future__ import annotations

import rdflib
from rdflib.namespace import RDF, RDFS, XSD
from rdflib.term import Literal, URIRef

from ...errors import NotFound
from ...kg.identity import program_iri, statement_iri
from ...kg.namespaces import NFEX
from ...kg.vocab import (
    ConditionValueSpec,
    DimensionSpec,
    ExtractorSpec,
    MetricSpec,
    ParameterSpec,
    Vocabulary,
)
from ..shape_text import require_shape
from ..types import ConditionAtom
from .parser import Atom, Pos, Program, Statement, Test

CLASSES = {
    "prune": NFEX.PruneStatement,
    "adjust": NFEX.AdjustStatement,
    "weight": NFEX.WeightStatement,
    "prefer": NFEX.PreferStatement,
    "require": NFEX.RequireStatement,
    "accept": NFEX.AcceptStatement,
    "escalate": NFEX.EscalateStatement,
}
KINDS = {v: k for k, v in CLASSES.items()}
VALUE_PROPERTY = {"adjust": NFEX.factor, "weight": NFEX.weight, "prefer": NFEX.bonus, "require": NFEX.bound}


def _double(v: float | int | bool | None) -> Literal:
    return Literal(float(v), datatype=XSD.double)  # type: ignore[arg-type]


def compile_program(program: Program, vocab: Vocabulary, *, source_file: str | None = None) -> rdflib.Graph:
    """The triples of ``program`` (already checked against ``vocab``)."""
    g = rdflib.Graph()
    p = program_iri(program.name)
    g.add((p, RDF.type, NFEX.Program))
    g.add((p, RDFS.label, Literal(program.name)))
    if source_file:
        g.add((p, NFEX.sourceFile, Literal(source_file)))
    seen: dict[str, int] = {}
    for order, s in enumerate(program.statements, start=1):
        label = s.label()
        iri = statement_iri(program.name, label, seen.get(label, 0))
        seen[label] = seen.get(label, 0) + 1
        g.add((iri, RDF.type, CLASSES[s.kind]))
        g.add((iri, NFEX.inProgram, p))
        g.add((iri, RDFS.label, Literal(label)))
        g.add((iri, NFEX.order, Literal(order)))
        if s.pos.line:
            g.add((iri, NFEX.line, Literal(s.pos.line)))
        if s.reason is not None:
            g.add((iri, NFEX.reason, Literal(s.reason)))
        if s.kind in ("prune", "prefer"):
            x = vocab.extractor(s.extractor or "")
            g.add((iri, NFEX.prunes if s.kind == "prune" else NFEX.prefers, x.iri))
        if s.kind in ("adjust", "require"):
            param = vocab.extractor(s.extractor or "").parameter(s.parameter or "")
            g.add((iri, NFEX.parameter, param.iri))
        if s.kind == "weight":
            g.add((iri, NFEX.metric, vocab.metric(s.metric or "").iri))
        if s.kind == "require":
            g.add((iri, NFEX.comparator, Literal(s.comparator)))
            g.add((iri, NFEX.bound, param.literal(param.coerce(s.value))))
            g += _require_shape(iri, s, vocab, label)
        elif s.kind in VALUE_PROPERTY:
            g.add((iri, VALUE_PROPERTY[s.kind], _double(s.value)))
        if s.kind == "escalate":
            g.add((iri, NFEX.maxEscalations, Literal(int(s.value or 0))))
        for i, t in enumerate(s.tests, start=1):
            node = URIRef(f"{iri}_test_{i}")
            g.add((iri, NFEX.hasTest, node))
            g.add((node, RDF.type, NFEX.PairTest))
            g.add((node, NFEX.order, Literal(i)))
            g.add((node, NFEX.signal, Literal(t.signal)))
            g.add((node, NFEX.testComparator, Literal(t.comparator)))
            g.add((node, NFEX.threshold, _double(t.bound)))
        for i, atom in enumerate(s.when, start=1):
            a = URIRef(f"{iri}_when_{i}")
            dim = vocab.dimension(atom.dimension)
            g.add((iri, NFEX.hasCondition, a))
            g.add((a, RDF.type, NFEX.ConditionAtom))
            g.add((a, NFEX.order, Literal(i)))
            g.add((a, NFEX.dimension, dim.iri))
            g.add((a, NFEX.negated, Literal(atom.negated)))
            for v in atom.values:
                g.add((a, NFEX.oneOf, dim.value(v).iri))
    return g


def _require_shape(iri: URIRef, s: Statement, vocab: Vocabulary, label: str) -> rdflib.Graph:
    """The context shape a ``require`` compiles to (docs/shapes.md), linked with ``nfex:shape``."""
    shape = URIRef(f"{iri}_shape")
    atoms = [ConditionAtom(a.dimension, frozenset(a.values), a.negated) for a in s.when]
    g = require_shape(shape, vocab, f"{s.extractor}.{s.parameter}", s.comparator or "", s.value if s.value is not None else 0, atoms, label=label, message=s.reason or "")
    g.add((iri, NFEX.shape, shape))
    return g


def _name(vocab: Vocabulary, iri: object) -> str:
    spec = vocab.by_iri.get(iri)  # type: ignore[call-overload]
    if isinstance(spec, ExtractorSpec | MetricSpec | DimensionSpec | ConditionValueSpec):
        return spec.name
    return str(iri).rsplit("#", 1)[-1]


def _int(g: rdflib.Graph, s: URIRef, p: URIRef, default: int = 0) -> int:
    v = g.value(s, p)
    return int(v.toPython()) if isinstance(v, Literal) else default


def _atom(g: rdflib.Graph, a: URIRef, vocab: Vocabulary) -> Atom:
    neg = g.value(a, NFEX.negated)
    values = tuple(sorted(_name(vocab, v) for v in g.objects(a, NFEX.oneOf)))
    return Atom(_name(vocab, g.value(a, NFEX.dimension)), values, bool(neg.toPython()) if isinstance(neg, Literal) else False)


def _test(g: rdflib.Graph, t: URIRef) -> Test:
    bound = g.value(t, NFEX.threshold)
    return Test(str(g.value(t, NFEX.signal)), str(g.value(t, NFEX.testComparator)), bound.toPython() if isinstance(bound, Literal) else 0.0)


def _statement(g: rdflib.Graph, s: URIRef, kind: str, vocab: Vocabulary) -> Statement:
    atoms = sorted(g.objects(s, NFEX.hasCondition), key=lambda a: (_int(g, a, NFEX.order), str(a)))  # type: ignore[arg-type]
    reason = g.value(s, NFEX.reason)
    fields: dict[str, object] = {}
    x = g.value(s, NFEX.prunes) or g.value(s, NFEX.prefers)
    if x is not None:
        fields["extractor"] = _name(vocab, x)
    param = vocab.by_iri.get(g.value(s, NFEX.parameter))  # type: ignore[call-overload]
    if isinstance(param, ParameterSpec):
        fields["extractor"], fields["parameter"] = param.extractor, param.name
    metric = g.value(s, NFEX.metric)
    if metric is not None:
        fields["metric"] = _name(vocab, metric)
    if kind in VALUE_PROPERTY:
        v = g.value(s, VALUE_PROPERTY[kind])
        fields["value"] = v.toPython() if isinstance(v, Literal) else None
    if kind == "require":
        fields["comparator"] = str(g.value(s, NFEX.comparator))
    if kind == "escalate":
        fields["value"] = _int(g, s, NFEX.maxEscalations)
    if kind == "accept":
        tests = sorted(g.objects(s, NFEX.hasTest), key=lambda t: (_int(g, t, NFEX.order), str(t)))  # type: ignore[arg-type]
        fields["tests"] = tuple(_test(g, t) for t in tests)  # type: ignore[arg-type]
    return Statement(
        kind,
        tuple(_atom(g, a, vocab) for a in atoms),  # type: ignore[arg-type]
        str(reason) if reason is not None else None,
        pos=Pos(_int(g, s, NFEX.line), 1),
        **fields,  # type: ignore[arg-type]
    )


def decompile(graph: rdflib.Graph, name: str, vocab: Vocabulary) -> Program:
    """The program ``name`` read back from its triples (``graph`` may hold other programs too)."""
    p = program_iri(name)
    if (p, RDF.type, NFEX.Program) not in graph:
        raise NotFound(f"no program named {name!r} in the graph")
    found: list[tuple[int, str, Statement]] = []
    for s in graph.subjects(NFEX.inProgram, p):
        kinds = [KINDS[t] for t in graph.objects(s, RDF.type) if t in KINDS]  # type: ignore[index]
        if kinds:
            found.append((_int(graph, s, NFEX.order), str(s), _statement(graph, s, kinds[0], vocab)))  # type: ignore[arg-type]
    source = graph.value(p, NFEX.sourceFile)
    return Program(str(graph.value(p, RDFS.label) or name), tuple(st for _, _, st in sorted(found, key=lambda t: t[:2])), str(source) if source else None)
