"""``nfex program …``: check, apply, show and list DSL programs (docs/dsl.md)."""
from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from nfex_core.errors import NotFound

from .common import author as author_of
from .common import echo_json, err, open_kg, settings, table
from .common import table as table_of

app = typer.Typer(help="DSL programs: check and apply rule files, show what the graph holds.", no_args_is_help=True)

FileArg = Annotated[Path, typer.Argument(help="A program file (.nfex).", exists=True, dir_okay=False, readable=True)]


@app.command()
def check(file: FileArg) -> None:
    """Parse FILE and check every name against the graph; print every problem with its line and column (stderr).

    Exit 0 when the program is valid, 2 on a syntax error, an unknown name or a number out of range.
    """
    from nfex_core.rules.dsl.check import problems
    from nfex_core.rules.dsl.parser import parse_file
    from nfex_core.rules.dsl.programs import source_name

    program = parse_file(file, source=source_name(file, settings()))
    vocab = open_kg().vocabulary()
    found = problems(program, vocab)
    if found:  # every problem once, on stderr (stdout stays for results), then the first's exit code
        for e in found:
            err(f"nfex: {e.title.lower()}: {e.detail}")
        raise typer.Exit(found[0].exit_code)
    typer.echo(f"ok: program {program.name}, {len(program.statements)} statements")


def shipped_or_file(file: Path) -> Path:
    """FILE itself, or the program of that name shipped outside the seeded set (``rules/*/NAME.nfex`` in the
    installed package, e.g. ``verification``): what a wheel user, who has no checkout, can name."""
    if file.exists():
        return file
    rules = settings().rules_dir
    found = sorted(p for p in rules.glob(f"*/{file.name}.nfex") if p.parent.name != "programs") if file.name == str(file) else []
    if not found:
        shipped = sorted(p.stem for p in rules.glob("*/*.nfex") if p.parent.name != "programs")
        raise NotFound(f"no file {str(file)!r} and no shipped program of that name; shipped: {', '.join(shipped) or '(none)'}")
    return found[0]


@app.command()
def apply(
    file: Annotated[Path, typer.Argument(help="A program file (.nfex), or the name of a shipped opt-in program (e.g. verification).")],
    message: Annotated[str, typer.Option("--message", "-m", help="A note kept with the version.")] = "",
    author: Annotated[str | None, typer.Option("--author", help="Who makes the change.")] = None,
    expect_version: Annotated[int | None, typer.Option("--expect-version", help="Refuse (exit 5) unless the graph is at this version.")] = None,
) -> None:
    """Check FILE and replace that program's statements in the graph as one versioned transaction."""
    from nfex_core.rules.dsl import programs

    from .kg import report_commit

    file = shipped_or_file(file)
    kg = open_kg()
    program, graph = programs.load(file, kg.vocabulary(), settings())
    result = programs.apply(
        kg, graph, program.name, author=author_of(author), message=message or f"apply program {program.name} from {file.name}",
        expected_version=expect_version,
    )
    report_commit(result, f"program {program.name}, {len(program.statements)} statements")


@app.command()
def show(
    name: Annotated[str | None, typer.Argument(help="The program's name (default: every program).")] = None,
    shapes: Annotated[bool, typer.Option("--shapes", help="Also print each require's SHACL shape, read back as a DSL line.")] = False,
) -> None:
    """Print a program's text as the graph holds it (read back from its triples)."""
    from nfex_core.rules.dsl import programs
    from nfex_core.rules.dsl.parser import render

    kg = open_kg()
    names = [name] if name else [p.name for p in programs.programs(kg)]
    if not names:
        raise NotFound("the graph holds no program")
    typer.echo("\n".join(render(programs.show(kg, n)) for n in names), nl=False)
    if shapes:
        from nfex_core.rules.shape_text import program_shapes

        for n in names:
            for _, line in program_shapes(kg, n):
                typer.echo(f"# shape: {line}")


@app.command("list")
def list_(as_json: Annotated[bool, typer.Option("--json", help="JSON instead of a table.")] = False) -> None:
    """The programs in the graph, with their statement counts and source files."""
    from nfex_core.rules.dsl import programs

    infos = programs.programs(open_kg())
    if as_json:
        echo_json([i.__dict__ for i in infos])
        return
    typer.echo(table(["program", "statements", "source", "iri"], [[i.name, str(i.statements), i.source or "", i.iri] for i in infos]))


@app.command()
def remove(
    name: Annotated[str, typer.Argument(help="The program to remove.")],
    message: Annotated[str, typer.Option("--message", "-m")] = "",
    author: Annotated[str | None, typer.Option("--author")] = None,
) -> None:
    """Remove a program and all its statements as one transaction."""
    from nfex_core.rules.dsl import programs

    kg = open_kg()
    if name not in {p.name for p in programs.programs(kg)}:
        raise NotFound(f"no program named {name!r}; the graph holds: {', '.join(p.name for p in programs.programs(kg)) or '(none)'}")
    result = programs.remove(kg, name, author=author_of(author), message=message)
    typer.echo(f"version {result.version}: removed program {name} (−{result.removed} triples)")


@app.command("learn-verification")
def learn_verification(
    table: Annotated[list[Path], typer.Option("--table", help="A sweep's training table; its pair table (…-pairs.csv.gz) is read beside it. Repeatable.", exists=True, dir_okay=False)],
    out: Annotated[Path, typer.Option("--out", "-o", help="The program file to write.")] = Path("rules/verification/verification.nfex"),
    min_pairs: Annotated[int, typer.Option("--min-pairs", help="Pairs an agent needs for thresholds of its own.")] = 500,
    escalations: Annotated[int, typer.Option("--escalations", help="The prior N of `escalate at most N`.")] = 2,
    max_extra_fallback: Annotated[float, typer.Option("--max-extra-fallback", help="Share of pairs the policy may coast on beyond those nothing survives.")] = 0.1,
) -> None:
    """Fit the verification program (accept pair if …, escalate at most N) to the sweeps' pair outcomes
    (nfex_core/sweeps/verification.py), check it against the graph and write it to OUT."""
    from nfex_core.errors import BadInput
    from nfex_core.rules.dsl.check import check as check_program
    from nfex_core.rules.dsl.parser import parse
    from nfex_core.sweeps.table import pairs_path
    from nfex_core.sweeps.verification import learn

    pair_tables = [pairs_path(t) for t in table]
    missing = [str(p) for p in pair_tables if not p.exists()]
    if missing:
        raise BadInput(f"no pair table beside the training table: {', '.join(missing)} (run `nfex sweep` with this --csv)")
    text, report = learn(pair_tables, table, min_pairs=min_pairs, escalations=escalations, max_extra_fallback=max_extra_fallback)
    check_program(parse(text, source=str(out)), open_kg().vocabulary())
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text)
    typer.echo(table_of(["agent", "accept pair if", "mean pair error °", "accept all °", "fall back all °", "pairs", "accepted"],
                        [[str(r[k]) for k in ("agent", "tests", "cost", "accept_all", "fall_back_all", "pairs", "accepted")]
                         for r in report]))
    typer.echo(f"wrote {out} ({len(report)} accept statements); apply it with `nfex program apply {out}`")
