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
nodes only — the neighbourhood's other nodes are there to be read, not judged (``_OnFocus``) — with a shapes
graph it keeps across validations (``Shapes.pyshacl_graph``; bench/bench_shacl_incremental.py times it).

A change that edits the shapes themselves is validated against the whole candidate graph.

One shape is global rather than local: ``nfex:CoreShape`` (rules/shapes/integrity.ttl) says each of
its target classes keeps an instance. A change that removes class memberships can break it without
touching the class node, so ``core_violations`` checks it on every commit — with the targets of the
head's shape and of the candidate's, and refusing a change that removes the shape itself — by asking
the store whether an instance survives the change.
"""
from __future__ import annotations

import functools
import threading
import uuid
from collections.abc import Callable, Collection, Iterable, Iterator
from dataclasses import dataclass, field
from typing import Any

import rdflib
from pyshacl.errors import ValidationFailure
from pyshacl.graph_abstraction import DataGraph
from pyshacl.shapes_graph import ShapesGraph
from pyshacl.validator import Validator
from rdflib.namespace import RDF, RDFS, SH
from rdflib.term import BNode, Literal, Node, URIRef

from ..errors import BadInput, ValidationResult
from ..namespaces import NFEX
from .backends import Backend
from .changes import ChangeSet
from .footprint import footprint, pairs, reads
from .history import prefix_block
from .rdflib_sparql import prepare_query
from .terms import Triple, is_skolem, n3

FORWARD_DEPTH = 3
BACKWARD_DEPTH = 2
CHUNK = 400


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


def _chunks(items: Iterable[Node], size: int = CHUNK) -> Iterator[list[Node]]:
    batch: list[Node] = []
    for it in items:
        batch.append(it)
        if len(batch) == size:
            yield batch
            batch = []
    if batch:
        yield batch


class Neighbourhood:
    """The store's triples around nodes at one graph version, as ``CandidateView`` reads them, carried from one
    commit to the next for the nodes the commit did not touch (``carry``): a fleet's reports read the same
    configurations, parameters and condition values batch after batch. Entries are a node's outgoing triples,
    its incoming ones per predicate filter, and the class hierarchy; a version other than the one carried to
    clears it, so a write that did not go through ``carry`` (another replica's, a rollback) costs a re-read,
    never a stale answer. Used under the store's write lock only (``KnowledgeGraph.commit``)."""

    MAX_NODES = 20_000  # past this many entries it starts again empty

    def __init__(self) -> None:
        self.version = -1
        self.outgoing: dict[Node, frozenset[Triple]] = {}
        self.incoming: dict[frozenset[URIRef] | None, dict[Node, frozenset[Triple]]] = {}  # per predicate filter
        self.axioms: frozenset[Triple] | None = None

    def at(self, version: int) -> Neighbourhood:
        """This cache, for reads of the store at ``version`` (emptied unless it holds that version)."""
        if version != self.version or len(self.outgoing) + sum(map(len, self.incoming.values())) > self.MAX_NODES:
            self.clear()
            self.version = version
        return self

    def clear(self) -> None:
        self.version = -1
        self.outgoing, self.incoming, self.axioms = {}, {}, None

    def carry(self, change: ChangeSet, version: int) -> None:
        """``change`` took the store from ``version`` to ``version + 1``: forget what it touched."""
        if version != self.version:
            self.clear()
            return
        for s, p, o in (*change.added, *change.removed):
            self.outgoing.pop(s, None)
            for kept in self.incoming.values():
                kept.pop(o, None)
            if p == RDFS.subClassOf:
                self.axioms = None
        self.version = version + 1


class CandidateView:
    """Reads of the state the store would have after ``change``, without writing it; ``cache``: what the store
    holds around nodes at its head, where the caller knows the head (``Neighbourhood``)."""

    def __init__(self, backend: Backend, change: ChangeSet, cache: Neighbourhood | None = None) -> None:
        self.backend = backend
        self.change = change
        self.cache = cache
        self._added_by_s: dict[Node, set[Triple]] = {}
        self._added_by_o: dict[Node, set[Triple]] = {}
        for t in change.added:
            self._added_by_s.setdefault(t[0], set()).add(t)
            self._added_by_o.setdefault(t[2], set()).add(t)

    def _stored(self, nodes: list[Node], kept: dict[Node, frozenset[Triple]] | None, side: int,
                query: Callable[[str], str]) -> set[Triple]:
        """The stored triples with ``nodes`` at position ``side`` (0: subject, 2: object), from ``kept`` where it
        has them, the rest read (``query(values)``) and kept."""
        missing = nodes if kept is None else [n for n in nodes if n not in kept]
        out: set[Triple] = set()
        for batch in _chunks(missing):
            out |= self.backend.triples(query(" ".join(n3(n) for n in batch)))
        if kept is not None:
            per: dict[Node, set[Triple]] = {n: set() for n in missing}
            for t in out:
                if t[side] in per:
                    per[t[side]].add(t)
            kept.update((n, frozenset(ts)) for n, ts in per.items())
            for n in nodes:
                out |= kept[n]
        return out

    def outgoing(self, nodes: Iterable[Node]) -> set[Triple]:
        nodes = [n for n in nodes if isinstance(n, URIRef)]
        out = self._stored(nodes, self.cache.outgoing if self.cache is not None else None, 0,
                           lambda values: f"CONSTRUCT {{ ?s ?p ?o }} WHERE {{ VALUES ?s {{ {values} }} ?s ?p ?o }}")
        out -= self.change.removed
        for n in nodes:
            out |= self._added_by_s.get(n, set())
        return out

    def incoming(self, nodes: Iterable[Node], predicates: Iterable[URIRef] | None = None) -> set[Triple]:
        """Edges pointing at ``nodes``, except ``rdf:type`` (every instance points at its class)."""
        nodes = [n for n in nodes if isinstance(n, URIRef)]
        preds = frozenset(predicates) if predicates is not None else None
        if preds is not None and not preds:
            return set()
        pred_filter = (
            f"VALUES ?p {{ {' '.join(n3(p) for p in sorted(preds))} }}" if preds is not None else f"FILTER (?p != {n3(RDF.type)})"
        )
        out = self._stored(nodes, self.cache.incoming.setdefault(preds, {}) if self.cache is not None else None, 2,
                           lambda values: f"CONSTRUCT {{ ?s ?p ?o }} WHERE {{ VALUES ?o {{ {values} }} ?s ?p ?o . {pred_filter} }}")
        out -= self.change.removed
        for n in nodes:
            for t in self._added_by_o.get(n, set()):
                if t[1] != RDF.type and (preds is None or t[1] in preds):
                    out.add(t)
        return out

    def subclass_axioms(self) -> set[Triple]:
        stored = self.cache.axioms if self.cache is not None else None
        if stored is None:
            stored = frozenset(self.backend.triples(
                f"CONSTRUCT {{ ?a {n3(RDFS.subClassOf)} ?b }} WHERE {{ ?a {n3(RDFS.subClassOf)} ?b }}"))
            if self.cache is not None:
                self.cache.axioms = stored
        out = set(stored) - self.change.removed
        out |= {t for t in self.change.added if t[1] == RDFS.subClassOf}
        return out


@dataclass(frozen=True)
class Shapes:
    """The shapes graph as pySHACL needs it, and the nodes it is made of as the store names them.

    The store holds shapes skolemised; pySHACL tells complex paths (``sh:path ( a b )``,
    ``[ sh:inversePath p ]``) from predicates by their being blank nodes, so ``graph`` has the skolem
    IRIs turned back into blank nodes.
    """

    graph: rdflib.Graph
    nodes: frozenset[Node]
    pyshacl_lock: threading.Lock = field(default_factory=threading.Lock, compare=False, repr=False)

    @functools.cached_property
    def token(self) -> str:
        """Names these shapes to a SHACL worker process (shacl_process.py), which keeps their shapes graph."""
        return uuid.uuid4().hex

    @functools.cached_property
    def pyshacl_graph(self) -> _ShapesGraph:
        """Built under ``pyshacl_lock``, by the first validation."""
        return _ShapesGraph(self.graph)

    def backward_predicates(self) -> set[URIRef]:
        return {o for o in self.graph.objects(None, NFEX.readsBackwardAlong) if isinstance(o, URIRef)}

    @functools.cached_property
    def footprint(self) -> frozenset[tuple[str, str | None]] | None:
        """What a shape can read beyond a focus node's own triples (kg/footprint.py pairs): every predicate of a
        property path, a target or a property-pair constraint, those of ``nfex:readsBackwardAlong``, types and
        the class hierarchy, and the footprint of every SPARQL constraint; None (anything) where a shape is
        ``sh:closed`` or a constraint's query has no footprint. ``validate_change`` walks back only from the
        subjects of changed triples that fall in it: a change of anything else can alter no other node's verdict."""
        g = self.graph
        if any(g.objects(None, SH.closed)):
            return None
        found: set[tuple[str, str | None]] = {(str(RDF.type), None), (str(RDFS.subClassOf), None)}

        def path(node: Node, seen: set[Node]) -> None:
            if isinstance(node, URIRef):
                if node != RDF.nil:
                    found.add((str(node), None))
                return
            if node in seen:
                return
            seen.add(node)
            for p, o in g.predicate_objects(node):
                if p in (SH.inversePath, SH.alternativePath, SH.zeroOrMorePath, SH.oneOrMorePath, SH.zeroOrOnePath,
                         RDF.first, RDF.rest):
                    path(o, seen)

        for o in g.objects(None, SH.path):
            path(o, set())
        for p in (SH.targetSubjectsOf, SH.targetObjectsOf, SH.equals, SH.disjoint, SH.lessThan, SH.lessThanOrEquals,
                  NFEX.readsBackwardAlong):
            found |= {(str(o), None) for o in g.objects(None, p) if isinstance(o, URIRef)}
        for p in (SH.select, SH.ask):
            for text in g.objects(None, p):
                fp = footprint(prefix_block() + str(text))
                if fp is None:
                    return None
                found |= fp
        return frozenset(found)


def shapes_closure(roots: set[Node], outgoing: Callable[[set[Node]], Iterable[Triple]]) -> Shapes:
    """Every triple reachable from ``roots`` through anonymous (skolemised or blank) nodes."""
    triples: set[Triple] = set()
    seen: set[Node] = set()
    frontier = set(roots)
    while frontier:
        seen |= frontier
        nxt: set[Node] = set()
        for t in outgoing(frontier):
            triples.add(t)
            if (is_skolem(t[2]) or isinstance(t[2], BNode)) and t[2] not in seen:
                nxt.add(t[2])
        frontier = nxt
    bnodes: dict[Node, BNode] = {}

    def anon(term: Node) -> Node:
        return bnodes.setdefault(term, BNode()) if is_skolem(term) else term

    g = rdflib.Graph()
    g.bind("nfex", NFEX)
    g.bind("sh", SH)
    for s, p, o in triples:
        g.add((anon(s), p, anon(o)))
    return Shapes(g, frozenset(seen))


def extract_shapes(backend: Backend) -> Shapes:
    """The shapes stored in the knowledge graph: every shape and what hangs off it."""
    roots = backend.select(
        "SELECT DISTINCT ?s WHERE { "
        f"{{ ?s a {n3(SH.NodeShape)} }} UNION {{ ?s a {n3(SH.PropertyShape)} }} UNION {{ ?s {n3(SH.declare)} ?d }} }}"
    )

    def outgoing(nodes: set[Node]) -> Iterable[Triple]:
        for batch in _chunks(n for n in nodes if isinstance(n, URIRef)):
            values = " ".join(n3(n) for n in batch)
            yield from backend.construct(f"CONSTRUCT {{ ?s ?p ?o }} WHERE {{ VALUES ?s {{ {values} }} ?s ?p ?o }}")

    return shapes_closure({r["s"] for r in roots.rows}, outgoing)


def shapes_in(graph: rdflib.Graph) -> Shapes:
    """The shapes contained in an in-memory graph (a candidate state)."""
    roots = set(graph.subjects(RDF.type, SH.NodeShape)) | set(graph.subjects(RDF.type, SH.PropertyShape))
    roots |= set(graph.subjects(SH.declare, None))
    return shapes_closure(roots, lambda nodes: (t for n in nodes for t in graph.triples((n, None, None))))


def touches_shapes(change: ChangeSet, shapes: Shapes) -> bool:
    sh = str(SH)
    for s, p, o in change.added | change.removed:
        if s in shapes.nodes or str(p).startswith(sh) or (p == RDF.type and str(o).startswith(sh)):
            return True
    return False


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
