"""Entry point of the ``nfex`` console script."""
from __future__ import annotations

import sys
import traceback
from typing import Annotated

import click
import typer

from nfex_core.errors import NfexError

from . import ate, evaluate, kg, program, select, serve, sparql, sweep, train, validate
from .common import STORE_HELP, err, state

app = typer.Typer(
    name="nfex",
    help="nFEX: which feature extractor to run, with which parameters, and why.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=True,  # --install-completion / --show-completion for bash, zsh, fish, PowerShell
)


def _version(value: bool) -> None:
    if value:
        from nfex_core import __version__

        typer.echo(f"nfex {__version__}")
        raise typer.Exit()


@app.callback()
def _options(
    store: Annotated[str | None, typer.Option("--store", help=STORE_HELP)] = None,
    debug: Annotated[bool, typer.Option("--debug", help="Print tracebacks.")] = False,
    version: Annotated[
        bool, typer.Option("--version", callback=_version, is_eager=True, help="Print the version and exit.")
    ] = False,
) -> None:
    state.store = store
    state.debug = debug


# Every command, listed here (each module keeps its heavy imports inside the command, so this stays fast).
app.command("sparql")(sparql.sparql)
app.command("validate")(validate.validate)
app.add_typer(kg.app, name="kg")
app.command("serve")(serve.serve)
app.command("select")(select.select)
app.add_typer(program.app, name="program")
app.command("ate")(ate.ate)
app.command("sweep")(sweep.sweep)
app.command("evaluate")(evaluate.evaluate)
app.command("train")(train.train)


def main(argv: list[str] | None = None) -> None:
    args = sys.argv[1:] if argv is None else argv
    debug = "--debug" in args
    try:
        rv = app(args=args, prog_name="nfex", standalone_mode=False)
    except click.exceptions.Exit as e:
        sys.exit(e.exit_code)
    except click.exceptions.Abort:
        err("nfex: aborted")
        sys.exit(130)
    except click.ClickException as e:
        e.show()
        sys.exit(2)
    except typer.exceptions.TyperException as e:  # typer 0.29 raises usage errors from its bundled click
        show = getattr(e, "show", None)
        if callable(show):
            show()
        else:
            err(f"nfex: {e}")
        sys.exit(2)
    except NfexError as e:
        if debug:
            traceback.print_exc()
        err(f"nfex: {e.title.lower()}: {e.detail}")
        sys.exit(e.exit_code)
    except KeyboardInterrupt:
        err("nfex: interrupted")
        sys.exit(130)
    except Exception as e:  # a bug: say so in one line, with the trace only on request
        if debug:
            traceback.print_exc()
        err(f"nfex: internal error: {type(e).__name__}: {e} (run with --debug for the traceback)")
        sys.exit(3)
    sys.exit(rv if isinstance(rv, int) else 0)


if __name__ == "__main__":
    main()
