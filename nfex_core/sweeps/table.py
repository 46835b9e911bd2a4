"""The sweep's training table (CSV; HELPERS.md, "The sweep's training table"), read by the neural part.

One row per window × configuration. Rows are appended as cells finish (so a killed sweep keeps what
it measured and resumes from it); ``label`` then marks, for each window, ``best_overall`` (the row with
the lowest ATE — a failure is never best) and ``best_for_extractor`` (each extractor's best row).
"""
from __future__ import annotations

import csv
import gzip
import math
from collections import defaultdict
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

from .cells import DIMENSIONS

BASE_COLUMNS = [
    "dataset", "sequence", "corruption", "schedule", "severity", "seed", "window_start", "window_end", "frames",
    *[f"ctx.{d}" for d in DIMENSIONS],
    "extractor", "params", "ate_rmse", "rpe_rmse", "tracking_lost", "failed", "mean_matches", "mean_inliers",
    "mean_keypoints", "extraction_ms", "matching_ms", "width", "height",
    "pair_rotation_error_deg", "pair_direction_error_deg", "bad_pair_fraction", "transition",
]
LABELS = ["best_overall", "best_for_extractor"]
WINDOW = ("dataset", "sequence", "corruption", "schedule", "severity", "seed", "window_start")


def columns(rows: Iterable[Mapping[str, Any]]) -> list[str]:
    """Base columns, then every ``m.*`` and ``stat.*`` column seen (sorted), the labels, and ``cell``."""
    extra = sorted({k for r in rows for k in r if k.startswith(("m.", "stat."))})
    return [*BASE_COLUMNS, *extra, *LABELS, "cell"]


def _fmt(v: Any) -> str:
    if v is None:
        return ""
    if isinstance(v, float):
        return "" if math.isnan(v) else f"{v:.6g}"
    return str(v)


def read(path: Path) -> list[dict[str, str]]:
    """A training table's rows (none where it does not exist); ``.gz`` is read through gzip."""
    if not path.exists():
        return []
    with gzip.open(path, "rt", newline="") if path.suffix == ".gz" else path.open(newline="") as f:
        return list(csv.DictReader(f))


def write(path: Path, rows: Sequence[Mapping[str, Any]]) -> None:
    """Write ``rows`` (whole table) atomically."""
    path.parent.mkdir(parents=True, exist_ok=True)
    cols = columns(rows)
    tmp = path.with_suffix(path.suffix + ".tmp")
    with tmp.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=cols, extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow({c: _fmt(r.get(c)) for c in cols})
    tmp.replace(path)


def label(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Set ``best_overall`` and ``best_for_extractor`` (0/1) on every row, per window."""
    windows: dict[tuple[str, ...], list[dict[str, Any]]] = defaultdict(list)
    for r in rows:
        windows[tuple(str(r.get(k, "")) for k in WINDOW)].append(r)
        r["best_overall"] = 0
        r["best_for_extractor"] = 0
    for group in windows.values():
        ok = [r for r in group if str(r.get("failed")) in ("0", "False") and r.get("ate_rmse") not in (None, "")]
        if not ok:
            continue
        min(ok, key=lambda r: float(r["ate_rmse"]))["best_overall"] = 1
        by_x: dict[str, list[dict[str, Any]]] = defaultdict(list)
        for r in ok:
            by_x[str(r["extractor"])].append(r)
        for rs in by_x.values():
            min(rs, key=lambda r: float(r["ate_rmse"]))["best_for_extractor"] = 1
    return rows


PAIR_COLUMNS = [
    "cell", "dataset", "sequence", "corruption", "severity", "seed", "window_start", "frame", "before", "after",
    "transition", "extractor", "params", "keypoints", "matches", "inliers", "lost", "rejected", "reason", "rotation_deg",
    "rotation_error_deg", "direction_error_deg", "parallax_px", "extraction_ms", "rx", "ry", "rz", "dx", "dy", "dz",
    "true_rx", "true_ry", "true_rz", "true_dx", "true_dy", "true_dz",
]


def pairs_path(table: Path) -> Path:
    """The per-pair table beside a training table: ``kitti00.csv`` (or ``kitti00.csv.gz``) → ``kitti00-pairs.csv.gz``."""
    name = table.name.removesuffix(".gz")
    return table.with_name(name.removesuffix(".csv") + "-pairs.csv.gz")


def write_pairs(path: Path, rows: Sequence[Mapping[str, Any]]) -> None:
    """Append per-pair rows (one per frame pair of each cell: its estimate as a rotation vector and a direction
    of motion, its errors against the ground truth, matches, inliers, loss) to a gzip CSV; a new file gets
    the header. Appending keeps a killed sweep's pairs, as the training table keeps its rows."""
    if not rows:
        return
    path.parent.mkdir(parents=True, exist_ok=True)
    new = not path.exists()
    with gzip.open(path, "at", newline="") as f:
        w = csv.DictWriter(f, fieldnames=PAIR_COLUMNS, extrasaction="ignore")
        if new:
            w.writeheader()
        for r in rows:
            w.writerow({c: _fmt(r.get(c)) for c in PAIR_COLUMNS})


def read_pairs(path: Path) -> list[dict[str, str]]:
    if not path.exists():
        return []
    with gzip.open(path, "rt", newline="") as f:
        return list(csv.DictReader(f))
