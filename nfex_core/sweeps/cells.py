"""One sweep cell — a configuration (α, Θ) on one window of one (possibly corrupted) sequence — and
the work of measuring it, run in a worker process (or a Ray task).

A cell's row is one line of the training table (HELPERS.md, "The sweep's training table"): ATE with
Sim(3) alignment and RPE over consecutive frames (monocular, evo ``-as``), tracking loss, matches,
window means of m1–m7, per-frame extraction and matching time, frame size, and the first frame's
statistics. Workers get the extractor specs (not a store: an embedded store has one writer) and keep
the sequences and decoded frames they have seen, so consecutive cells on one window decode it once.
"""
from __future__ import annotations

import hashlib
import json
from collections import OrderedDict
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from ..datasets.base import Frame, Sequence
from ..kg.vocab import ExtractorSpec

METRIC_EVERY = 3  # window means of m1–m7 from frames 0, 3, 6, … of the window
DIMENSIONS = ("agent", "motion", "scene", "light", "reflectance", "texture")


@dataclass(frozen=True)
class Cell:
    format: str  # kitti | euroc | tum | handheld
    path: str
    sequence: str
    corruption: str  # "none" or a corruption name
    severity: float
    seed: int
    start: int
    stop: int
    extractor: str
    params: str  # canonical JSON of the full Θ

    @property
    def key(self) -> str:
        """Stable identity of the cell (the data path is not part of it: the same data moved is the same cell)."""
        d = asdict(self)
        d.pop("path")
        return hashlib.sha1(json.dumps(d, sort_keys=True).encode()).hexdigest()[:20]

    @property
    def window_key(self) -> tuple[str, str, str, float, int, int]:
        return (self.format, self.sequence, self.corruption, self.severity, self.seed, self.start)


class _CachedSequence(Sequence):
    """A view of a sequence that keeps recently decoded (and corrupted) frames."""

    def __init__(self, inner: Sequence, size: int = 256) -> None:
        self.inner = inner
        self.dataset, self.name = inner.dataset, inner.name
        self.intrinsics, self.context = inner.intrinsics, inner.context
        self._frames: OrderedDict[int, Frame] = OrderedDict()
        self._size = size

    def __len__(self) -> int:
        return len(self.inner)

    def __getitem__(self, i):
        f = self._frames.get(i)
        if f is None:
            f = self._frames[i] = self.inner[i]
            if len(self._frames) > self._size:
                self._frames.popitem(last=False)
        else:
            self._frames.move_to_end(i)
        return f

    @property
    def timestamps(self) -> np.ndarray:
        return self.inner.timestamps

    @property
    def poses(self) -> np.ndarray | None:
        return self.inner.poses


_REGISTRY: Any = None
_SEQUENCES: OrderedDict[tuple[Any, ...], Sequence] = OrderedDict()


def init_worker(specs: Mapping[str, ExtractorSpec]) -> None:
    """Process-pool initializer: the extractor registry from the graph's specs."""
    global _REGISTRY
    from ..vision.registry import ExtractorRegistry

    _REGISTRY = ExtractorRegistry(specs)


def load_sequence(cell: Cell) -> Sequence:
    from ..datasets import open_sequence

    key = (cell.path, cell.format, cell.sequence, cell.corruption, cell.severity, cell.seed)
    seq = _SEQUENCES.get(key)
    if seq is None:
        seq = open_sequence(cell.path, cell.format, cell.sequence or None)
        if cell.corruption != "none":
            from ..datasets.corruptions import corrupt

            seq = corrupt(seq, cell.corruption, cell.severity, seed=cell.seed)
        seq = _SEQUENCES[key] = _CachedSequence(seq)
        if len(_SEQUENCES) > 4:
            _SEQUENCES.popitem(last=False)
    else:
        _SEQUENCES.move_to_end(key)
    return seq


def run_cell(cell: Cell, specs: Mapping[str, ExtractorSpec] | None = None) -> dict[str, Any]:
    """Measure one cell; returns its training-table row (never raises for tracking failure)."""
    from ..vision.context import frame_statistics
    from ..vision.metrics import compute_metrics
    from ..vo import fixed, run_vo

    if _REGISTRY is None or specs is not None:
        init_worker(specs or {})
    seq = load_sequence(cell)
    params = json.loads(cell.params)
    def measure(feats: Any, image: np.ndarray, previous: Any) -> dict[str, float]:
        # m1–m7 on every METRIC_EVERY-th frame of the window (with its predecessor for the temporal
        # ones): for SIFT on a KITTI frame they cost as much as the extraction itself
        return compute_metrics(feats, image, previous) if (counter.__next__() % METRIC_EVERY == 0) else {}

    counter = iter(range(10**9))
    res = run_vo(seq, fixed(cell.extractor, params), registry=_REGISTRY, measure=measure,
                 start=cell.start, stop=cell.stop)
    first = seq[cell.start]
    ctx = {**seq.context, **first.context}
    ate_rmse, rpe_rmse = window_errors(seq, res) if not res.failed else (None, None)
    failed = res.failed or ate_rmse is None
    row: dict[str, Any] = {
        "dataset": seq.dataset, "sequence": seq.name, "corruption": cell.corruption,
        "severity": cell.severity if cell.corruption != "none" else 0.0, "seed": cell.seed,
        "window_start": cell.start, "window_end": cell.stop, "frames": len(res.frames),
    }
    row.update({f"ctx.{d}": ctx.get(d, "") or "" for d in DIMENSIONS})
    row.update({
        "extractor": cell.extractor, "params": cell.params,
        "ate_rmse": None if failed else ate_rmse, "rpe_rmse": None if failed else rpe_rmse,
        "tracking_lost": res.lost_count, "failed": int(failed),
        "mean_matches": res.mean("matches", skip_first=True), "mean_inliers": res.mean("inliers", skip_first=True),
        "mean_keypoints": res.mean("keypoints"), "extraction_ms": res.mean("extraction_ms"),
        "matching_ms": res.mean("matching_ms", skip_first=True), "width": res.width, "height": res.height,
    })
    row.update({f"m.{k}": v for k, v in res.metric_means().items()})
    row.update({f"stat.{k}": float(v) for k, v in frame_statistics(first.image).items()})
    row["cell"] = cell.key
    return row


def window_errors(seq: Sequence, res: Any) -> tuple[float | None, float | None]:
    """ATE RMSE (Sim(3), as evo ``-as``) and RPE RMSE (consecutive frames, after the same Sim(3)
    scale) of a VO result against the ground truth; (None, None) without ground truth or when the
    alignment is degenerate (e.g. the estimate does not move)."""
    from ..errors import NfexError
    from ..trajectory import Trajectory, ate, rpe

    gt = np.array([seq[f.index].pose for f in res.frames], dtype=object)
    if any(p is None for p in gt):
        return None, None
    ref = Trajectory(res.timestamps.copy(), np.stack(list(gt)).astype(float))
    est = Trajectory(res.timestamps.copy(), res.poses.copy())
    try:
        a = ate(ref, est, align="sim3")
        r = rpe(ref, est, align="sim3")
    except (NfexError, np.linalg.LinAlgError):
        return None, None
    if not np.isfinite(a.rmse):
        return None, None
    return float(a.rmse), float(r.rmse)
