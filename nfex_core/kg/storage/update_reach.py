"""What a SPARQL Update can read or remove: the triple patterns of its WHERE clauses, DELETE templates
and DELETE DATA blocks, so ``sparql_update`` copies only the triples matching them, not the whole graph.

Why that is exact. Let F be the default graph and S ⊆ F hold every triple of F that matches one of
these patterns (a variable, blank node or literal matches any term; ``reach`` keeps only IRIs as
constraints). Every triple pattern and property path of the update then has the same solutions over S
as over F, so every WHERE clause (OPTIONAL, MINUS, FILTER EXISTS, subqueries and aggregates are built
from those solutions), every deletion and every later operation's view of the earlier ones are the same.
The triples of F − S match none of the patterns: the update never reads or deletes them, and an
insertion of one of them is found afterwards by asking the store which inserted triples it already holds.
So (S after the update) − S, less what F holds, is what the update adds to F, and S − (S after) what it
removes. INSERT templates need no copy for the same reason.

Three kinds of pattern reach every triple, and the whole graph is copied as before: a pattern with no
IRI in it (``?s ?p ?o``, ``?s ?p "x"``), a negated property set (``!rdf:type``), and a path that can be
empty (``*``, ``?``) between two ends that are not IRIs (a zero-length path matches every node of the
graph). A path that can be empty with an IRI end also copies the triples around that IRI, so the copy
knows whether it is a node of the graph.

The patterns come from rdflib's SPARQL parser; Oxigraph still runs the update. Where the two could read
an IRI differently — a ``BASE``, ``\\u`` escapes, a backslash in a prefixed name — or rdflib cannot
parse the text, ``reach`` answers None and the caller copies everything (or reports Oxigraph's error).
An update made of ``INSERT DATA`` alone, recognised from its keywords, reads nothing.
"""
from __future__ import annotations

import re
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from typing import Any

import rdflib
from rdflib.paths import AlternativePath, InvPath, MulPath, NegatedPath, Path, SequencePath
from rdflib.term import BNode, Literal, URIRef, Variable

from ..rdf.rdflib_sparql import RDFLIB_SPARQL_PARSER
from ..rdf.terms import n3
from .backends import Backend

Pattern = tuple[URIRef | None, URIRef | None, URIRef | None]
"""A triple pattern to copy: None matches any term."""

INSERT_DATA_WORDS = frozenset({"PREFIX", "INSERT", "DATA", "A", "TRUE", "FALSE", "GRAPH"})
FETCH_ROWS = 200  # VALUES rows a copying query carries


class _Everything(Exception):
    """A pattern of the update can match every triple."""


@dataclass(frozen=True)
class Reach:
    """The patterns an update reads or deletes through (``everything``: the whole graph)."""

    patterns: frozenset[Pattern] = frozenset()
    everything: bool = False

    def fetch(self, backend: Backend) -> rdflib.Graph:
        """Every triple of the default graph matching one of the patterns."""
        if self.everything:
            return backend.construct("CONSTRUCT { ?s ?p ?o } WHERE { ?s ?p ?o }")
        out = rdflib.Graph()
        by_mask: dict[tuple[bool, bool, bool], list[Pattern]] = {}
        for p in self.patterns:
            by_mask.setdefault((p[0] is not None, p[1] is not None, p[2] is not None), []).append(p)
        for mask, patterns in sorted(by_mask.items()):
            names = [v for v, bound in zip(("?s", "?p", "?o"), mask, strict=True) if bound]
            for i in range(0, len(patterns), FETCH_ROWS):
                rows = " ".join(
                    "(" + " ".join(n3(t) for t in p if t is not None) + ")" for p in patterns[i : i + FETCH_ROWS]
                )
                out += backend.construct(
                    f"CONSTRUCT {{ ?s ?p ?o }} WHERE {{ VALUES ({' '.join(names)}) {{ {rows} }} ?s ?p ?o }}"
                )
        return out


EVERYTHING = Reach(everything=True)

# A lexical reading of SPARQL, enough to tell an update of INSERT DATA alone and text whose IRIs rdflib and
# Oxigraph could read differently; what may run at all is decided on the parse (sparql_gate.py).
_ESCAPE = re.compile(r"\\u([0-9A-Fa-f]{4})|\\U([0-9A-Fa-f]{8})")
# one alternative per token kind; only the last (a bare word) can be a keyword
_TOKEN = re.compile(
    r"""
      (?P<long>\"\"\"(?:[^"\\]|\\.|"(?!""))*(?:\"\"\"|$)|'''(?:[^'\\]|\\.|'(?!''))*(?:'''|$))
    | (?P<short>"(?:[^"\\\n\r]|\\.)*(?:"|$)|'(?:[^'\\\n\r]|\\.)*(?:'|$))
    | (?P<iri><[^<>"{}|^`\\\x00-\x20]*>)
    | (?P<comment>\#[^\n\r]*)
    | (?P<var>[?$][\w\u00B7\u0300-\u036F\u203F-\u2040]*)
    | (?P<bnode>_:[\w.\-\u00B7]*)
    | (?P<pname>[A-Za-z\u00C0-\uFFFF][\w.\-\u00B7]*:[\w.\-:%\\\u00B7]*|:[\w.\-:%\\\u00B7]*)
    | (?P<word>[A-Za-z_][\w\-]*)
    """,
    re.VERBOSE | re.DOTALL,
)



def decode_escapes(text: str) -> str:
    """SPARQL 1.1 §19.2: ``\\uXXXX`` and ``\\UXXXXXXXX`` stand for their code point anywhere in the text."""

    def sub(m: re.Match[str]) -> str:
        try:
            return chr(int(m.group(1) or m.group(2), 16))
        except (ValueError, OverflowError):
            return m.group(0)

    return _ESCAPE.sub(sub, text)


def tokens(text: str) -> Iterator[re.Match[str]]:
    """The tokens of ``text`` once its escapes are decoded; a token's kind is its match's ``lastgroup``
    (long, short, iri, comment, var, bnode, pname, word). Characters outside every kind are skipped."""
    return _TOKEN.finditer(decode_escapes(text))


def only_inserts_data(update: str) -> bool:
    """True when every operation of ``update`` is INSERT DATA: its bare words are those of INSERT DATA,
    PREFIX declarations and literals (``a``, ``true``, ``false``, language tags). Only a Modify
    (DELETE/INSERT … WHERE) reads the graph, and it needs the word WHERE."""
    for m in tokens(update):
        if m.lastgroup != "word" or (m.start() > 0 and m.string[m.start() - 1] == "@"):
            continue
        if m.group("word").upper() not in INSERT_DATA_WORDS:
            return False
    return True


def _ambiguous(update: str) -> bool:
    """Text where rdflib and Oxigraph could read an IRI differently (module docstring)."""
    if decode_escapes(update) != update:
        return True
    for m in tokens(update):
        if (m.lastgroup == "word" and m.group("word").upper() == "BASE") or (m.lastgroup == "pname" and "\\" in m.group()):
            return True
    return False


def reach(update: str) -> Reach | None:
    """The patterns ``update`` reads or deletes through; None when rdflib cannot parse it or could read
    its IRIs differently from Oxigraph (the caller then copies the whole graph)."""
    if only_inserts_data(update):
        return Reach()
    if _ambiguous(update):
        return None
    from rdflib.plugins.sparql.algebra import translateUpdate
    from rdflib.plugins.sparql.parser import parseUpdate

    try:
        with RDFLIB_SPARQL_PARSER:
            operations = translateUpdate(parseUpdate(update)).algebra
    except Exception:  # rdflib's parser raises several unrelated types
        return None
    patterns: set[Pattern] = set()
    try:
        for op in operations:
            if op.name == "InsertData":
                continue
            if op.name not in ("DeleteData", "DeleteWhere", "Modify"):
                raise _Everything
            # inserted triples are looked up in the store afterwards; the rest is read or deleted
            _collect({key: value for key, value in op.items() if key != "insert"}, patterns)
    except _Everything:
        return EVERYTHING
    return Reach(frozenset(patterns))


def _collect(node: Any, out: set[Pattern]) -> None:
    """Walk rdflib's algebra (and the parse trees it leaves inside EXISTS) for triple patterns."""
    if isinstance(node, dict):  # CompValue, Expr, and the quads of a template (graph → triples)
        for key, value in node.items():
            if key == "triples":
                _triples(value, out)
            else:
                _collect(value, out)
    elif isinstance(node, list | tuple | set | frozenset):
        for item in node:
            _collect(item, out)


def _triples(items: Iterable[Any], out: set[Pattern]) -> None:
    """A BGP's triples (3-tuples) or a parse tree's triples blocks (flat lists, three terms a triple)."""
    flat: list[Any] = []
    for item in items:
        if isinstance(item, tuple | list):
            flat.extend(item)
        else:
            raise _Everything
    if len(flat) % 3:
        raise _Everything
    for i in range(0, len(flat), 3):
        _pattern(flat[i], flat[i + 1], flat[i + 2], out)


def _constraint(term: Any) -> URIRef | None:
    if isinstance(term, URIRef):
        return term
    if isinstance(term, Variable | BNode | Literal):
        return None  # literals too: rdflib and Oxigraph canonicalise lexical forms differently
    raise _Everything


def _pattern(s: Any, p: Any, o: Any, out: set[Pattern]) -> None:
    subject, obj = _constraint(s), _constraint(o)
    if isinstance(p, Path):
        if _nullable(p):
            ends = [t for t in (subject, obj) if t is not None]
            if not ends:  # a zero-length path between two open ends: every node of the graph
                raise _Everything
            for end in ends:
                out.add((end, None, None))
                out.add((None, None, end))
        for iri in _path_iris(p):
            out.add((None, iri, None))
        return
    pattern = (subject, _constraint(p), obj)
    if pattern == (None, None, None):
        raise _Everything
    out.add(pattern)


def _path_iris(path: Any) -> set[URIRef]:
    if isinstance(path, URIRef):
        return {path}
    if isinstance(path, InvPath):
        return _path_iris(path.arg)
    if isinstance(path, SequencePath | AlternativePath):
        return set().union(*(_path_iris(a) for a in path.args))
    if isinstance(path, MulPath):
        return _path_iris(path.path)
    raise _Everything  # a negated property set matches triples of every other predicate


def _nullable(path: Any) -> bool:
    """Whether ``path`` matches a zero-length path (a node to itself)."""
    if isinstance(path, URIRef | NegatedPath):
        return False
    if isinstance(path, InvPath):
        return _nullable(path.arg)
    if isinstance(path, SequencePath):
        return all(_nullable(a) for a in path.args)
    if isinstance(path, AlternativePath):
        return any(_nullable(a) for a in path.args)
    if isinstance(path, MulPath):
        return bool(path.zero) or _nullable(path.path)
    raise _Everything
