"""``nfex sweep``: measure extractor × parameter grid × windows × corruptions and populate the graph."""
from __future__ import annotations

import shlex
import sys
from enum import StrEnum
from pathlib import Path
from typing import Annotated

import typer

from nfex_core.errors import BadInput

from .common import author as author_of
from .common import echo_json, open_kg


class Executor(StrEnum):
    local = "local"
    ray = "ray"


def split_values(values: list[str]) -> tuple[str, ...]:
    """Repeated options that may also be comma-separated: ``-x ORB,SIFT -x AKAZE`` → (ORB, SIFT, AKAZE)."""
    return tuple(v.strip() for item in values for v in item.split(",") if v.strip())


def sweep(
    path: Annotated[Path, typer.Argument(help="Dataset folder (e.g. $NFEX_DATA/kitti).")],
    format: Annotated[str, typer.Option("--format", help="kitti | euroc | tum | handheld")] = "kitti",
    sequence: Annotated[list[str], typer.Option("--sequence", help="Sequence id(s), repeat or comma-separate.")] = [],  # noqa: B006
    extractors: Annotated[list[str], typer.Option("--extractors", "-x", help="Extractors (default ORB,SIFT).")] = [],  # noqa: B006
    corruptions: Annotated[list[str], typer.Option("--corruptions", "-c", help="none and/or corruption names.")] = [],  # noqa: B006
    severity: Annotated[list[float], typer.Option(help="Corruption severity in [0, 1]; repeat for several (each "
                        "corruption and schedule at each).")] = [0.7],  # noqa: B006
    schedule: Annotated[list[str], typer.Option("--schedule", help="A condition schedule over each whole sequence, e.g. "
                        "none:0-49,dark:50-99@0.2-0.9,motion_blur:100-149@0.5,overexposed:150-199 (repeatable; @S a "
                        "segment's own severity, @S0-S1 a linear ramp, none: --severity).")] = [],  # noqa: B006
    checks: Annotated[bool, typer.Option("--checks/--no-checks", help="The front-end checks of the sequence's agent.")] = True,
    window: Annotated[int, typer.Option(help="Frames per window.")] = 20,
    stride: Annotated[int, typer.Option(help="Frames between window starts.")] = 50,
    max_windows: Annotated[int | None, typer.Option(help="At most this many windows per sequence.")] = None,
    sample: Annotated[int | None, typer.Option(help="Parameter sets per extractor (default: the whole grid).")] = None,
    seed: Annotated[int, typer.Option(help="Seed of corruptions and sampling.")] = 0,
    csv: Annotated[Path, typer.Option("--csv", help="The training table (appended; resumable).")] = Path("out/sweep.csv"),
    executor: Annotated[Executor, typer.Option(help="local process pool or a Ray cluster.")] = Executor.local,
    address: Annotated[str | None, typer.Option(help="Ray cluster address (with --executor ray).")] = None,
    workers: Annotated[int, typer.Option(help="Worker processes (local) or CPUs of a local Ray.")] = 2,
    batch: Annotated[int, typer.Option(help="Measurements per graph transaction.")] = 32,
    export: Annotated[Path | None, typer.Option(help="Afterwards, write the measurements of the table's cells here "
                      "(Turtle; .nt N-Triples; .gz compressed).")] = None,
    author: Annotated[str | None, typer.Option(help="Author recorded on the graph versions.")] = None,
    json_out: Annotated[bool, typer.Option("--json", help="Print the counts as JSON.")] = False,
    progress: Annotated[bool, typer.Option(help="Show a progress bar with ETA.")] = True,
) -> None:
    """Run the VO for every cell of the grid, write Measurements (one transaction per batch) and the table."""
    from nfex_core.sweeps import RunInfo, SweepSpec, export_measurements
    from nfex_core.sweeps import sweep as run_sweep

    if not path.is_dir():
        raise BadInput(f"{path}: not a folder")
    spec = SweepSpec(
        path=str(path), format=format, sequences=split_values(sequence) or ("",), extractors=split_values(extractors) or ("ORB", "SIFT"),
        window=window, stride=stride, max_windows=max_windows, corruptions=split_values(corruptions) or ("none",),
        severity=severity[0], severities=tuple(severity), schedules=tuple(schedule), checks=checks, seed=seed, sample=sample,
    )
    if any(not 0.0 <= v <= 1.0 for v in severity):
        raise BadInput(f"--severity must lie in [0, 1], got {severity}")
    if window < 2 or stride < 1:
        raise BadInput("--window must be at least 2 and --stride at least 1")
    kg = open_kg()
    try:
        run = RunInfo(command="nfex sweep " + " ".join(shlex.quote(a) for a in sys.argv[2:]))
        counts = run_sweep(spec, kg, csv, run=run, executor=executor.value, workers=workers, address=address,
                           batch=batch, author=author_of(author), progress=progress)
        if export is not None:
            from nfex_core.sweeps.table import read as read_rows

            counts["exported_triples"] = export_measurements(kg, export, cells=[str(r["cell"]) for r in read_rows(csv)])
    finally:
        kg.close()
    if json_out:
        echo_json(counts)
    else:
        typer.echo(", ".join(f"{k}: {v}" for k, v in counts.items()))
