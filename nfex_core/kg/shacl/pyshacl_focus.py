"""pySHACL adapted to validating a change's neighbourhood: focus nodes only, a shapes graph kept across runs.

``_OnFocus`` restricts a top-level shape to the focus nodes among its targets (``_ShapesGraph`` wraps them, kept by
``shapes.Shapes``); ``PreparedQueryGraph`` parses each SPARQL constraint once; ``parse_report`` turns pySHACL's
results graph into ValidationResults. validation.py ``run_pyshacl`` runs them.
"""
from __future__ import annotations

import functools
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import rdflib
from pyshacl.shapes_graph import ShapesGraph
from rdflib.namespace import RDF, RDFS, SH
from rdflib.term import Literal, Node, URIRef

from ...errors import ValidationResult
from ..rdf.rdflib_sparql import prepare_query
from ..rdf.terms import Triple, is_skolem


class PreparedQueryGraph(rdflib.Graph):
    """An rdflib graph that parses each distinct SPARQL text once.

    pySHACL runs a SPARQL-based constraint once per focus node with ``$this`` pre-bound, re-parsing
    the same text every time — rdflib's parser costs ~20 ms a query, most of a validation. rdflib's
    prepared queries are made to be reused with different initial bindings, so cache them by text.
    """

    _prepared: dict[tuple[str, tuple[tuple[str, str], ...]], Any] = {}

    def query(self, query_object: Any, *args: Any, **kwargs: Any) -> Any:
        if isinstance(query_object, str):
            init_ns = kwargs.get("initNs") or (args[2] if len(args) > 2 else None) or {}
            key = (query_object, tuple(sorted((k, str(v)) for k, v in dict(init_ns).items())))
            prepared = self._prepared.get(key)
            if prepared is None:
                if len(self._prepared) > 512:
                    self._prepared.clear()
                prepared = self._prepared[key] = prepare_query(query_object, init_ns)
            query_object = prepared
        return super().query(query_object, *args, **kwargs)


def _as_prepared(data: Iterable[Triple]) -> PreparedQueryGraph:
    if isinstance(data, PreparedQueryGraph):
        return data
    g = PreparedQueryGraph()
    for t in data:
        g.add(t)
    return g


class _OnFocus:
    """A top-level pySHACL shape that validates only those of its targets that are focus nodes.

    pySHACL's own ``focus_nodes`` option is not used: in pySHACL 0.40 it also filters the value nodes of
    nested shapes (sh:or, sh:node over literals), so such constraints pass vacuously. Here a shape is
    narrowed only where it finds its own targets (``focus is None``: the validator's top-level call); a
    nested evaluation passes its value nodes through untouched. A result's focus node is the top-level
    target it was found under, so this drops exactly the results that filtering the report would drop,
    without computing them: a report's neighbourhood holds its extractor's parameters, the condition
    values and the rest, all targets of their own shapes, and validating them was most of the time.

    Which focus nodes a shape targets is read from the focus nodes (``_Targets.among``), not by listing every
    target in the data graph and keeping the focus nodes among them: of the ~170 shapes, a report batch is the
    target of one, and listing all their targets was a third of its validation.
    """

    def __init__(self, shape: Any, focus: _Focus, targets: _Targets | None) -> None:
        self.shape, self.focus, self.targets = shape, focus, targets

    def __getattr__(self, name: str) -> Any:
        return getattr(self.shape, name)

    def validate(self, executor: Any, graph: Any, focus: Any = None, _evaluation_path: Any = None) -> Any:
        if focus is not None:
            return self.shape.validate(executor, graph, focus=focus, _evaluation_path=_evaluation_path)
        if self.targets is None:  # a SHACL-AF target (sh:target): only pySHACL can list what it selects
            mine = [f for f in self.shape.focus_nodes(graph) if f in self.focus.nodes]
        else:
            mine = self.targets.among(self.focus.facts(graph))
        return self.shape.validate(executor, graph, focus=mine) if mine else (True, [])


@dataclass(frozen=True)
class _Targets:
    """A shape's target declarations as pySHACL's ``Shape.focus_nodes`` reads them (``Shape.target``): explicit
    nodes, classes (``sh:targetClass`` and the shape itself where it is a class), and the predicates whose
    subjects or objects it targets."""

    nodes: frozenset[Node]
    classes: frozenset[Node]
    subjects_of: frozenset[Node]
    objects_of: frozenset[Node]

    @classmethod
    def of(cls, shape: Any) -> _Targets | None:
        """None where the shape has a SHACL-AF target (``sh:target``), which this does not read: pySHACL's own
        ``focus_nodes`` then lists the targets, those of such a target only in advanced mode, which the validator
        switches on after the shapes were read."""
        if any(shape.sg.graph.objects(shape.node, SH.target)):
            return None
        nodes, classes, implicit, objects_of, subjects_of = shape.target()
        return cls(frozenset(nodes), frozenset(classes) | frozenset(implicit), frozenset(subjects_of), frozenset(objects_of))

    def among(self, facts: dict[Node, _Facts]) -> list[Node]:
        """The focus nodes this shape targets: pySHACL's targets, from the focus nodes' side. A node of type T is
        an instance of every class T reaches along ``rdfs:subClassOf`` in the data graph, as ``focus_nodes``
        finds the instances of a target class's transitive subclasses; an explicit target node counts whether
        the data graph holds it or not."""
        return [f for f, (classes, out, into) in facts.items()
                if f in self.nodes or not self.classes.isdisjoint(classes) or not self.subjects_of.isdisjoint(out)
                or not self.objects_of.isdisjoint(into)]


_Facts = tuple[frozenset[Node], frozenset[Node], frozenset[Node]]  # a node's classes, predicates out, predicates in


class _Focus:
    """The focus nodes of one validation, and what a target declaration can ask of each in its data graph (read
    once per validation, for all shapes)."""

    def __init__(self, nodes: frozenset[Node]) -> None:
        self.nodes = nodes
        self._facts: tuple[Any, dict[Node, _Facts]] | None = None

    def facts(self, graph: Any) -> dict[Node, _Facts]:
        if self._facts is None or self._facts[0] is not graph:
            found: dict[Node, _Facts] = {}
            for f in self.nodes:
                classes = {c for t in graph.objects(f, RDF.type) for c in graph.transitive_objects(t, RDFS.subClassOf)}
                found[f] = (frozenset(classes), frozenset(p for p, _ in graph.predicate_objects(f)),
                            frozenset(p for _, p in graph.subject_predicates(f)))
            self._facts = (graph, found)
        return self._facts[1]


class _ShapesGraph(ShapesGraph):
    """pySHACL's view of a ``Shapes``, built once (its shape objects and their parsed constraints, their target
    declarations) rather than once per validation, with the focus of the validation under way (``run_pyshacl``
    sets it)."""

    focus: frozenset[Node] | None = None

    @functools.cached_property
    def _targets(self) -> dict[Node, _Targets | None]:
        return {s.node: _Targets.of(s) for s in super().shapes}

    @property
    def shapes(self) -> Any:
        shapes = super().shapes
        if self.focus is None:
            return shapes
        focus = _Focus(self.focus)
        return [_OnFocus(s, focus, self._targets[s.node]) for s in shapes]


def parse_report(results_graph: rdflib.Graph, shapes: rdflib.Graph) -> list[ValidationResult]:
    """SHACL results as ValidationResults; an anonymous property shape is named by its node shape."""
    out: list[ValidationResult] = []
    for r in results_graph.subjects(RDF.type, SH.ValidationResult):
        shape = results_graph.value(r, SH.sourceShape)
        owner = shapes.value(None, SH.property, shape) if shape is not None else None
        path = results_graph.value(r, SH.resultPath)
        anonymous = not isinstance(shape, URIRef) or is_skolem(shape)
        shape_name = str(owner) if (owner is not None and anonymous) else str(shape)
        value = results_graph.value(r, SH.value)
        severity = results_graph.value(r, SH.resultSeverity)
        message = results_graph.value(r, SH.resultMessage)
        if message is None:
            comp = results_graph.value(r, SH.sourceConstraintComponent)
            message = Literal(f"violates {comp}")
        out.append(
            ValidationResult(
                focus_node=str(results_graph.value(r, SH.focusNode)),
                source_shape=shape_name,
                message=str(message),
                path=str(path) if isinstance(path, URIRef) else None,
                value=str(value) if value is not None else None,
                severity=str(severity).rsplit("#", 1)[-1] if severity is not None else "Violation",
            )
        )
    # every field in the key: results that tie on the first three (one per value of a path) otherwise keep the
    # results graph's order, which differs between processes (the SHACL worker's report against this one's)
    out.sort(key=lambda v: (v.focus_node, v.source_shape, v.message, v.path or "", v.value or "", v.severity))
    return out


