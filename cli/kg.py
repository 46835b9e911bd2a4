"""``nfex kg …``: transactional, SHACL-checked writes, versions and export."""
from __future__ import annotations

from enum import StrEnum
from pathlib import Path
from typing import Annotated

import typer

from .common import author as author_of
from .common import echo_json, err, open_kg, table

app = typer.Typer(help="Edit the knowledge graph: every write is one SHACL-checked, versioned transaction.", no_args_is_help=True)

AuthorOpt = Annotated[str | None, typer.Option("--author", help="Who makes the change (default $NFEX_AUTHOR or your user).")]
MessageOpt = Annotated[str, typer.Option("--message", "-m", help="A note kept with the version.")]
ExpectOpt = Annotated[
    int | None, typer.Option("--expect-version", help="Refuse (exit 5) unless the graph is still at this version.")
]


def _files_graph(files: list[Path]):
    import rdflib

    from nfex_core.kg import read_rdf_file

    g = rdflib.Graph()
    for f in files:
        g += read_rdf_file(f)
    return g


def report_commit(result, what: str) -> None:
    """Print a commit's outcome: the new version and its triple counts, or that nothing changed."""
    if result.changed:
        typer.echo(f"version {result.version}: {what} (+{result.added} −{result.removed} triples)")
    else:
        typer.echo(f"no change; the graph stays at version {result.version}")


@app.command()
def add(
    files: Annotated[list[Path], typer.Argument(help="RDF files (Turtle, N-Triples, JSON-LD, RDF/XML).")],
    author: AuthorOpt = None,
    message: MessageOpt = "",
    expect_version: ExpectOpt = None,
) -> None:
    """Add the triples of FILES as one transaction (exit 1 with the SHACL report if rejected)."""
    _commit_files("add", files, author, message, expect_version)


@app.command()
def remove(
    files: Annotated[list[Path], typer.Argument(help="RDF files whose triples to remove.")],
    author: AuthorOpt = None,
    message: MessageOpt = "",
    expect_version: ExpectOpt = None,
) -> None:
    """Remove the triples of FILES as one transaction (the rest of the graph must still conform)."""
    _commit_files("remove", files, author, message, expect_version)


def _commit_files(verb: str, files: list[Path], author: str | None, message: str, expect_version: int | None) -> None:
    """``kg.add`` or ``kg.remove`` (``verb``) of the triples of ``files``, as one transaction, and its report."""
    g = _files_graph(files)
    kg = open_kg()
    msg = message or f"{verb} " + ", ".join(f.name for f in files)
    write = kg.add if verb == "add" else kg.remove
    report_commit(write(g, author=author_of(author), message=msg, expected_version=expect_version), msg)


@app.command()
def update(
    update: Annotated[str, typer.Argument(help="A SPARQL 1.1 Update (PREFIX nfex: and friends are predeclared).")],
    author: AuthorOpt = None,
    message: MessageOpt = "",
    expect_version: ExpectOpt = None,
) -> None:
    """Run a SPARQL 1.1 Update as one checked transaction."""
    from nfex_core.kg.storage.sparql_query import with_prefixes

    kg = open_kg()
    report_commit(kg.update(with_prefixes(update), author=author_of(author), message=message, expected_version=expect_version), "update")


@app.command()
def versions(
    limit: Annotated[int, typer.Option(help="Show at most this many, newest first.")] = 20,
    json: Annotated[bool, typer.Option("--json", help="Print JSON.")] = False,
) -> None:
    """List graph versions, newest first."""
    kg = open_kg()
    vs = kg.versions(limit=limit)
    if json:
        echo_json([v.as_dict() for v in vs])
        return
    rows = [
        [str(v.number), v.time.strftime("%Y-%m-%d %H:%M:%S") if v.time else "", v.author, f"+{v.added} −{v.removed}", v.message]
        for v in vs
    ]
    typer.echo(table(["version", "time (UTC)", "author", "triples", "message"], rows))


@app.command()
def diff(
    version: Annotated[int, typer.Argument(help="Show what this version changed…")],
    since: Annotated[int | None, typer.Option(help="…or the net change from version SINCE to VERSION.")] = None,
) -> None:
    """Print a version's change set as N-Triples lines prefixed with + and −."""
    from nfex_core.kg.rdf.terms import triple_n3

    kg = open_kg()
    change = kg.diff(since, version) if since is not None else kg.changes(version)
    for t in sorted(change.removed, key=str):
        typer.echo("- " + triple_n3(t))
    for t in sorted(change.added, key=str):
        typer.echo("+ " + triple_n3(t))


@app.command()
def rollback(
    version: Annotated[int, typer.Argument(help="The version whose knowledge to restore.")],
    author: AuthorOpt = None,
    expect_version: ExpectOpt = None,
) -> None:
    """Restore the graph to VERSION as a new version (history is kept)."""
    kg = open_kg()
    report_commit(kg.rollback(version, author=author_of(author), expected_version=expect_version), f"rollback to version {version}")


class ExportFormat(StrEnum):
    turtle = "turtle"
    nt = "nt"
    jsonld = "json-ld"
    xml = "xml"


@app.command()
def export(
    format: Annotated[ExportFormat, typer.Option("--format", help="Serialisation.")] = ExportFormat.turtle,
    output: Annotated[Path | None, typer.Option("--output", "-o", help="Write to a file instead of stdout.")] = None,
    owl: Annotated[bool, typer.Option("--owl", help="OWL only: leave out the SHACL shapes (for Protégé and reasoners).")] = False,
) -> None:
    """Export the knowledge (the default graph) — it opens in Protégé and re-imports with `kg add`."""
    kg = open_kg()
    if owl:
        from nfex_core.kg.vocabulary.owl import owl_only

        text = owl_only(kg.data_graph()).serialize(format=format.value)
    else:
        text = kg.export(format.value)
    if output:
        output.write_text(text)
        err(f"wrote {output}")  # a message, not the export: stdout stays clean for pipes
    else:
        typer.echo(text, nl=False)


@app.command()
def seed() -> None:
    """Bring the graph in line with ontology/ and rules/ (adds what is new, removes what was deleted)."""
    from nfex_core.knowledge import seed as do_seed

    kg = open_kg(seed=False)
    report_commit(do_seed(kg), "seeded from ontology/ and rules/")


@app.command()
def info(json: Annotated[bool, typer.Option("--json")] = False) -> None:
    """Where the store is, its version and size."""
    kg = open_kg()
    data = {"store": kg.location, "version": kg.version, "triples": kg.triple_count()}
    if json:
        echo_json(data)
    else:
        for k, v in data.items():
            typer.echo(f"{k}: {v}")
