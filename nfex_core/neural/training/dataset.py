"""Training examples from the sweep's training table: one per window (§IV-B, "best configurations").

The table (written by the sweeps, one row per window × configuration; schema in HELPERS/DESIGN) gives
per window its context labels, the frame statistics of its first frame, and the rows flagged
``best_for_extractor`` (ParamNet's targets: the best Θ of each extractor) and ``best_overall``
(SelectorNet's label: the extractor of the lowest-ATE configuration). Windows are split by
*sequence*, never windows of one sequence on both sides; with one sequence, by contiguous halves.
"""
from __future__ import annotations

import json
import logging
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ...sweeps.table import WINDOW
from ...sweeps.table import read as read_rows
from ..selectornet import prepare_image

log = logging.getLogger(__name__)


@dataclass
class Window:
    dataset: str
    sequence: str
    corruption: str
    severity: str
    seed: str
    start: int
    end: int
    context: dict[str, str | None]
    stats: dict[str, float]
    pixels: int
    best_params: dict[str, dict[str, Any]] = field(default_factory=dict)  # extractor → Θ of its best row
    metrics: dict[str, dict[str, float]] = field(default_factory=dict)  # extractor → m of its best row
    label: str | None = None  # extractor of the best_overall row
    ate: dict[str, float] = field(default_factory=dict)  # extractor → its lowest ATE in the window (successful rows)
    schedule: str = ""  # the condition schedule of a scheduled window (corruption "schedule")
    image: np.ndarray | None = None  # prepared for SelectorNet

    @property
    def seq_key(self) -> str:
        return f"{self.dataset}/{self.sequence}"


def _flag(row: dict[str, str], key: str) -> bool:
    return str(row.get(key, "")).strip() in ("1", "1.0", "true", "True")


def _float(text: str | None) -> float | None:
    try:
        return float(text) if text not in (None, "") else None
    except ValueError:
        return None


def read_table(paths: Path | Sequence[Path]) -> list[Window]:
    """Group the rows of one or more tables into windows (dataset, sequence, corruption, schedule, severity,
    seed, window_start); tables are concatenated, so a window measured in two of them is one window."""
    windows: dict[tuple[str, ...], Window] = {}
    for path in [paths] if isinstance(paths, Path) else paths:
        for row in read_rows(path):
            _add_row(windows, row)
    return list(windows.values())


def _add_row(windows: dict[tuple[str, ...], Window], row: dict[str, str]) -> None:
    key = tuple(row.get(k) or "" for k in WINDOW)
    w = windows.get(key)
    if w is None:
        w = windows[key] = Window(
            dataset=row["dataset"],
            sequence=row["sequence"],
            corruption=row.get("corruption") or "none",
            severity=row.get("severity", ""),
            seed=row.get("seed", ""),
            start=int(float(row["window_start"])),
            end=int(float(row.get("window_end") or row["window_start"])),
            context={k[4:]: (v or None) for k, v in row.items() if k.startswith("ctx.")},
            stats={k[5:]: s for k, v in row.items() if k.startswith("stat.") and (s := _float(v)) is not None},
            pixels=int(float(row.get("width") or 0) * float(row.get("height") or 0)),
            schedule=row.get("schedule") or "",
        )
    failed = _flag(row, "failed")
    x = row["extractor"]
    if not failed and (a := _float(row.get("ate_rmse"))) is not None and a < w.ate.get(x, float("inf")):
        w.ate[x] = a
    if _flag(row, "best_for_extractor") and not failed:
        w.best_params[x] = json.loads(row["params"])
        w.metrics[x] = {k[2:]: m for k, v in row.items() if k.startswith("m.") and (m := _float(v)) is not None}
    if _flag(row, "best_overall") and not failed:
        w.label = x


def split(windows: Sequence[Window], val_sequences: Sequence[str] | None = None) -> tuple[list[Window], list[Window], str]:
    """Train/validation by sequence: ``val_sequences`` (keys "dataset/sequence" or bare names) or the last
    sequence; with a single sequence, its first half of frames trains and its second half validates
    (windows straddling the middle are dropped), with every corruption of a window on the same side."""
    keys = sorted({w.seq_key for w in windows})
    if len(keys) >= 2:
        wanted = set(val_sequences) if val_sequences else {keys[-1]}
        val_keys = {k for k in keys if k in wanted or k.split("/", 1)[1] in wanted}
        if not val_keys or val_keys == set(keys):
            raise ValueError(f"validation sequences {sorted(wanted)} must name some but not all of {keys}")
        tr = [w for w in windows if w.seq_key not in val_keys]
        va = [w for w in windows if w.seq_key in val_keys]
        return tr, va, f"split by sequence: train {sorted(set(keys) - val_keys)}, validate {sorted(val_keys)}"
    if not keys:
        raise ValueError("the table has no windows")
    lo, hi = min(w.start for w in windows), max(w.end for w in windows)
    mid = (lo + hi) // 2
    tr = [w for w in windows if w.end <= mid]
    va = [w for w in windows if w.start >= mid]
    note = (
        f"one sequence ({keys[0]}): split by contiguous halves of its frames, train [{lo}, {mid}), "
        f"validate [{mid}, {hi}]; {len(windows) - len(tr) - len(va)} windows straddling frame {mid} dropped"
    )
    return tr, va, note


Fold = tuple[list[Window], list[Window]]  # (train, validate)


def folds(windows: Sequence[Window], val_sequences: Sequence[str] | None = None) -> tuple[list[Fold], str]:
    """The validation folds. With two or more sequences, leave-one-sequence-out: each sequence is validated
    once, by a model trained on all the others. ``val_sequences`` names one held-out set instead, and a
    table of one sequence is split by the halves of its frames (``split``)."""
    keys = sorted({w.seq_key for w in windows})
    if val_sequences or len(keys) < 2:
        tr, va, note = split(windows, val_sequences)
        return [(tr, va)], note
    out = [([w for w in windows if w.seq_key != k], [w for w in windows if w.seq_key == k]) for k in keys]
    return out, f"leave-one-sequence-out: {len(keys)} folds, each of {keys} validated by a model trained on the others"


ImageSource = Callable[[Window], "np.ndarray | None"]


def default_image_source(data_dir: Path) -> ImageSource:
    """The first frame of a window under the sweep's own condition (``nfex_slam.datasets.schedule.under``); where
    the loader cannot open the sequence, an uncorrupted KITTI frame is read from its file directly, and otherwise
    the window has no image (it still trains, with the image bit at 0)."""
    from nfex_slam.datasets import open_sequence
    from nfex_slam.datasets.schedule import under

    cache: dict[tuple[str, ...], Any] = {}

    def source(w: Window) -> np.ndarray | None:
        key = (w.dataset, w.sequence, w.corruption, w.schedule, w.severity, w.seed)
        try:
            if key not in cache:
                seq = open_sequence(data_dir / w.dataset, w.dataset, w.sequence)
                cache[key] = under(seq, w.corruption, float(w.severity or 1), int(float(w.seed or 0)), w.schedule or None)
            return prepare_image(cache[key][w.start].image)
        except Exception as e:  # noqa: BLE001 - a window without its image still trains
            log.debug("no image for %s: %s", w.seq_key, e)
        if w.dataset == "kitti" and w.corruption in ("", "none"):
            import cv2

            p = data_dir / "kitti" / "sequences" / w.sequence / "image_0" / f"{w.start:06d}.png"
            img = cv2.imread(str(p), cv2.IMREAD_GRAYSCALE)
            return prepare_image(img) if img is not None else None
        return None

    return source
