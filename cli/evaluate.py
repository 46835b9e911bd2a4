"""``nfex evaluate``: every static method, nFEX, the motion-prior control and (``--oracle``) the hindsight oracles
on one or more sequences, in paired runs under corruptions and condition schedules, with the same front-end
checks for every method; front-end figures first, monocular ATE beside, per sequence and pooled."""
from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from nfex_core.errors import BadInput

from .common import echo_json, open_kg
from .sweep import split_values


def evaluate(
    path: Annotated[Path | None, typer.Argument(help="Dataset folder (e.g. $NFEX_DATA/kitti); optional with --manifest.")] = None,
    format: Annotated[str, typer.Option("--format", help="kitti | euroc | tum | handheld")] = "kitti",
    sequence: Annotated[list[str], typer.Option("--sequence", help="Sequence id (KITTI: 01); repeat or comma-separate "
                        "for several, evaluated one by one and pooled.")] = [],  # noqa: B006
    manifest: Annotated[Path | None, typer.Option("--manifest", help="A TOML file of \\[\\[sequence]] tables (path, format, "
                        "sequence, step) joining sequences of other datasets (docs/experiments.md).")] = None,
    methods: Annotated[list[str], typer.Option("--methods", "-m", help="Methods (repeatable or comma-separated): "
                       "<extractor>-default, <extractor>-dyn for every extractor in the graph, tuned-static, nfex. "
                       "Default: all of them.")] = [],  # noqa: B006
    runs: Annotated[int, typer.Option(help="Paired runs per method and condition (run r: seed r for every method).")] = 5,
    corruption: Annotated[list[str], typer.Option("--corruption", "-c", help="none and/or corruption names, "
                          "each applied to the whole sequence.")] = [],  # noqa: B006
    schedule: Annotated[str | None, typer.Option("--schedule", help="Conditions that change along the sequence, "
                        "e.g. none:0-12,dark:13-25@0.2-0.9,motion_blur:26-38@0.5,overexposed:39-50 (frame positions, "
                        "inclusive, covering every frame; @S a segment's severity, @S0-S1 a linear ramp).")] = None,
    severity: Annotated[float, typer.Option(help="Corruption severity in [0, 1].")] = 0.7,
    budget_ms: Annotated[list[float], typer.Option("--budget-ms", help="Also run nFEX at this per-frame budget (repeatable).")] = [],  # noqa: B006
    checks: Annotated[bool, typer.Option("--checks/--no-checks", help="The front-end checks of the sequence's agent "
                      "(rotation, heading change) for every method.")] = True,
    oracle: Annotated[bool, typer.Option("--oracle", help="Also run the hindsight oracles over the static methods' "
                      "pair estimates (best per segment, best per frame pair).")] = False,
    frames: Annotated[int | None, typer.Option(help="Only the first N frames (after --step).")] = None,
    step: Annotated[int, typer.Option(help="Every STEP-th frame (e.g. 3 for a 30 Hz handheld video).")] = 1,
    out: Annotated[Path, typer.Option("--out", help="Folder for table.md, runs.csv, frames.csv, selections.csv, "
                   "result.json and plots (a subfolder per sequence with several).")] = Path("out/evaluate"),
    plots: Annotated[bool, typer.Option(help="Draw the plots.")] = True,
    json_out: Annotated[bool, typer.Option("--json", help="Print the result as JSON instead of the table.")] = False,
    progress: Annotated[bool, typer.Option(help="Show a progress bar.")] = True,
    vo: Annotated[str, typer.Option("--vo", help="two-view: each step's length from the points the previous step "
                  "triangulated; map: the local map with a sliding-window bundle adjustment (docs/vo.md).")] = "two-view",
) -> None:
    """Pose AUC and front-end ATE, then monocular ATE, with 95 % intervals over paired runs per method, paired tests
    against the best static method with the difference they could detect, lost and coasted pairs, per-segment and
    transition rows under a schedule, ms/frame — per sequence (each held out of the graph) and pooled."""
    import json

    from nfex_core.config import Settings
    from nfex_core.evaluation import csv_text, frames_csv, known_methods, selections_csv
    from nfex_core.evaluation.pooled import concat_csv, evaluate_sequences, study_json, study_markdown
    from nfex_core.evaluation.sources import from_arguments, read_manifest

    if runs < 1:
        raise BadInput("--runs must be at least 1")
    if step < 1:
        raise BadInput("--step must be at least 1")
    if not 0.0 <= severity <= 1.0:
        raise BadInput(f"--severity must lie in [0, 1], got {severity}")
    sources = from_arguments(path, format, split_values(sequence), step)
    if manifest is not None:
        sources += read_manifest(manifest, Settings.from_env().data)
    if not sources:
        raise BadInput("give a dataset folder (with --sequence) or --manifest")
    seqs = [src.open() for src in sources]
    kg = open_kg()
    try:
        vocab = kg.vocabulary()
        known = known_methods(vocab)
        chosen = list(split_values(methods)) or known
        for m in chosen:
            if m not in known:
                raise BadInput(f"unknown method {m!r}; known: {', '.join(known)}")
        if not methods:  # the default list leaves out what cannot run here (a learned extractor without its extra)
            from nfex_core.vision.backends import unavailable

            absent = {x.lower(): why for x, why in unavailable(vocab.extractors, kg.settings).items()}
            for m in [m for m in chosen if m.rpartition("-")[0] in absent]:
                chosen.remove(m)
                typer.echo(f"nfex: {m} left out: {absent[m.rpartition('-')[0]].detail}", err=True)
        conditions = list(split_values(corruption)) or ([] if schedule else ["none"])
        study = evaluate_sequences(seqs, kg, methods=chosen, runs=runs, corruptions=conditions, severity=severity,
                                   budgets=budget_ms, frames=frames, schedule=schedule, checks=checks, oracle=oracle,
                                   progress=progress and not json_out, vo=vo)
    finally:
        kg.close()
    out.mkdir(parents=True, exist_ok=True)
    evs = study.evaluations
    md = study_markdown(study)
    result = study_json(study)
    (out / "table.md").write_text(md)
    (out / "runs.csv").write_text(concat_csv([csv_text(ev) for ev in evs]))
    (out / "frames.csv").write_text(concat_csv([frames_csv(ev) for ev in evs]))
    (out / "selections.csv").write_text(concat_csv([selections_csv(ev) for ev in evs]))
    if plots:
        from .plots import draw

        result["plots"] = [str(p) for ev in evs
                           for p in draw(ev, out if len(evs) == 1 else out / ev.label.replace("/", "-"))]
    (out / "result.json").write_text(json.dumps(result, indent=2))
    if json_out:
        echo_json(result)
    else:
        typer.echo(md.rstrip())
        typer.echo(f"written to {out}/")
