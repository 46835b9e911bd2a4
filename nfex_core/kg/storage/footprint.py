"""What a SPARQL query can read: its *footprint*, the (predicate, object) pairs of the triples it can match.

Every triple pattern of a SPARQL query has a predicate, or a property path of predicates; a pattern whose
predicate is a constant p matches triples with predicate p only (and, for ``?x a C``, object C only). So the
answer of a query with a footprint is a function of the graph's triples that match it, and a change that adds
or removes none of those leaves the answer as it was. The rule engine keeps a SPARQL rule's last hits on that
ground (rules/engine.py), and the observation index reads nothing again for a change that misses the
observations' queries (evidence/index.py).

A footprint is blind to subjects: every report adds ``?m a nfex:Measurement ; nfex:underCondition …``, so a rule
that counts Measurements under agent = car and motion = fast reads every report. ``anchors`` keeps, for each
pattern, the *star* of its subject: the constant triples ``?m p o`` its basic graph pattern asks of that same
variable. A solution of a BGP that binds ?m to s uses a triple t = (s, p, o) only if s has the whole star in that
graph, so a changed triple matters to the BGP only where its subject has the star — after the change for an added
triple, before it for a removed one (``change_effect``). The answer of a query is a function of its BGPs'
solutions (SPARQL 1.1 §18.5: the graph is read at BGPs and property paths only), so a change that alters no
BGP's solutions leaves it as it was. Only a pattern's first step is anchored to its subject: the later steps of
``p1/p2``, an inverse or repeated path are not (any triple of their predicate matters). A constant subject or
object narrows a pattern to the triples that have it. ``Reach`` is the union of a query set's patterns: the
triples they can read at all. A path that may be of length zero (``p*``, ``p?``) between two variables matches
every node of the graph to itself, so a query with one has no footprint.

Each pattern also has a *sign*: how the answer moves when its BGP's solutions grow. Join, union, filter, BIND,
projection and DISTINCT are monotone, so at the top a pattern's sign is +1; the right side of a MINUS flips it (a
solution there takes rows out); the right side of an OPTIONAL, an aggregate, a LIMIT/OFFSET or an EXISTS make it
0 (either way). A change whose every triple that matters (star held) adds to a pattern of sign −1 or removes from
one of sign +1 can only take rows out of the answer (``change_effect``: ``SHRINKS``); so an answer that was empty
stays empty — a prior that has yielded to evidence stays silent however much more evidence comes (rules/engine.py).
"""
from __future__ import annotations

import enum
import functools
from collections.abc import Callable, Collection, Iterable, Set
from dataclasses import dataclass

from pyparsing import ParseResults
from rdflib.namespace import RDF
from rdflib.paths import AlternativePath, InvPath, MulPath, SequencePath
from rdflib.plugins.sparql.algebra import translateGroupGraphPattern
from rdflib.plugins.sparql.parserutils import CompValue
from rdflib.term import BNode, Node, URIRef, Variable

from ..rdf.rdflib_sparql import prepare_query
from ..rdf.terms import Triple
from .backends import GraphReader, SelectResult
from .history import prefix_block

Footprint = frozenset[tuple[str, str | None]]  # (predicate, object or None: any)
_OPAQUE = {"TriplesBlock", "ServiceGraphPattern", "Graph"}  # patterns not in algebra form, or not of the default graph


@dataclass(frozen=True)
class Anchor:
    """A triple pattern's reach: triples of ``predicate`` (and ``object``, ``subject``, where constant), which matter
    only where their subject has every (predicate, object) of ``star`` (empty: any subject)."""

    predicate: URIRef
    object: URIRef | None
    star: frozenset[tuple[URIRef, URIRef]]
    subject: URIRef | None = None
    sign: int = 1  # +1: the answer grows with its BGP's solutions, −1: it shrinks, 0: either (module docstring)

    def matches(self, t: tuple[Node, Node, Node]) -> bool:
        return t[1] == self.predicate and (self.object is None or t[2] == self.object) and (self.subject is None or t[0] == self.subject)


@dataclass(frozen=True)
class Reach:
    """The triples a set of queries can read — every triple some pattern of theirs can match (their anchors, stars
    aside) — so that a graph holding just these answers each query as the whole graph does: the rules' evidence
    view copies only these (evidence/view.py)."""

    predicates: frozenset[URIRef]  # any subject and object
    objects: frozenset[tuple[URIRef, URIRef]]  # (predicate, object)
    subjects: frozenset[tuple[URIRef, URIRef]]  # (subject, predicate)

    @classmethod
    def of(cls, anchors: Iterable[Anchor]) -> Reach:
        found = list(anchors)
        predicates = frozenset(a.predicate for a in found if a.object is None and a.subject is None)
        subjects = frozenset((a.subject, a.predicate) for a in found if a.subject is not None and a.predicate not in predicates)
        objects = frozenset((a.predicate, a.object) for a in found
                            if a.object is not None and a.subject is None and a.predicate not in predicates)
        return cls(predicates, objects, subjects)

    def holds(self, t: tuple[Node, Node, Node]) -> bool:
        s, p, o = t
        return p in self.predicates or (p, o) in self.objects or (s, p) in self.subjects

    def pattern(self) -> str:
        """A SPARQL group pattern binding ?s ?p ?o to the triples in reach."""
        parts = []
        if self.predicates:
            parts.append(f"{{ VALUES ?p {{ {' '.join(f'<{p}>' for p in sorted(self.predicates))} }} ?s ?p ?o }}")
        if self.objects:
            parts.append(f"{{ VALUES (?p ?o) {{ {' '.join(f'(<{p}> <{o}>)' for p, o in sorted(self.objects))} }} ?s ?p ?o }}")
        if self.subjects:
            parts.append(f"{{ VALUES (?s ?p) {{ {' '.join(f'(<{s}> <{p}>)' for s, p in sorted(self.subjects))} }} ?s ?p ?o }}")
        return " UNION ".join(parts) if parts else "{ FILTER (false) }"


@dataclass(frozen=True)
class Delta:
    """What a change added and removed, triple by triple (rdflib terms)."""

    added: frozenset[tuple[Node, Node, Node]]
    removed: frozenset[tuple[Node, Node, Node]]

    def pairs(self) -> frozenset[tuple[str, str]]:
        return pairs(self.added) | pairs(self.removed)


@functools.lru_cache(maxsize=256)
def anchors(query: str) -> tuple[Anchor, ...] | None:
    """Each triple pattern of ``query`` with the star of its subject and its sign (module docstring); None where that
    cannot be told (``footprint``)."""
    try:
        algebra = prepare_query(query).algebra
    except Exception:
        return None
    anchors: set[Anchor] = set()
    opaque = False

    def predicates(path: object, star: frozenset[tuple[URIRef, URIRef]], sign: int, obj: URIRef | None = None,
                   subj: URIRef | None = None) -> bool:
        """Note ``path``'s predicates; ``star``: what its first step's subject must have (empty: nothing known);
        ``obj``: the pattern's constant object, for a plain predicate; ``subj``: its constant subject, for a first step."""
        if isinstance(path, URIRef):
            anchors.add(Anchor(path, obj, star, subj, sign))
            return True
        none: frozenset[tuple[URIRef, URIRef]] = frozenset()
        if isinstance(path, SequencePath):  # paths are monotone in their triples: the pattern's sign
            return predicates(path.args[0], star, sign, None, subj) and all(predicates(a, none, sign) for a in path.args[1:])
        if isinstance(path, AlternativePath):
            return all(predicates(a, star, sign, None, subj) for a in path.args)
        if isinstance(path, InvPath):
            return predicates(path.arg, none, sign)
        if isinstance(path, MulPath):
            return predicates(path.path, none, sign)
        return False  # a variable, a negated property set

    def bgp(node: CompValue, sign: int) -> None:
        nonlocal opaque
        stars: dict[Node, set[tuple[URIRef, URIRef]]] = {}
        for s, p, o in node.triples:
            if isinstance(s, Variable | BNode) and isinstance(p, URIRef) and isinstance(o, URIRef):
                stars.setdefault(s, set()).add((p, o))
        for s, p, o in node.triples:
            if not predicates(p, frozenset(stars.get(s, ())), sign, o if isinstance(o, URIRef) else None,
                              s if isinstance(s, URIRef) else None):
                opaque = True
            # a path that may be of length zero between two variables matches every node of the graph to itself
            if _nullable(p) and isinstance(s, Variable | BNode) and isinstance(o, Variable | BNode):
                opaque = True

    def walk(node: object, sign: int) -> None:
        nonlocal opaque
        if isinstance(node, list | tuple | ParseResults):
            for item in node:
                walk(item, sign)
            return
        if not isinstance(node, CompValue):
            return
        name = node.name
        if name in _OPAQUE:
            opaque = True
        elif name == "BGP":
            bgp(node, sign)
        elif name == "GroupGraphPatternSub":  # an EXISTS pattern, which rdflib leaves as parsed: translated here
            try:
                walk(translateGroupGraphPattern(node), 0)
            except Exception:
                opaque = True
        elif name == "Minus":
            walk(node.p1, sign)
            walk(node.p2, -sign)
        elif name == "LeftJoin":
            walk(node.p1, sign)
            walk(node.p2, 0)
            walk(node.get("expr"), 0)
        else:
            inner = 0 if name in _EITHER_WAY else sign
            for key, value in node.items():
                walk(value, 0 if key == "expr" else inner)  # a filter's or BIND's expression reads the graph only in an EXISTS

    walk(algebra, 1)
    return None if opaque else tuple(sorted(anchors, key=repr))


_EITHER_WAY = {"Group", "AggregateJoin", "Slice", "Builtin_EXISTS", "Builtin_NOTEXISTS"}  # what is below moves the answer either way


def _nullable(path: object) -> bool:
    """Whether ``path`` can be of length zero (``p*``, ``p?``, a sequence of such)."""
    if isinstance(path, MulPath):
        return path.zero or _nullable(path.path)
    if isinstance(path, SequencePath):
        return all(_nullable(a) for a in path.args)
    if isinstance(path, AlternativePath):
        return any(_nullable(a) for a in path.args)
    if isinstance(path, InvPath):
        return _nullable(path.arg)
    return False


@functools.lru_cache(maxsize=256)
def footprint(query: str) -> Footprint | None:
    """The triples ``query`` can read, as (predicate, object) pairs — the object only for ``rdf:type`` with a
    constant class, else None (any) — or None where that cannot be told (a variable predicate, a negated
    property set, a pattern rdflib's algebra leaves unparsed, a query rdflib cannot parse): its anchors, stars
    and subjects aside."""
    found = anchors(query)
    if found is None:
        return None
    return frozenset((str(a.predicate), str(a.object) if a.object is not None and a.predicate == RDF.type else None) for a in found)


Holds = Callable[[Set[tuple[URIRef, URIRef, URIRef]]], Set[tuple[URIRef, URIRef, URIRef]] | None]


class Effect(enum.Enum):
    """What a change can do to a query's answer (``change_effect``)."""

    NONE = "none"  # the answer is as it was
    SHRINKS = "shrinks"  # the answer after holds only rows it held before
    ANY = "any"


def change_effect(anchors: Iterable[Anchor], delta: Delta, holds: Holds) -> Effect:
    """What the change ``delta`` can do to the answer of a query with ``anchors``. A changed triple matters to a pattern
    it matches whose subject's star held, after the change for an added triple and before it for a removed one; none
    that matters: ``NONE``; each that matters adding to a pattern of sign −1 or removing from one of sign +1:
    ``SHRINKS``; else ``ANY``. ``holds(triples)``: which of ``triples`` the graph holds after the change (None: cannot
    tell); asked once, for the star triples the change itself does not settle (a triple it added is there after and
    not before; one it removed the other way round; any other is there before exactly when after)."""
    by_predicate: dict[URIRef, list[Anchor]] = {}
    for a in anchors:
        by_predicate.setdefault(a.predicate, []).append(a)
    moves: set[int] = set()  # how the answer moves with each change that matters: +1 grows, −1 shrinks, 0 either
    wanted: list[tuple[bool, frozenset[tuple[URIRef, URIRef, URIRef]], int]] = []  # (after?, a star on one subject, move)
    for after, triples in ((True, delta.added), (False, delta.removed)):
        for s, p, o in triples:
            for a in by_predicate.get(p, ()):  # type: ignore[call-overload]
                if not a.matches((s, p, o)):
                    continue
                move = a.sign if after else -a.sign
                if not a.star or not isinstance(s, URIRef):
                    moves.add(move)
                else:
                    wanted.append((after, frozenset((s, sp, so) for sp, so in a.star), move))
    pending = [w for w in wanted if w[2] not in moves]  # a star need not be asked where its move is already known
    unsettled = {t for _, star, _ in pending for t in star if t not in delta.added and t not in delta.removed}
    held = holds(unsettled) if unsettled else set()
    if held is None:
        return Effect.ANY
    for after, star, move in pending:
        there = (lambda t: t in delta.added or (t not in delta.removed and t in held)) if after \
            else (lambda t: t in delta.removed or (t not in delta.added and t in held))
        if all(there(t) for t in star):
            moves.add(move)
    if not moves:
        return Effect.NONE
    return Effect.SHRINKS if moves == {-1} else Effect.ANY



def pairs(triples: Iterable[Triple]) -> frozenset[tuple[str, str]]:
    """The (predicate, object) pairs of ``triples``: what ``reads`` compares with a footprint."""
    return frozenset((str(p), str(o)) for _, p, o in triples)


def reads(footprint: Footprint | None, touched: Collection[tuple[str, str]] | None) -> bool:
    """Whether a change of the (predicate, object) pairs ``touched`` (None: unknown) can change the answer of a
    query with ``footprint`` (``footprint``)."""
    if footprint is None or touched is None:
        return True
    return any((p, None) in footprint or (p, o) in footprint for p, o in touched)


class Recorder:
    """A ``GraphReader`` over ``reader`` that notes every query it passes on, so that what a loader read can be
    told afterwards: ``footprint()`` is the union of its queries' footprints (None when any has none, or when
    it asked nothing). ``KnowledgeGraph`` learns the vocabulary's this way and carries the vocabulary over a
    change that misses it — without a list of the loader's queries to keep in step with the loader."""

    def __init__(self, reader: GraphReader) -> None:
        self._reader = reader
        self.queries: list[str] = []

    @property
    def version(self) -> int:
        return self._reader.version

    def select(self, query: str, *, prefixes: bool = True) -> SelectResult:
        self.queries.append((prefix_block() if prefixes else "") + query)
        return self._reader.select(query, prefixes=prefixes)

    def footprint(self) -> Footprint | None:
        found: set[tuple[str, str | None]] = set()
        for query in self.queries:
            fp = footprint(query)
            if fp is None:
                return None
            found |= fp
        return frozenset(found) if self.queries else None
