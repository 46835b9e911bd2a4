"""RDF terms across the boundaries: pyoxigraph, SPARQL JSON results, SPARQL text, skolem IRIs.

rdflib terms are the lingua franca of nfex_core. Two normalisations keep term equality exact across
a round trip through any store: a literal typed ``xsd:string`` becomes a plain literal (RDF 1.1 makes
them the same term, rdflib does not), and blank nodes are skolemised (RDF 1.1 Concepts §3.5) because a
blank node cannot be addressed by a later request — a DELETE of a blank node matches nothing.
"""
from __future__ import annotations

import hashlib
from collections.abc import Callable, Iterable, Iterator
from decimal import Decimal
from typing import Any

import pyoxigraph as ox
import rdflib
from rdflib.compare import to_canonical_graph
from rdflib.namespace import XSD
from rdflib.term import BNode, Literal, Node, URIRef

from .namespaces import GENID

Triple = tuple[Node, Node, Node]
XSD_STRING = ox.NamedNode(str(XSD.string))


_INTEGERS = {XSD.integer, XSD.int, XSD.long, XSD.short, XSD.byte, XSD.nonNegativeInteger, XSD.positiveInteger,
             XSD.nonPositiveInteger, XSD.negativeInteger, XSD.unsignedInt, XSD.unsignedLong}


def plain(lit: Literal) -> Literal:
    """One lexical form per value, so the same literal compares equal wherever it was read from.

    Stores canonicalise differently (Oxigraph writes ``"0.0"^^xsd:decimal`` as ``"0"`` per XSD 1.1;
    rdflib keeps XSD 1.0's ``"0.0"``). Literals typed xsd:string become plain literals (RDF 1.1 makes
    them one term). Ill-typed lexical forms are kept as they are.
    """
    dt = lit.datatype
    if dt is None or lit.language:
        return lit
    if dt == XSD.string:
        return Literal(str(lit))
    try:
        if dt in _INTEGERS:
            return Literal(str(int(str(lit).strip())), datatype=dt)
        if dt == XSD.decimal:
            value = Decimal(str(lit).strip())
            if not value.is_finite():
                return lit
            text = str(int(value)) if value == value.to_integral_value() else format(value.normalize(), "f")
            return Literal(text, datatype=dt)
        if dt in (XSD.double, XSD.float):
            return Literal(repr(float(str(lit).strip())), datatype=dt)
        if dt == XSD.boolean:
            text = str(lit).strip()
            if text in ("true", "1"):
                return Literal("true", datatype=dt)
            if text in ("false", "0"):
                return Literal("false", datatype=dt)
    except (ValueError, ArithmeticError):
        return lit
    return lit


def from_oxigraph(term: object, *, as_written: bool = False) -> Node:
    """An Oxigraph term as rdflib's; a literal ``plain``, or ``as_written`` (as rdflib's parsers give it:
    skolemising hashes a blank node's neighbours as written, so a file must read the same either way)."""
    if isinstance(term, ox.NamedNode):
        return URIRef(term.value)
    if isinstance(term, ox.BlankNode):
        return BNode(term.value)
    if isinstance(term, ox.Literal):
        if term.language:
            return Literal(term.value, lang=term.language)
        if as_written:
            return Literal(term.value) if term.datatype == XSD_STRING else Literal(term.value, datatype=URIRef(term.datatype.value))
        return plain(Literal(term.value, datatype=URIRef(term.datatype.value)))
    raise TypeError(f"unsupported term {term!r}")


def to_oxigraph(term: Node) -> ox.NamedNode | ox.Literal:
    """An rdflib IRI or literal as Oxigraph's, the literal ``plain`` (as ``n3`` writes it); ValueError for a blank
    node, or a term Oxigraph refuses."""
    if isinstance(term, URIRef):
        return ox.NamedNode(term)
    if isinstance(term, Literal):
        lit = plain(term)
        if lit.language:
            return ox.Literal(str(lit), language=lit.language)
        return ox.Literal(str(lit), datatype=ox.NamedNode(lit.datatype)) if lit.datatype is not None else ox.Literal(str(lit))
    raise ValueError(f"blank node {term} cannot be written to the store; skolemise first")


_CONVERTED: dict[bool, dict[object, Node]] = {False: {}, True: {}}  # term_converter's memo, per as_written
CONVERTED_MAX = 100_000  # terms remembered per mode; then the memo starts again
LONG_LITERAL = 200  # characters: a longer literal (a rule's query, a comment) is converted each time, not kept


def term_converter(*, as_written: bool = False) -> Callable[[object], Node]:
    """``from_oxigraph`` that converts each distinct term once, for the life of the process: the same predicates,
    classes, extractors, parameters and reasons come back row after row and read after read (a commit's
    validation reads its configuration's neighbourhood again; a compile, the same rules' answers), and rdflib's
    term constructors (``plain`` builds a literal twice) were most of a read's time. rdflib terms are immutable,
    so sharing them is safe; a full memo is emptied, not evicted term by term."""
    terms = _CONVERTED[as_written]

    def convert(term: object) -> Node:
        found = terms.get(term)
        if found is None:
            found = from_oxigraph(term, as_written=as_written)
            if isinstance(term, ox.Literal) and len(term.value) > LONG_LITERAL:  # a rule's text, a note: not kept
                return found
            if len(terms) >= CONVERTED_MAX:
                terms.clear()
            terms[term] = found
        return found

    return convert


def oxigraph_triples(items: Iterable[Any], *, as_written: bool = False) -> Iterator[Triple]:
    """Oxigraph's triples or quads (their default-graph part) as rdflib triples (``term_converter``)."""
    term = term_converter(as_written=as_written)
    return ((term(t.subject), term(t.predicate), term(t.object)) for t in items)


def from_sparql_json(b: dict[str, str]) -> Node:
    kind = b["type"]
    if kind == "uri":
        return URIRef(b["value"])
    if kind == "bnode":
        return BNode(b["value"])
    if "xml:lang" in b:
        return Literal(b["value"], lang=b["xml:lang"])
    dt = b.get("datatype")
    if dt:
        return plain(Literal(b["value"], datatype=URIRef(dt)))
    return Literal(b["value"])


def py(term: object) -> Any:
    """A SPARQL result term as a Python value (a literal's value; an IRI or blank node as it is)."""
    return term.toPython() if isinstance(term, Literal) else term


def n3(term: Node) -> str:
    """A term in SPARQL/N-Triples syntax."""
    if isinstance(term, URIRef):
        return f"<{term}>"
    if isinstance(term, Literal):
        return plain(term).n3()
    raise ValueError(f"blank node {term} cannot be written to the store; skolemise first")


def triple_n3(t: Triple) -> str:
    return f"{n3(t[0])} {n3(t[1])} {n3(t[2])} ."


_NT_ESCAPES = str.maketrans({"\\": "\\\\", '"': '\\"', "\n": "\\n", "\r": "\\r"})


def nt(term: Node) -> str:
    """A term in N-Triples syntax: on one line, which ``n3`` (long strings) does not promise."""
    if isinstance(term, URIRef):
        return f"<{term}>"
    if isinstance(term, Literal):
        lit = plain(term)
        text = f'"{str(lit).translate(_NT_ESCAPES)}"'
        if lit.language:
            return f"{text}@{lit.language}"
        return f"{text}^^<{lit.datatype}>" if lit.datatype is not None else text
    raise ValueError(f"blank node {term} cannot be written to the store; skolemise first")


def triple_nt(t: Triple) -> str:
    """One N-Triples line (also a SPARQL triple: INSERT DATA takes it as it is)."""
    return f"{nt(t[0])} {nt(t[1])} {nt(t[2])} ."


def normalise(graph: Iterable[Triple]) -> set[Triple]:
    """Triples with plain literals; blank nodes must already be skolemised."""
    out: set[Triple] = set()
    for s, p, o in graph:
        if isinstance(s, BNode) or isinstance(o, BNode):
            raise ValueError("normalise() needs a skolemised graph")
        out.add((s, p, plain(o) if isinstance(o, Literal) else o))
    return out


def skolemise(graph: Iterable[Triple]) -> list[Triple]:
    """Replace blank nodes by IRIs that depend only on what surrounds them.

    Blank nodes are grouped into connected components; each component, with the triples that touch
    it, is relabelled canonically (rdflib.compare, after Hogan's algorithm) and its IRIs are hashes of
    those canonical labels. So the same description skolemises to the same IRIs every time, whatever
    else the file or the seed contains: adding and later removing a file with blank nodes addresses the
    same nodes, and editing one part of the ontology does not rename blank nodes elsewhere.
    Triples without blank nodes pass through as they are (an rdflib Graph is never copied: at the seed's
    33k triples that copy cost more than the parse).
    """
    out: list[Triple] = []
    touching: list[Triple] = []
    for t in graph:
        (touching if isinstance(t[0], BNode) or isinstance(t[2], BNode) else out).append(t)
    if not touching:
        return out
    parent: dict[Node, Node] = {}

    def find(x: Node) -> Node:
        while parent.setdefault(x, x) != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    for s, _, o in touching:
        if isinstance(s, BNode) and isinstance(o, BNode):
            parent[find(s)] = find(o)
    components: dict[Node, rdflib.Graph] = {}
    for t in touching:
        b = t[0] if isinstance(t[0], BNode) else t[2]
        components.setdefault(find(b), rdflib.Graph()).add(t)

    for component in components.values():
        canon = to_canonical_graph(component)
        # canonical labels are only unique within a component: qualify them by its content
        digest = hashlib.sha1("\n".join(sorted(" ".join(x.n3() for x in t) for t in canon)).encode()).hexdigest()

        def sk(t: Node, digest: str = digest) -> Node:
            if isinstance(t, BNode):
                return URIRef(GENID + hashlib.sha1((digest + str(t)).encode()).hexdigest()[:20])
            return t

        out.extend((sk(s), p, sk(o)) for s, p, o in canon)
    return out


def is_skolem(term: Node) -> bool:
    return isinstance(term, URIRef) and str(term).startswith(GENID)
