"""``nfex ate``: absolute (and optionally relative) trajectory error of an estimate against a reference, as evo."""
from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from nfex_core.errors import UnknownName

from .common import echo_json

STAT_KEYS = ("rmse", "mean", "median", "std", "min", "max", "sse")
FORMATS = ("kitti", "tum", "euroc")
ALIGNS = ("se3", "sim3", "none")
DELTA_UNITS = ("f", "m")


def _choice(kind: str, value: str, known: tuple[str, ...]) -> str:
    # plain strings checked here rather than Enum options, so that a bad value is nFEX's one-line
    # bad-input error (exit 2) whatever click the installed typer bundles
    if value.lower() not in known:
        raise UnknownName(kind, value, known)
    return value.lower()


ALIGN_TITLE = {"se3": "with SE(3) Umeyama alignment", "sim3": "with Sim(3) Umeyama alignment", "none": "not aligned"}


def ate(
    ref: Annotated[Path, typer.Option("--ref", help="Reference (ground-truth) trajectory file.")],
    est: Annotated[Path, typer.Option("--est", help="Estimated trajectory file.")],
    format: Annotated[str, typer.Option("--format", help="File format of both files: kitti, tum or euroc.")],  # noqa: A002
    align: Annotated[
        str, typer.Option("--align", help="Umeyama alignment: se3 (evo -a), sim3 (evo -as, monocular) or none.")
    ] = "se3",
    t_max_diff: Annotated[
        float, typer.Option("--t-max-diff", help="Max. time difference (s) for associating poses, as evo's --t_max_diff.")
    ] = 0.01,
    rpe_delta: Annotated[
        float | None, typer.Option("--rpe-delta", help="Also compute the RPE (translation part) for this delta.")
    ] = None,
    delta_unit: Annotated[str, typer.Option("--delta-unit", help="RPE delta in frames (f) or metres (m).")] = "f",
    all_pairs: Annotated[bool, typer.Option("--all-pairs", help="RPE over all pairs, not consecutive ones.")] = False,
    json: Annotated[bool, typer.Option("--json", help="Print a JSON object instead of a table.")] = False,
) -> None:
    """Absolute trajectory error (APE, translation part, metres) of EST against REF, computed as evo_ape."""
    from nfex_slam.trajectory import ate as ate_stats
    from nfex_slam.trajectory import read_trajectory, rpe

    fmt = _choice("trajectory format", format, FORMATS)
    align = _choice("alignment", align, ALIGNS)
    delta_unit = _choice("delta unit", delta_unit, DELTA_UNITS)
    reference = read_trajectory(ref, fmt)
    estimate = read_trajectory(est, fmt)
    stats = ate_stats(reference, estimate, align=align, t_max_diff=t_max_diff)
    relative = None
    if rpe_delta is not None:
        relative = rpe(
            reference, estimate, delta=rpe_delta, delta_unit=delta_unit, all_pairs=all_pairs, t_max_diff=t_max_diff
        )
    if json:
        out = stats.to_dict() | {"align": align, "t_max_diff": t_max_diff, "ref": str(ref), "est": str(est)}
        if relative is not None:
            out["rpe"] = relative.to_dict() | {"delta": rpe_delta, "delta_unit": delta_unit, "all_pairs": all_pairs}
        echo_json(out)
        return
    typer.echo(f"APE w.r.t. translation part (m), {ALIGN_TITLE[align]}")
    typer.echo(f"{'pairs':>8}  {stats.pairs}")
    if align == "sim3":
        typer.echo(f"{'scale':>8}  {stats.scale:.6f}")
    for key in STAT_KEYS:
        typer.echo(f"{key:>8}  {getattr(stats, key):.6f}")
    if relative is not None:
        pairs = "all pairs" if all_pairs else "consecutive pairs"
        unit = "frames" if delta_unit == "f" else "m"
        typer.echo(f"\nRPE w.r.t. translation part (m), delta = {rpe_delta:g} ({unit}) using {pairs}, not aligned")
        typer.echo(f"{'pairs':>8}  {relative.pairs}")
        for key in STAT_KEYS:
            typer.echo(f"{key:>8}  {getattr(relative, key):.6f}")
