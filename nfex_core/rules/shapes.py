"""Context shapes compiled for the rule engine: gate atoms, a parameter bound or a prohibition.

A context shape (``rules/shapes/context.ttl``, docs/shapes.md) has one form,
``sh:or ( [ sh:not GATE ] REQUIREMENT )``, targeting ``nfex:CandidateConfiguration``. Read as logic
it is GATE ⇒ REQUIREMENT on the candidate (α, Θ′) under context E. The engine reads it once per graph
version into a ``CompiledShape``:

- GATE → the extractor it names and condition atoms (the DSL's ``ConditionAtom``: a value, one of several
  values, or — negated — a known value not among them); an unknown dimension satisfies no atom,
  exactly as pySHACL finds no ``nfex:underCondition`` value for it;
- REQUIREMENT → a ``Bound`` ``θ_k ⋈ b`` (⋈ ∈ {≤, <, ≥, >, =}) on one parameter's setting, compared
  the way pySHACL compares literals, or, for anything that does not read the settings, a prohibition:
  the candidate is pruned wherever the gate holds.

A shape that does not have this form is reported in the table's errors and not compiled.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import rdflib
from rdflib.collection import Collection
from rdflib.namespace import RDF, RDFS, SH
from rdflib.term import BNode, Literal, Node, URIRef

from ..kg.namespaces import NFEX
from ..kg.terms import is_skolem
from ..kg.vocab import ConditionValueSpec, DimensionSpec, ExtractorSpec, ParameterSpec, Vocabulary
from .shape_check import verify_prohibitions
from .statements import CompiledStatement
from .types import Bound, CompiledShape, ConditionAtom

if TYPE_CHECKING:
    pass

COMPARATORS: dict[URIRef, str] = {
    SH.maxInclusive: "<=",
    SH.maxExclusive: "<",
    SH.minInclusive: ">=",
    SH.minExclusive: ">",
    SH.hasValue: "=",
}
DSL_COMPARATORS = {"<=": "<=", "<": "<", ">=": ">=", ">": ">", "=": "=", "==": "="}


class ShapeFormError(ValueError):
    """A context shape that is not of the compiled form (docs/shapes.md)."""


# ---------------------------------------------------------------------------------------- reading
def _term(vocab: Vocabulary, node: Node) -> object:
    return vocab.by_iri.get(node) if isinstance(node, URIRef) else None


def _only(g: rdflib.Graph, node: Node, allowed: set[URIRef], what: str) -> None:
    extra = {p for p in g.predicates(node, None) if p not in allowed and p != RDF.type}
    if extra:
        raise ShapeFormError(f"{what} has unexpected {', '.join(sorted(g.namespace_manager.normalizeUri(str(p)) for p in extra))}")


def _one(g: rdflib.Graph, node: Node, pred: URIRef, what: str) -> Node:
    values = list(g.objects(node, pred))
    if len(values) != 1:
        raise ShapeFormError(f"{what} needs exactly one {g.namespace_manager.normalizeUri(pred)}")
    return values[0]


def _value_spec(vocab: Vocabulary, node: Node) -> ConditionValueSpec:
    spec = _term(vocab, node)
    if not isinstance(spec, ConditionValueSpec):
        raise ShapeFormError(f"{node} is not a condition value")
    return spec


def _atom(g: rdflib.Graph, vocab: Vocabulary, prop: Node) -> ConditionAtom:
    """``sh:hasValue V`` | qualified ``sh:in (V…)`` | qualified ``inDimension D ; sh:not [ sh:in (V…) ]``."""
    if (prop, SH.hasValue, None) in g:
        _only(g, prop, {SH.path, SH.hasValue}, "a condition atom")
        v = _value_spec(vocab, _one(g, prop, SH.hasValue, "a condition atom"))
        return ConditionAtom(v.dimension, frozenset({v.name}))
    _only(g, prop, {SH.path, SH.qualifiedValueShape, SH.qualifiedMinCount}, "a condition atom")
    if _one(g, prop, SH.qualifiedMinCount, "a condition atom") != Literal(1):
        raise ShapeFormError("a condition atom needs sh:qualifiedMinCount 1")
    q = _one(g, prop, SH.qualifiedValueShape, "a condition atom")
    if (q, SH["in"], None) in g:
        _only(g, q, {SH["in"]}, "a condition atom's value shape")
        values = [_value_spec(vocab, v) for v in Collection(g, _one(g, q, SH["in"], "a value shape"))]
        negated = False
    else:
        _only(g, q, {SH.property, SH["not"]}, "a negated condition atom")
        dim_prop = _one(g, q, SH.property, "a negated condition atom")
        _only(g, dim_prop, {SH.path, SH.hasValue}, "a negated atom's dimension")
        if _one(g, dim_prop, SH.path, "a negated atom's dimension") != NFEX.inDimension:
            raise ShapeFormError("a negated condition atom names its dimension with nfex:inDimension")
        dim = _term(vocab, _one(g, dim_prop, SH.hasValue, "a negated atom's dimension"))
        inner = _one(g, q, SH["not"], "a negated condition atom")
        _only(g, inner, {SH["in"]}, "a negated condition atom's sh:not")
        values = [_value_spec(vocab, v) for v in Collection(g, _one(g, inner, SH["in"], "sh:not"))]
        if not isinstance(dim, DimensionSpec) or any(v.dimension != dim.name for v in values):
            raise ShapeFormError("a negated condition atom's values must belong to its dimension")
        negated = True
    dims = {v.dimension for v in values}
    if len(dims) != 1:
        raise ShapeFormError("the values of one condition atom must belong to one dimension")
    return ConditionAtom(dims.pop(), frozenset(v.name for v in values), negated)


def _gate(g: rdflib.Graph, vocab: Vocabulary, gate: Node) -> tuple[str | None, tuple[ConditionAtom, ...]]:
    _only(g, gate, {SH.property}, "the gate")
    extractor: str | None = None
    atoms: list[ConditionAtom] = []
    for prop in sorted(g.objects(gate, SH.property), key=str):
        path = _one(g, prop, SH.path, "a gate property")
        if path == NFEX.ofExtractor:
            _only(g, prop, {SH.path, SH.hasValue}, "the gate's extractor")
            x = _term(vocab, _one(g, prop, SH.hasValue, "the gate's extractor"))
            if not isinstance(x, ExtractorSpec) or extractor is not None:
                raise ShapeFormError("the gate names at most one known extractor")
            extractor = x.name
        elif path == NFEX.underCondition:
            atoms.append(_atom(g, vocab, prop))
        else:
            raise ShapeFormError(f"the gate may read nfex:ofExtractor and nfex:underCondition, not {path}")
    order = list(vocab.dimensions)  # SHACL keeps no order: atoms in the vocabulary's dimension order
    return extractor, tuple(sorted(atoms, key=lambda a: (order.index(a.dimension), a.negated, sorted(a.values))))


def _reads_settings(g: rdflib.Graph, node: Node) -> bool:
    seen, frontier = set(), {node}
    while frontier:
        seen |= frontier
        nxt = set()
        for n in frontier:
            for _, p, o in g.triples((n, None, None)):
                if NFEX.hasSetting in (p, o) or NFEX.value in (p, o) or NFEX.parameter in (p, o):
                    return True
                if (isinstance(o, BNode) or is_skolem(o)) and o not in seen:
                    nxt.add(o)
        frontier = nxt
    return False


def _bound(g: rdflib.Graph, vocab: Vocabulary, req: Node) -> Bound | None:
    """The requirement as one parameter bound; None for a prohibition (it does not read settings)."""
    if not _reads_settings(g, req):
        return None
    try:
        _only(g, req, {SH.property}, "a bound requirement")
        prop = _one(g, req, SH.property, "a bound requirement")
        _only(g, prop, {SH.path, SH.qualifiedValueShape, SH.qualifiedMinCount}, "a bound requirement")
        if _one(g, prop, SH.path, "a bound") != NFEX.hasSetting or _one(g, prop, SH.qualifiedMinCount, "a bound") != Literal(1):
            raise ShapeFormError("a bound reads nfex:hasSetting with sh:qualifiedMinCount 1")
        q = _one(g, prop, SH.qualifiedValueShape, "a bound")
        _only(g, q, {SH.property}, "a bound's setting shape")
        param = compare = None
        for p in g.objects(q, SH.property):
            path = _one(g, p, SH.path, "a bound's setting shape")
            if path == NFEX.parameter:
                _only(g, p, {SH.path, SH.hasValue}, "a bound's parameter")
                param = _term(vocab, _one(g, p, SH.hasValue, "a bound's parameter"))
            elif path == NFEX.value:
                _only(g, p, {SH.path, *COMPARATORS}, "a bound's value")
                [(pred, lit)] = [(pr, o) for pr, o in g.predicate_objects(p) if pr in COMPARATORS]
                compare = (COMPARATORS[pred], lit)  # type: ignore[index]
    except ValueError as e:  # includes the unpacking of two comparators
        raise ShapeFormError(f"a requirement that reads the settings must be one parameter bound ({e})") from e
    if not isinstance(param, ParameterSpec) or compare is None or not isinstance(compare[1], Literal):
        raise ShapeFormError("a bound names one known parameter (nfex:parameter sh:hasValue) and one literal bound on nfex:value")
    return Bound(param.extractor, param.name, compare[0], compare[1])


def compile_shape(g: rdflib.Graph, vocab: Vocabulary, shape: Node) -> CompiledShape:
    """One context shape of the shapes graph ``g`` (blank nodes, as pySHACL reads it)."""
    ors = list(g.objects(shape, SH["or"]))
    members = list(Collection(g, ors[0])) if len(ors) == 1 else []
    if len(members) != 2 or len(list(g.objects(members[0], SH["not"]))) != 1:
        raise ShapeFormError("a context shape is sh:or ( [ sh:not GATE ] REQUIREMENT )")
    extractor, atoms = _gate(g, vocab, _one(g, members[0], SH["not"], "the gate"))
    prune = g.value(shape, NFEX.pruneOnViolation)
    label = g.value(shape, RDFS.label) or shape
    message = g.value(shape, SH.message) or label
    return CompiledShape(
        iri=shape,  # type: ignore[arg-type]
        label=str(label),
        message=str(message),
        extractor=extractor,
        atoms=atoms,
        bound=_bound(g, vocab, members[1]),
        prune=bool(prune.toPython()) if isinstance(prune, Literal) else False,
    )


def context_shape_nodes(g: rdflib.Graph) -> list[Node]:
    """Shapes typed nfex:ContextShape or targeting candidates (pySHACL applies both)."""
    nodes = set(g.subjects(RDF.type, NFEX.ContextShape)) | set(g.subjects(SH.targetClass, NFEX.CandidateConfiguration))
    return sorted(nodes, key=str)


def require_as_shape(s: CompiledStatement) -> CompiledShape | None:
    """A DSL ``require`` that has no SHACL shape of its own, with the same semantics."""
    if s.extractor is None or s.parameter is None or s.value is None or s.comparator not in DSL_COMPARATORS:
        return None
    bound = Bound(s.extractor, s.parameter, DSL_COMPARATORS[s.comparator], Literal(s.value))
    return CompiledShape(s.iri, s.label, s.reason, s.extractor, s.atoms, bound, kind="require", source=s.source)


@dataclass(frozen=True)
class GraphShapes:
    """The context shapes of one shapes graph, compiled and verified (pySHACL) for one vocabulary, with the
    errors of the malformed ones. A compile keeps them while the graph and the vocabulary are the same objects
    (rules/setup.py: KnowledgeGraph carries both over a change that leaves them alone, so an editor's
    statement toggle compiles no shape again)."""

    graph: rdflib.Graph = field(compare=False, repr=False)
    vocab: Vocabulary = field(compare=False, repr=False)
    shapes: tuple[CompiledShape, ...]
    errors: tuple[str, ...]

    @classmethod
    def compile(cls, g: rdflib.Graph, vocab: Vocabulary) -> GraphShapes:
        out: list[CompiledShape] = []
        errors: list[str] = []
        for node in context_shape_nodes(g):
            try:
                out.append(compile_shape(g, vocab, node))
            except ShapeFormError as e:
                errors.append(f"{node}: {e} (docs/shapes.md)")
        out, unverified = verify_prohibitions(out, vocab, g)
        return cls(g, vocab, tuple(out), tuple(errors + unverified))

    def of(self, g: rdflib.Graph, vocab: Vocabulary) -> bool:
        """Whether these are the shapes of ``g`` compiled for ``vocab``."""
        return self.graph is g and self.vocab is vocab


def load_context_shapes(graph_shapes: GraphShapes, statements: list[CompiledStatement]) -> tuple[list[CompiledShape], list[str]]:
    """Every context shape of the graph and every shapeless ``require``; errors for malformed shapes."""
    out, errors = list(graph_shapes.shapes), list(graph_shapes.errors)
    for s in statements:
        if s.kind == "require" and s.shape is None:
            shape = require_as_shape(s)
            if shape is None:
                errors.append(f"{s.iri}: a require statement needs a parameter, a comparator and a bound")
            else:
                out.append(shape)
    return out, errors
