"""Context shapes to and from the DSL's words: ``require ORB.fastThreshold <= 10 when light is dark``.

``require_shape`` writes the SHACL shape of a ``require`` statement in the one form the engine
compiles (docs/shapes.md) — the DSL compiler calls it and links the statement to the shape with
``nfex:shape``. ``describe`` prints a compiled shape back as a DSL line, for ``nfex program show``:

    require ORB.fastThreshold <= 10 when light is dark
    require SIFT.nOctaveLayers <= 3 when agent is one of (drone, human)   # prune on violation
    prune BRISK when light is dark and texture is low                     (a prohibition)
"""
from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING

import rdflib
from rdflib.collection import Collection
from rdflib.namespace import RDF, RDFS, SH
from rdflib.term import BNode, Literal, Node, URIRef

from ..kg.identity import program_iri
from ..kg.namespaces import NFEX
from ..kg.terms import is_skolem, n3
from ..kg.vocab import Value, Vocabulary
from .shapes import COMPARATORS, DSL_COMPARATORS, CompiledShape, ShapeFormError, compile_shape
from .types import ConditionAtom

if TYPE_CHECKING:
    from ..kg.store import KnowledgeGraph

_PREDICATE = {v: k for k, v in COMPARATORS.items()}


def _list(g: rdflib.Graph, items: Sequence[Node]) -> BNode:
    head = BNode()
    Collection(g, head, list(items))
    return head


def _prop(g: rdflib.Graph, path: URIRef, **constraints: Node) -> BNode:
    node = BNode()
    g.add((node, SH.path, path))
    for name, value in constraints.items():
        g.add((node, SH[name], value))
    return node


def _atom(g: rdflib.Graph, vocab: Vocabulary, atom: ConditionAtom) -> BNode:
    dim = vocab.dimension(atom.dimension)
    values = [dim.value(v).iri for v in sorted(atom.values)]
    if not atom.negated and len(values) == 1:
        return _prop(g, NFEX.underCondition, hasValue=values[0])
    q = BNode()
    if atom.negated:
        g.add((q, SH.property, _prop(g, NFEX.inDimension, hasValue=dim.iri)))
        inner = BNode()
        g.add((inner, SH["in"], _list(g, values)))
        g.add((q, SH["not"], inner))
    else:
        g.add((q, SH["in"], _list(g, values)))
    return _prop(g, NFEX.underCondition, qualifiedMinCount=Literal(1), qualifiedValueShape=q)


def require_shape(
    iri: URIRef,
    vocab: Vocabulary,
    parameter: str,
    comparator: str,
    bound: Value,
    atoms: Sequence[ConditionAtom] = (),
    *,
    label: str = "",
    message: str = "",
    prune: bool = False,
) -> rdflib.Graph:
    """The context shape ``iri`` for ``require <parameter> <comparator> <bound> when <atoms>``.

    ``parameter`` is qualified (``ORB.fastThreshold``); the bound is typed as the parameter is.
    """
    extractor_name, _, name = parameter.partition(".")
    spec = vocab.extractor(extractor_name)
    param = spec.parameter(name)
    cmp = DSL_COMPARATORS[comparator]
    text = f"{param.qualified} {cmp} {bound}"
    g = rdflib.Graph()
    g.add((iri, RDF.type, SH.NodeShape))
    g.add((iri, RDF.type, NFEX.ContextShape))
    g.add((iri, RDFS.label, Literal(label or f"require {text}", lang="en")))
    g.add((iri, SH.targetClass, NFEX.CandidateConfiguration))
    when = " and ".join(_atom_text(a) for a in atoms)
    g.add((iri, SH.message, Literal(message or f"{'Under ' + when + ' a' if when else 'A'} {spec.name} configuration needs {text}.")))
    if prune:
        g.add((iri, NFEX.pruneOnViolation, Literal(True)))
    gate = BNode()
    g.add((gate, SH.property, _prop(g, NFEX.ofExtractor, hasValue=spec.iri)))
    for a in atoms:
        g.add((gate, SH.property, _atom(g, vocab, a)))
    not_gate = BNode()
    g.add((not_gate, SH["not"], gate))
    setting = BNode()
    g.add((setting, SH.property, _prop(g, NFEX.parameter, hasValue=param.iri)))
    value = BNode()
    g.add((value, SH.path, NFEX.value))
    g.add((value, _PREDICATE[cmp], param.literal(param.coerce(bound))))
    g.add((setting, SH.property, value))
    requirement = BNode()
    g.add((requirement, SH.property, _prop(g, NFEX.hasSetting, qualifiedMinCount=Literal(1), qualifiedValueShape=setting)))
    g.add((iri, SH["or"], _list(g, [not_gate, requirement])))
    return g


def _atom_text(a: ConditionAtom) -> str:
    """As the DSL writes an atom: ``light is dark``, ``agent is not one of (car, human)``."""
    values = sorted(a.values)
    what = values[0] if len(values) == 1 else f"one of ({', '.join(values)})"
    return f"{a.dimension} is {'not ' if a.negated else ''}{what}"


def describe(shape: CompiledShape) -> str:
    """A compiled shape as a DSL line (see the module docstring)."""
    when = " and ".join(_atom_text(a) for a in shape.atoms)
    suffix = f" when {when}" if when else ""
    if shape.bound is None:
        return f"prune {shape.extractor or 'every extractor'}{suffix}"
    b = shape.bound
    value = b.literal.toPython()
    text = str(value).lower() if isinstance(value, bool) else str(value)
    line = f"require {b.extractor}.{b.parameter} {b.comparator} {text}{suffix}"
    return line + ("   # prune on violation" if shape.prune else "")


def shape_graph(kg: KnowledgeGraph, roots: Iterable[Node]) -> rdflib.Graph:
    """The stored triples of shapes ``roots`` and of the (skolemised) nodes they hang on, as the store names them."""
    out = rdflib.Graph()
    seen: set[Node] = set()
    frontier: set[Node] = {r for r in roots if isinstance(r, URIRef)}
    while frontier:
        seen |= frontier
        g = kg.construct(f"CONSTRUCT {{ ?s ?p ?o }} WHERE {{ VALUES ?s {{ {' '.join(n3(n) for n in frontier)} }} ?s ?p ?o }}")
        out += g
        frontier = {o for o in g.objects() if is_skolem(o) and o not in seen}
    return out


def program_shapes(kg: KnowledgeGraph, program: str) -> list[tuple[str, str]]:
    """(statement label, the DSL line read back from its SHACL shape) for each ``require`` of ``program``."""
    rows = kg.select(
        f"SELECT ?label ?shape WHERE {{ ?s nfex:inProgram {n3(program_iri(program))} ; rdfs:label ?label ; nfex:shape ?shape ; nfex:order ?o }} ORDER BY ?o"
    ).rows
    g, vocab = kg.shapes().graph, kg.vocabulary()
    out = []
    for r in rows:
        try:
            line = f"{describe(compile_shape(g, vocab, r['shape']))}   # {r['shape']}"
        except ShapeFormError as e:
            line = f"# {r['shape']}: {e}"
        out.append((str(r["label"]), line))
    return out
