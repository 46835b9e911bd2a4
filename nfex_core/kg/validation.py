"""SHACL validation of a write on the nodes it touches, and of the whole graph.

Whole-graph pySHACL costs about a second at 17k triples, too much for every write. A change can only
alter the validation result of

1. the *subjects* of its triples (their own properties changed), and
2. the nodes that *reach* those subjects along a path a shape follows (a configuration whose
   parameter's range changed), found by walking incoming edges ``BACKWARD_DEPTH`` steps back.

These are the focus nodes. The data graph handed to pySHACL is their neighbourhood in the candidate
state (store − removed + added): outgoing edges ``FORWARD_DEPTH`` steps deep, the types of every node
reached, the class hierarchy, and — for shapes that compare a node with its siblings, such as unique
parameter names per extractor — the incoming edges along the predicates those shapes declare with
``nfex:readsBackwardAlong``. ``tests/nfex_core/kg/test_validation.py`` checks on random changes that
this gives the same verdict as validating the whole candidate graph. pySHACL then validates the focus
nodes only — the neighbourhood's other nodes are there to be read, not judged (pyshacl_focus.py ``_OnFocus``) —
with a shapes graph it keeps across validations (shacl_shapes.py ``Shapes.pyshacl_graph``;
bench/bench_shacl_incremental.py times it). The reads of the candidate state are candidate.py's.

A change that edits the shapes themselves is validated against the whole candidate graph.

One shape is global rather than local: ``nfex:CoreShape`` (rules/shapes/integrity.ttl) says each of
its target classes keeps an instance. A change that removes class memberships can break it without
touching the class node, so ``core_violations`` checks it on every commit — with the targets of the
head's shape and of the candidate's, and refusing a change that removes the shape itself — by asking
the store whether an instance survives the change.
"""
from __future__ import annotations

from collections.abc import Callable, Collection, Iterable
from dataclasses import dataclass

import rdflib
from pyshacl.errors import ValidationFailure
from pyshacl.graph_abstraction import DataGraph
from pyshacl.validator import Validator
from rdflib.namespace import RDF, SH
from rdflib.term import Node, URIRef

from ..errors import BadInput, ValidationResult
from .backends import Backend
from .candidate import CandidateView, Neighbourhood
from .changes import ChangeSet
from .footprint import pairs, reads
from .namespaces import NFEX
from .pyshacl_focus import _as_prepared, parse_report
from .shacl_shapes import Shapes, extract_shapes, shapes_closure, shapes_in, touches_shapes
from .terms import Triple, n3

__all__ = ["CandidateView", "Neighbourhood", "Report", "Shapes", "core_violations", "extract_shapes", "parse_report",
           "run_pyshacl", "shapes_closure", "shapes_in", "touches_shapes", "validate_change", "validate_graph"]

FORWARD_DEPTH = 3
BACKWARD_DEPTH = 2

@dataclass(frozen=True)
class Report:
    conforms: bool
    results: list[ValidationResult]
    text: str
    focus_nodes: int = 0
    data_triples: int = 0

    @property
    def violations(self) -> list[ValidationResult]:
        return [r for r in self.results if r.severity == "Violation"]


def run_pyshacl(data: Iterable[Triple], shapes: Shapes, focus: set[Node] | None) -> tuple[list[ValidationResult], str]:
    """Run pySHACL; with ``focus``, only on the targets among those nodes (``_OnFocus``).

    The validator is pySHACL's own (``pyshacl.validate`` builds the same); only its shapes graph is
    ``shapes``' kept one. Validations on one ``Shapes`` take turns on its lock: the kept shapes graph
    carries the focus of the validation under way.
    """
    with shapes.pyshacl_lock:
        sg = shapes.pyshacl_graph
        sg.focus = frozenset(focus) if focus is not None else None
        try:
            # the Validator wraps the graph it is given in a ShapesGraph of its own: an empty one, replaced at once
            validator = Validator(DataGraph.from_rdflib(_as_prepared(data)), shacl_graph=rdflib.Graph(), options={
                "advanced": True, "allow_warnings": True, "inplace": True})
            validator.shacl_graph = sg
            try:
                _, results_graph, text = validator.run()
            except ValidationFailure as e:  # what pyshacl.validate reports for a shape it cannot run
                raise BadInput(f"pySHACL cannot validate with these shapes: {e.message}") from e
        finally:
            sg.focus = None
    results = parse_report(results_graph, shapes.graph)
    if focus is not None:
        names = {str(f) for f in focus}
        results = [r for r in results if r.focus_node in names]
        text = "Conforms: " + str(not any(r.severity == "Violation" for r in results)) + "".join(
            f"\n{r.severity}: {r.line()}" for r in results
        )
    return results, str(text)


def validate_graph(data: rdflib.Graph, shapes: Shapes) -> Report:
    results, text = run_pyshacl(data, shapes, None)
    violations = [r for r in results if r.severity == "Violation"]
    return Report(not violations, results, text, data_triples=len(data))


Runner = Callable[[Collection[Triple], Shapes, set[Node]], tuple[list[ValidationResult], str]]
"""What runs pySHACL on a change's neighbourhood: ``run_pyshacl`` here, or a worker process's (shacl_process.py)."""


def validate_change(backend: Backend, change: ChangeSet, shapes: Shapes, run: Runner | None = None,
                    cache: Neighbourhood | None = None) -> Report:
    """Validate the candidate state on the nodes ``change`` touches (see the module docstring); ``run``: where
    pySHACL runs (default: in this process); ``cache``: the store's neighbourhoods at its head (``Neighbourhood``)."""
    view = CandidateView(backend, change, cache)
    focus: set[Node] = {s for s in change.subjects() if isinstance(s, URIRef)}
    fp = shapes.footprint
    frontier: set[Node] = {t[0] for t in change.added | change.removed if isinstance(t[0], URIRef) and reads(fp, pairs([t]))}
    for _ in range(BACKWARD_DEPTH):
        referrers = {t[0] for t in view.incoming(frontier)} - focus
        focus |= referrers
        frontier = referrers
        if not frontier:
            break

    data: set[Triple] = set()
    reached: set[Node] = set(focus)
    frontier = set(focus)
    for _ in range(FORWARD_DEPTH):
        triples = view.outgoing(frontier)
        data |= triples
        nxt: set[Node] = {t[2] for t in triples if isinstance(t[2], URIRef) and t[1] != RDF.type}
        nxt -= reached
        reached |= nxt
        frontier = nxt
        if not frontier:
            break
    # the last ring's own types (sh:class checks) and its siblings along declared predicates
    data |= {t for t in view.outgoing(frontier) if t[1] == RDF.type}
    siblings = view.incoming(reached, shapes.backward_predicates())
    data |= siblings
    data |= {t for t in view.outgoing({t[0] for t in siblings} - reached)}
    data |= view.subclass_axioms()

    results, text = (run or run_pyshacl)(data, shapes, focus)
    violations = [r for r in results if r.severity == "Violation"]
    return Report(not violations, results, text, focus_nodes=len(focus), data_triples=len(data))


CORE_SHAPE = NFEX.CoreShape
CORE_MESSAGE = "No instance of {} would remain: the ontology's core cannot be removed."


def core_violations(backend: Backend, change: ChangeSet) -> list[ValidationResult]:
    """``nfex:CoreShape`` on the candidate state: every target class of the head's shape or the
    candidate's keeps an instance, and the shape itself stays (module docstring)."""
    head = {r["c"] for r in backend.select(f"SELECT ?c WHERE {{ {n3(CORE_SHAPE)} {n3(SH.targetNode)} ?c }}").rows}
    if not head and not any(s == CORE_SHAPE for s, _, _ in change.added):
        return []  # a graph without the core shape (being seeded, or an older graph)
    out: list[ValidationResult] = []
    if (CORE_SHAPE, RDF.type, SH.NodeShape) in change.removed and (CORE_SHAPE, RDF.type, SH.NodeShape) not in change.added:
        out.append(ValidationResult(str(CORE_SHAPE), str(CORE_SHAPE), "the core shape itself cannot be removed"))
    targets = head | {o for s, p, o in change.added if s == CORE_SHAPE and p == SH.targetNode}
    untyped: dict[Node, set[Node]] = {}
    for s, p, o in change.removed:
        if p == RDF.type and o in targets:
            untyped.setdefault(o, set()).add(s)
    for cls, gone in sorted(untyped.items(), key=lambda kv: str(kv[0])):
        if any(t[1] == RDF.type and t[2] == cls for t in change.added):
            continue
        others = " ".join(n3(x) for x in gone if isinstance(x, URIRef))
        exclude = f"FILTER (?x NOT IN ({', '.join(n3(x) for x in gone if isinstance(x, URIRef))}))" if others else ""
        if not backend.ask(f"ASK {{ ?x {n3(RDF.type)} {n3(cls)} . {exclude} }}"):
            out.append(ValidationResult(str(cls), str(CORE_SHAPE), CORE_MESSAGE.format(cls)))
    return out
