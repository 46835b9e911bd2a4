"""What every command shares: opening the store, the author of a write, output helpers."""
from __future__ import annotations

import json
import sys
from typing import TYPE_CHECKING, Any

import typer

from nfex_core.config import Settings

if TYPE_CHECKING:
    from nfex_core.kg import KnowledgeGraph

STORE_HELP = "A folder (embedded store) or an http(s) SPARQL endpoint; default $NFEX_STORE."


class State:
    store: str | None = None
    debug: bool = False


state = State()


def settings() -> Settings:
    return Settings.from_env()


def open_kg(seed: bool = True) -> KnowledgeGraph:
    """The store named by ``--store`` / NFEX_STORE, seeded first if it is empty (unless ``seed`` is False)."""
    from nfex_core.knowledge import open_graph

    return open_graph(state.store, seed_empty=seed)


def author(value: str | None) -> str:
    return value or settings().author_or_user()


def echo_json(obj: Any) -> None:
    typer.echo(json.dumps(obj, indent=2, default=str))


def err(message: str) -> None:
    print(message, file=sys.stderr)


def table(headers: list[str], rows: list[list[str]]) -> str:
    """A plain-text table with aligned columns."""
    widths = [len(h) for h in headers]
    for row in rows:
        for i, cell in enumerate(row):
            widths[i] = max(widths[i], len(cell))
    line = "  ".join(h.ljust(w) for h, w in zip(headers, widths, strict=True))
    sep = "  ".join("-" * w for w in widths)
    body = ["  ".join(c.ljust(w) for c, w in zip(row, widths, strict=True)) for row in rows]
    return "\n".join([line, sep, *body])
