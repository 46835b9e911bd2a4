"""Operations a client's SPARQL may not contain, found before any store sees the text.

A SPARQL Update may ``LOAD`` a URL (the store fetches it: server-side request forgery), ``CLEAR`` /
``DROP`` a graph (thirty thousand triples in one commit, the version history included), or ``CREATE``,
``ADD``, ``MOVE`` and ``COPY`` named graphs, which hold nFEX's history; a query or an update may call
``SERVICE`` (the store fetches a URL again). None of these is evaluated, not even on a scratch copy:
pyoxigraph and SPARQL servers would fetch while evaluating.

The check is lexical and exact for these words: in the SPARQL 1.1 grammar (§19.8) they are keywords
that appear nowhere else, so one is present iff it occurs as a bare word once strings, IRIs, comments,
variables, prefixed names and blank-node labels are set aside. Codepoint escapes (``\\u004C`` = ``L``,
§19.2) are decoded first, as a conforming parser does. The scan is linear and costs microseconds, so
the read-only endpoint runs it on every query.
"""
from __future__ import annotations

import re
from collections.abc import Iterator
from typing import TYPE_CHECKING

from rdflib.namespace import SH
from rdflib.term import Literal

from ..errors import BadInput
from ..namespaces import NFEX

if TYPE_CHECKING:
    from .changes import ChangeSet

FORBIDDEN_UPDATES = ("LOAD", "CLEAR", "DROP", "CREATE", "ADD", "MOVE", "COPY", "SERVICE")
FORBIDDEN_QUERY = ("SERVICE",)
# predicates whose literal is SPARQL that nFEX or pySHACL evaluates: pruning rules, SHACL-SPARQL constraints
EXECUTED_TEXT = (NFEX.query, SH.select, SH.ask, SH.construct, SH.update)

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


class ForbiddenOperation(BadInput):
    """The SPARQL text contains an operation nFEX never runs for a client."""

    status = 403
    type = "forbidden-operation"
    title = "Forbidden SPARQL operation"


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


def keywords(text: str) -> list[str]:
    """The bare words of ``text`` (upper-cased), in order: keywords, function names, ``a``."""
    return [m.group("word").upper() for m in tokens(text) if m.lastgroup == "word"]


def forbidden_in(text: str, forbidden: tuple[str, ...]) -> list[str]:
    """The ``forbidden`` operations that ``text`` contains, each once, in order of appearance."""
    found: list[str] = []
    for word in keywords(text):
        if word in forbidden and word not in found:
            found.append(word)
    return found


def refuse_unsafe_update(update: str) -> None:
    """Raise ForbiddenOperation (403) naming each forbidden operation in ``update``."""
    found = forbidden_in(update, FORBIDDEN_UPDATES)
    if found:
        raise ForbiddenOperation(
            f"SPARQL Update may not use {', '.join(found)}: nFEX never fetches URLs for a client (LOAD, SERVICE) "
            "nor clears, drops, creates, adds, moves or copies graphs (the named graphs hold the version history); "
            "use INSERT/DELETE DATA or DELETE/INSERT … WHERE on the default graph",
            operations=found,
        )


def refuse_unsafe_query(query: str) -> None:
    """Raise ForbiddenOperation (403) when ``query`` calls a remote endpoint (SERVICE)."""
    found = forbidden_in(query, FORBIDDEN_QUERY)
    if found:
        raise ForbiddenOperation(
            "SPARQL queries may not use SERVICE: nFEX never fetches URLs for a client (federated queries are off)",
            operations=found,
        )


def refuse_unsafe_change(change: ChangeSet) -> None:
    """Refuse a write that stores SPARQL text nFEX would later run (a rule's ``nfex:query``, a SHACL
    constraint's ``sh:select``/``sh:ask``) containing SERVICE or an update operation."""
    for _, p, o in change.added:
        if p in EXECUTED_TEXT and isinstance(o, Literal):
            found = forbidden_in(str(o), FORBIDDEN_UPDATES)
            if found:
                raise ForbiddenOperation(
                    f"the change stores SPARQL ({p}) that uses {', '.join(found)}; nFEX runs stored rules and "
                    "shapes itself and never fetches URLs or touches named graphs for them",
                    operations=found,
                )
