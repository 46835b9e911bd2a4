"""``nfex train``: ParamNet and SelectorNet from a sweep's training table (torch, imported only here)."""
from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from nfex_core.errors import BadInput, DataMissing

from .common import err, open_kg, settings


def train(
    table: Annotated[list[Path], typer.Option("--table", help="A sweep's training table (CSV or .csv.gz, one row per window × "
                                             "configuration); repeat to concatenate several.")],
    out: Annotated[Path | None, typer.Option("--out", help="Model folder to write (default: $NFEX_MODELS/default).")] = None,
    epochs: Annotated[int | None, typer.Option("--epochs", help="Passes over the training windows (default: enough for 4,000 Adam steps, at least 300).")] = None,
    lr: Annotated[float, typer.Option("--lr", help="Adam learning rate (the paper: 1e-4).")] = 1e-4,
    batch: Annotated[int, typer.Option("--batch", help="Batch size (the paper: 8).")] = 8,
    val_sequences: Annotated[
        list[str] | None,
        typer.Option("--val-sequences", help="Validate on these sequences only (dataset/sequence or name; repeatable). "
                     "Default: leave each sequence out once; with one sequence, its second half."),
    ] = None,
    refit_all: Annotated[bool, typer.Option("--refit-all", help="After validating on one split, train the shipped weights "
                                            "again on every window (always so after leave-one-sequence-out).")] = False,
    no_images: Annotated[bool, typer.Option("--no-images", help="Train SelectorNet without frames (image bit 0).")] = False,
    seed: Annotated[int, typer.Option("--seed")] = 0,
) -> None:
    """Validate both networks against the best constant and the lookup by labels, train the shipped weights,
    and write a versioned model folder; a network that does not beat both is not used by default."""
    for t in table:
        if not t.is_file():
            raise DataMissing(f"no training table at {t}")
    try:
        from nfex_core.neural.training.train import train as run
    except ImportError as e:  # torch is a training-only dependency
        raise BadInput(f"training needs torch (pip install 'nfex[train]'): {e}") from None
    s = settings()
    dest = out or s.models / "default"
    kg = open_kg()
    try:
        vocab = kg.vocabulary()
    finally:
        kg.close()
    try:
        report = run(
            table, dest, vocab, epochs=epochs, lr=lr, batch=batch, val_sequences=val_sequences, refit_all=refit_all,
            data_dir=None if no_images else s.data, seed=seed, log=err,
        )  # fmt: skip
    except ValueError as e:
        raise BadInput(str(e)) from None
    from nfex_core.neural.artifacts import NeuralModel

    gates = NeuralModel.load(report.path).validation_gates()
    typer.echo(json.dumps({"model": str(report.path), "split": report.split, "windows": report.windows,
                           "validation": report.metrics, "not_used_by_default": gates}, indent=2))  # fmt: skip
