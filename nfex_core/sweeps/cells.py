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
from nfex_slam.datasets.base import Frame, Sequence
from nfex_slam.motion import NO_CHECKS, StepChecks, motion_direction, relative_truth, rotation_deg

from ..kg.vocabulary.vocab import ExtractorSpec

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
    schedule: str = ""  # with corruption "schedule": the schedule over the whole sequence (datasets.schedule)
    checks: tuple[float | None, float | None] = (None, None)  # the agent's front-end limits (motion.StepChecks)

    @property
    def key(self) -> str:
        """Stable identity of the cell (the data path is not part of it: the same data moved is the same cell)."""
        d = asdict(self)
        d.pop("path")
        if not d["schedule"]:  # absent from the keys of cells made before schedules and checks existed
            d.pop("schedule")
        if tuple(d["checks"]) == (None, None):
            d.pop("checks")
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
    from nfex_slam.datasets import open_sequence

    key = (cell.path, cell.format, cell.sequence, cell.corruption, cell.severity, cell.seed, cell.schedule)
    seq = _SEQUENCES.get(key)
    if seq is None:
        from nfex_slam.datasets.schedule import under

        seq = under(open_sequence(cell.path, cell.format, cell.sequence or None), cell.corruption, cell.severity,
                    seed=cell.seed, schedule=cell.schedule)
        seq = _SEQUENCES[key] = _CachedSequence(seq)
        if len(_SEQUENCES) > 4:
            _SEQUENCES.popitem(last=False)
    else:
        _SEQUENCES.move_to_end(key)
    return seq


def run_cell(cell: Cell, specs: Mapping[str, ExtractorSpec] | None = None) -> dict[str, Any]:
    """Measure one cell; returns its training-table row (never raises for tracking failure)."""
    from nfex_slam.vo import fixed, run_vo, window_errors

    from ..vision.context import frame_statistics
    from ..vision.metrics import compute_metrics

    if _REGISTRY is None or specs is not None:
        init_worker(specs or {})
    seq = load_sequence(cell)
    params = json.loads(cell.params)
    def measure(feats: Any, image: np.ndarray, previous: Any) -> dict[str, float]:
        # m1–m7 on every METRIC_EVERY-th frame of the window (with its predecessor for the temporal
        # ones): for SIFT on a KITTI frame they cost as much as the extraction itself
        return compute_metrics(feats, image, previous) if (counter.__next__() % METRIC_EVERY == 0) else {}

    counter = iter(range(10**9))
    checks = StepChecks(*cell.checks, agent=seq.context.get("agent", "")) if any(c is not None for c in cell.checks) else NO_CHECKS
    res = run_vo(seq, fixed(cell.extractor, params), registry=_REGISTRY, measure=measure,
                 start=cell.start, stop=cell.stop, checks=checks)
    first = seq[cell.start]
    labels = [dict(seq[i].context) for i in range(cell.start, min(cell.stop, len(seq)))]
    # the labels that held on every frame of the window (a window across a change of conditions keeps the common ones)
    ctx = {**seq.context, **{d: v for d, v in labels[0].items() if all(x.get(d) == v for x in labels)}}
    segments = _segments(seq, cell)
    ate_rmse, rpe_rmse = window_errors(seq, res) if not res.failed else (None, None)
    failed = res.failed or ate_rmse is None
    row: dict[str, Any] = {
        "dataset": seq.dataset, "sequence": seq.name, "corruption": cell.corruption, "schedule": cell.schedule,
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
    row.update(pair_summary(res))
    row["transition"] = ",".join(f"{a}→{b}" for a, b in zip(segments, segments[1:], strict=False) if a != b)
    row.update({f"m.{k}": v for k, v in res.metric_means().items()})
    row.update({f"stat.{k}": float(v) for k, v in frame_statistics(first.image).items()})
    row["cell"] = cell.key
    row["_pairs"] = pair_rows(cell, seq, res, segments)
    return row


BAD_PAIR_DEG = 5.0  # a pair whose rotation or direction error exceeds this counts as bad


def _segments(seq: Sequence, cell: Cell) -> list[str]:
    """The corruption of each frame of the window (its segment's, under a schedule)."""
    schedule = getattr(getattr(seq, "inner", seq), "schedule", None)
    if schedule is None:
        return [cell.corruption] * (cell.stop - cell.start)
    return [schedule.segment_of(i).corruption for i in range(cell.start, min(cell.stop, len(seq)))]


def pair_summary(res: Any) -> dict[str, Any]:
    """Per window: the median rotation and direction errors of the pairs' estimates and the fraction of bad pairs."""
    pairs = res.frames[1:]
    if not pairs:
        return {}
    errs = [f.errors for f in pairs if f.errors is not None]
    bad = sum(f.lost or f.errors is None or max(f.errors) > BAD_PAIR_DEG for f in pairs)
    out: dict[str, Any] = {"bad_pair_fraction": bad / len(pairs)}
    if errs:
        out["pair_rotation_error_deg"] = float(np.median([e[0] for e in errs]))
        out["pair_direction_error_deg"] = float(np.median([e[1] for e in errs]))
    return out


def pair_rows(cell: Cell, seq: Sequence, res: Any, segments: list[str]) -> list[dict[str, Any]]:
    """One row per frame pair of the window: what the configuration's estimate showed, and its error."""
    out = []
    poses = seq.poses  # the ground truth as an array: seq[i].pose would decode frame i's image again
    for j, f in enumerate(res.frames[1:], start=1):
        truth = _truth(poses, res.frames[j - 1].index, f.index)
        est = f.estimate
        rvec = _rotvec(est[0]) if est is not None else (None, None, None)
        direction = motion_direction(*est) if est is not None else (None, None, None)
        before, after = segments[j - 1], segments[j] if j < len(segments) else segments[-1]
        out.append({
            "cell": cell.key, "dataset": seq.dataset, "sequence": seq.name, "corruption": cell.corruption,
            "severity": cell.severity, "seed": cell.seed, "window_start": cell.start, "frame": cell.start + j,
            "before": before, "after": after, "transition": f"{before}→{after}" if before != after else "",
            "extractor": cell.extractor, "params": cell.params, "keypoints": f.keypoints, "matches": f.matches,
            "inliers": f.inliers, "lost": int(f.lost), "rejected": int(f.rejected), "reason": f.reason,
            "rotation_deg": rotation_deg(est[0]) if est is not None else None,
            "rotation_error_deg": f.errors[0] if f.errors else None, "direction_error_deg": f.errors[1] if f.errors else None,
            "parallax_px": f.parallax_px, "extraction_ms": f.extraction_ms,
            "rx": rvec[0], "ry": rvec[1], "rz": rvec[2], "dx": direction[0], "dy": direction[1], "dz": direction[2],
            "true_rx": truth[0], "true_ry": truth[1], "true_rz": truth[2],
            "true_dx": truth[3], "true_dy": truth[4], "true_dz": truth[5],
        })
    return out


def _truth(poses: np.ndarray | None, a: int, b: int) -> tuple[float | None, ...]:
    """The true relative motion of frames a → b as a rotation vector and a unit direction of motion (Nones
    without poses): what a verifier's choices are scored against (sweeps/verification.py)."""
    if poses is None:
        return (None,) * 6
    R, t = relative_truth(poses[a], poses[b])
    return (*_rotvec(R), *(float(v) for v in motion_direction(R, t)))


def _rotvec(R: np.ndarray) -> tuple[float, float, float]:
    import cv2

    v, _ = cv2.Rodrigues(np.asarray(R, dtype=float))
    return float(v[0, 0]), float(v[1, 0]), float(v[2, 0])
