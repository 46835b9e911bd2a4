"""``nfex evaluate``: the paper's Table I on a sequence (and its corruptions), with cost per frame."""
from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from ..errors import BadInput
from .common import echo_json, open_kg
from .sweep import split_values


def evaluate(
    path: Annotated[Path, typer.Argument(help="Dataset folder (e.g. $NFEX_DATA/kitti).")],
    format: Annotated[str, typer.Option("--format", help="kitti | euroc | tum | handheld")] = "kitti",
    sequence: Annotated[str | None, typer.Option("--sequence", help="Sequence id (KITTI: 01).")] = None,
    methods: Annotated[list[str], typer.Option("--methods", "-m", help="orb-default, sift-default, orb-dyn, sift-dyn, nfex, orb_grid-default, xfeat-default, xfeat-dyn.")] = [],  # noqa: B006
    runs: Annotated[int, typer.Option(help="Runs per method and condition (Mean ATE over them).")] = 1,
    corruption: Annotated[list[str], typer.Option("--corruption", "-c", help="none and/or corruption names.")] = [],  # noqa: B006
    severity: Annotated[float, typer.Option(help="Corruption severity in [0, 1].")] = 0.7,
    budget_ms: Annotated[list[float], typer.Option("--budget-ms", help="Also run nFEX at this per-frame budget (repeatable).")] = [],  # noqa: B006
    frames: Annotated[int | None, typer.Option(help="Only the first N frames (after --step).")] = None,
    step: Annotated[int, typer.Option(help="Every STEP-th frame (e.g. 3 for a 30 Hz handheld video).")] = 1,
    out: Annotated[Path, typer.Option("--out", help="Folder for table.md, runs.csv, selections.csv, result.json and plots.")] = Path("out/evaluate"),
    plots: Annotated[bool, typer.Option(help="Draw the plots.")] = True,
    json_out: Annotated[bool, typer.Option("--json", help="Print the result as JSON instead of the table.")] = False,
    progress: Annotated[bool, typer.Option(help="Show a progress bar.")] = True,
) -> None:
    """Mean ATE (Sim(3)) over R runs for each method — 'fail' where every run lost tracking — and ms/frame."""
    import json

    from ..datasets import open_sequence
    from ..evaluation import METHODS, as_json, csv_text, markdown, selections_csv
    from ..evaluation import evaluate as run_evaluation

    chosen = list(split_values(methods)) or list(METHODS)
    for m in chosen:
        if m not in METHODS:
            raise BadInput(f"unknown method {m!r}; known: {', '.join(METHODS)}")
    if runs < 1:
        raise BadInput("--runs must be at least 1")
    if step < 1:
        raise BadInput("--step must be at least 1")
    seq = open_sequence(path, format, sequence)
    if step > 1:
        seq = seq[::step]
    if seq.poses is None:
        raise BadInput(f"{path}: the sequence has no ground truth; ATE needs it")
    kg = open_kg()
    if not methods:  # the default list leaves out what cannot run here (a learned extractor without its extra)
        from ..vision.backends import unavailable

        absent = unavailable(kg.vocabulary().extractors, kg.settings)
        for m in [m for m in chosen if m.split("-")[0].upper() in absent]:
            chosen.remove(m)
            typer.echo(f"nfex: {m} left out: {absent[m.split('-')[0].upper()].detail}", err=True)
    try:
        ev = run_evaluation(seq, kg, methods=chosen, runs=runs, corruptions=list(split_values(corruption)) or ["none"],
                            severity=severity, budgets=budget_ms, frames=frames, progress=progress and not json_out)
    finally:
        kg.close()
    out.mkdir(parents=True, exist_ok=True)
    md = markdown(ev)
    result = as_json(ev)
    (out / "table.md").write_text(md)
    (out / "runs.csv").write_text(csv_text(ev))
    (out / "selections.csv").write_text(selections_csv(ev))
    if plots:
        from ..evaluation.plots import draw

        result["plots"] = [str(p) for p in draw(ev, out)]
    (out / "result.json").write_text(json.dumps(result, indent=2))
    if json_out:
        echo_json(result)
    else:
        typer.echo(md.rstrip())
        typer.echo(f"written to {out}/")
