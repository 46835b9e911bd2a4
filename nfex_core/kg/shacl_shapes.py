"""The shapes graph as the store holds it: extracted (skolemised shapes turned back into blank nodes), what a
change to it is, and what a shape can read beyond a focus node's own triples (``Shapes.footprint``).

validation.py validates writes with it (pySHACL through pyshacl_focus.py), rules/shape_check.py compiles the
context shapes from ``shapes_closure``.
"""
from __future__ import annotations

import functools
import threading
import uuid
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field

import rdflib
from rdflib.namespace import RDF, RDFS, SH
from rdflib.term import BNode, Node, URIRef

from .backends import Backend
from .candidate import chunks
from .changes import ChangeSet
from .footprint import footprint
from .history import prefix_block
from .namespaces import NFEX
from .pyshacl_focus import _ShapesGraph
from .terms import Triple, is_skolem, n3


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
        for batch in chunks(n for n in nodes if isinstance(n, URIRef)):
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


