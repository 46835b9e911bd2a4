"""Context shapes to and from the DSL's words: ``require ORB.fastThreshold <= 10 when light is dark``.

``require_shape`` writes the SHACL shape of a ``require`` statement in the one form the engine
compiles (docs/shapes.md) — the DSL compiler calls it and links the statement to the shape with
``nfex:shape``. ``describe`` prints a compiled shape back as a DSL line, for ``nfex program show``:

    require ORB.fastThreshold <= 10 when light is dark
    require SIFT.nOctaveLayers <= 3 when agent is drone or human   (prune on violation)
    prune BRISK when light is dark and texture is low               (a prohibition)
"""
from __future__ import annotations

from collections.abc import Sequence

import rdflib
from rdflib.collection import Collection
from rdflib.namespace import RDF, RDFS, SH
from rdflib.term import BNode, Literal, Node, URIRef

from ..kg.vocab import Value, Vocabulary
from ..namespaces import NFEX
from .shapes import COMPARATORS, DSL_COMPARATORS, CompiledShape
from .statements import Atom

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


def _atom(g: rdflib.Graph, vocab: Vocabulary, atom: Atom) -> BNode:
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
    atoms: Sequence[Atom] = (),
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


def _atom_text(a: Atom) -> str:
    return f"{a.dimension} is {'not ' if a.negated else ''}{' or '.join(sorted(a.values))}"


def describe(shape: CompiledShape) -> str:
    """A compiled shape as a DSL line (see the module docstring)."""
    when = " and ".join(_atom_text(a) for a in shape.atoms)
    suffix = f" when {when}" if when else ""
    if shape.bound is None:
        return f"prune {shape.extractor or 'every extractor'}{suffix}"
    b = shape.bound
    value = b.literal.toPython()
    line = f"require {b.extractor}.{b.parameter} {b.comparator} {value}{suffix}"
    return line + ("   (prune on violation)" if shape.prune else "")
