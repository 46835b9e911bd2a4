"""``nfex sparql``: ask the knowledge graph a question."""
from __future__ import annotations

import csv
import io
from enum import StrEnum
from pathlib import Path
from typing import Annotated

import typer
from rdflib.term import Literal, Node, URIRef

from nfex_core.errors import BadInput

from .common import echo_json, open_kg, table


class Format(StrEnum):
    table = "table"
    json = "json"
    csv = "csv"
    tsv = "tsv"


def short(term: Node | None, prefixes: dict[str, str]) -> str:
    if term is None:
        return ""
    if isinstance(term, URIRef):
        for p, ns in prefixes.items():
            if str(term).startswith(ns):
                return f"{p}:{str(term)[len(ns):]}"
        return f"<{term}>"
    return str(term)


def to_tsv_term(term: Node) -> str:
    if isinstance(term, Literal):
        return term.n3()
    return term.n3() if hasattr(term, "n3") else str(term)


def sparql(
    query: Annotated[str | None, typer.Argument(help="The SPARQL query (PREFIX nfex: and friends are predeclared).")] = None,
    file: Annotated[Path | None, typer.Option("--file", "-f", help="Read the query from a file.")] = None,
    format: Annotated[Format, typer.Option("--format", help="Output format for SELECT/ASK results.")] = Format.table,
) -> None:
    """Run a SPARQL 1.1 query against the knowledge graph (read-only)."""
    from nfex_core.kg.namespaces import PREFIXES
    from nfex_core.kg.sparql_gate import gate_query
    from nfex_core.kg.sparql_query import with_prefixes

    if (query is None) == (file is None):
        raise BadInput("give a query or --file, not both and not neither")
    if file is not None:
        try:
            query = file.read_text()
        except OSError as e:
            raise BadInput(f"{file}: cannot read: {e.strerror}") from e
    assert query is not None
    form = gate_query(query).form
    kg = open_kg()
    text = with_prefixes(query)
    if form == "ask":
        answer = kg.backend.ask(text)
        if format is Format.json:
            echo_json({"head": {}, "boolean": answer})
        else:
            typer.echo("true" if answer else "false")
        return
    if form in ("construct", "describe"):
        typer.echo(kg.backend.construct(text).serialize(format="turtle"))
        return
    result = kg.backend.select(text)
    if format is Format.json:
        from nfex_core.kg.backends import json_bindings

        echo_json(json_bindings(result))
    elif format is Format.csv:
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\r\n")
        w.writerow(result.variables)
        for row in result.rows:
            w.writerow([str(row[v]) if v in row else "" for v in result.variables])
        typer.echo(buf.getvalue(), nl=False)
    elif format is Format.tsv:
        lines = ["\t".join("?" + v for v in result.variables)]
        lines += ["\t".join(to_tsv_term(row[v]) if v in row else "" for v in result.variables) for row in result.rows]
        typer.echo("\n".join(lines))
    else:
        rows = [[short(row.get(v), PREFIXES) for v in result.variables] for row in result.rows]
        typer.echo(table(result.variables, rows))
        typer.echo(f"({len(rows)} row{'s' if len(rows) != 1 else ''})")
