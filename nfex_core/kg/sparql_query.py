"""Small facts about SPARQL text: the prefixes nFEX predeclares, and parse errors placed in the user's lines.

Used at the edges (CLI, HTTP endpoint) to let users write ``nfex:ORB`` without a PREFIX line. What a text is and
whether it may run is the gate's to say (sparql_gate.py).
"""
from __future__ import annotations

import re
from collections.abc import Callable

from ..errors import BadInput, ParseError
from .namespaces import PREFIXES

_DECLARED = re.compile(r"PREFIX\s+([A-Za-z0-9_.-]*):", re.IGNORECASE)


def strip_comments(text: str) -> str:
    """Remove ``#`` comments, leaving ``#`` inside IRIs and strings alone."""
    out: list[str] = []
    in_iri = False
    quote: str | None = None
    i = 0
    while i < len(text):
        c = text[i]
        if quote:
            out.append(c)
            if c == "\\" and i + 1 < len(text):
                out.append(text[i + 1])
                i += 2
                continue
            if c == quote:
                quote = None
        elif in_iri:
            out.append(c)
            if c == ">":
                in_iri = False
        elif c == "#":
            while i < len(text) and text[i] != "\n":
                i += 1
            continue
        else:
            if c in "\"'":
                quote = c
            elif c == "<" and i + 1 < len(text) and not text[i + 1].isspace() and text[i + 1] not in "=":
                in_iri = True
            out.append(c)
        i += 1
    return "".join(out)


def prefix_head(query: str) -> str:
    """The PREFIX lines for nFEX's namespaces ``query`` does not declare itself."""
    declared = {m.group(1) for m in _DECLARED.finditer(strip_comments(query))}
    return "".join(f"PREFIX {p}: <{ns}>\n" for p, ns in PREFIXES.items() if p not in declared)


def with_prefixes(query: str) -> str:
    """``query`` with PREFIX lines for nFEX's namespaces it does not declare itself."""
    return prefix_head(query) + query


# "error at 2:9" (Oxigraph, embedded and server), "line 3, column 5" (Jena), "line 3:" (Virtuoso)
_AT = re.compile(r"\bat (\d+):(\d+)")
_LINE = re.compile(r"\bline (\d+)(?:, column (\d+))?", re.IGNORECASE)


def at_user_lines(error: ParseError, query: str) -> ParseError:
    """``error``, raised parsing ``with_prefixes(query)``, with its positions in the lines of ``query``.

    The hidden PREFIX lines shift every line number a parser reports; this moves them back (and sets
    the problem's ``line``/``column``), so a user reads the position in the text they wrote."""
    hidden = prefix_head(query).count("\n")
    found: list[tuple[int, int | None]] = []

    def shift(m: re.Match[str]) -> str:
        line = int(m.group(1)) - hidden
        if line < 1:
            return m.group(0)
        column = int(m.group(2)) if m.group(2) else None
        found.append((line, column))
        return m.group(0).replace(m.group(1), str(line), 1)

    detail = _LINE.sub(shift, _AT.sub(shift, error.detail))
    if not found:
        return error
    line, column = found[0]
    if column is None:  # a server that names only the line (Virtuoso): Oxigraph's parser finds the column
        local = _oxigraph_position(with_prefixes(query))
        if local is not None and local[0] - hidden == line:
            column = local[1]
            detail += f" (at {line}:{column})"
    extra = {k: v for k, v in error.extra.items() if k not in ("line", "column")}
    return ParseError(detail, line=line, column=column, **extra)


def _oxigraph_position(text: str) -> tuple[int, int] | None:
    """Where Oxigraph's SPARQL 1.1 parser stops on ``text`` (a query or an update), or None where it parses.

    Only called on an error path; the text runs against an empty in-memory store, so nothing is read or changed."""
    import pyoxigraph

    from .sparql_gate import gate_query

    store = pyoxigraph.Store()
    run: Callable[[str], object]
    try:
        gate_query(text)  # the text passed the gate already; this says whether it is a query
        run = store.query
    except BadInput:  # an update: the update parser names the position
        run = store.update
    try:
        run(text)
    except SyntaxError as e:
        m = _AT.search(str(e))
        return (int(m.group(1)), int(m.group(2))) if m else None
    except Exception:  # parsed, then failed running (e.g. SERVICE): no position to give
        return None
    return None
