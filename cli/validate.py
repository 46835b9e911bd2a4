"""``nfex validate``: check the whole graph against its SHACL shapes."""
from __future__ import annotations

from typing import Annotated

import typer

from .common import echo_json, open_kg


def validate(json: Annotated[bool, typer.Option("--json", help="Print the results as JSON.")] = False) -> None:
    """Validate the whole graph; exit 0 when it conforms, 1 with the report when it does not."""
    kg = open_kg()
    report = kg.validate()
    if json:
        echo_json({"conforms": report.conforms, "version": kg.version, "results": [r.__dict__ for r in report.results]})
    elif report.conforms:
        typer.echo(f"conforms: version {kg.version}, {report.data_triples} triples")
    else:
        typer.echo(f"does not conform: {len(report.violations)} violation(s) at version {kg.version}")
        for r in report.results:
            typer.echo(f"  {r.severity}: {r.line()}")
    if not report.conforms:
        raise typer.Exit(1)
