"""Errors of one VO run, whole and by part: the run's ATE and RPE, per segment of a schedule, and the
frame pairs that straddle a change of conditions.

One Sim(3) alignment of the whole estimate onto the ground truth (evo ``-as``) gives the per-frame
position errors e_i and, with its scale, the per-pair relative translation errors r_k of the pairs
(k−1, k) (evo ``rpe`` with Δ = 1 frame). Then

- ATE = RMSE(e_i) over all frames; RPE = RMSE(r_k) over all pairs;
- a segment's ATE = RMSE(e_i) over its frames, its RPE = RMSE(r_k) over the pairs inside it;
- a segment's lost and coasted pairs (``outcomes``) and, with the run's front-end figures, the pose AUC at
  10° of its pairs;
- a transition pair (k−1, k), k the first frame of a segment: its r_k, its rotation and direction errors
  against the ground truth (``motion.pair_errors``), the configuration that measured it, whether it was
  tracked, and its outcome.

A segment's ATE under the global alignment says how much of the run's ATE accrued there: the frames of
a segment also carry the drift that earlier segments left.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from nfex_slam.datasets.schedule import Schedule
from nfex_slam.vo import VOResult

if TYPE_CHECKING:
    from .outcomes import FrontEnd


@dataclass(frozen=True)
class RunErrors:
    ate: float | None
    rpe: float | None
    frame_errors: np.ndarray | None  # e_i
    pair_errors: np.ndarray | None  # r_k for k = 1..N−1 (index k−1)


def run_errors(ground_truth: np.ndarray | None, res: VOResult, failed: bool | None = None) -> RunErrors:
    """ATE and RPE of ``res`` against ``ground_truth`` (N×4×4 poses of the same frames); none for a failed
    run (``failed``: the evaluation's verdict, ``outcomes``; by default the VO's own)."""
    from nfex_slam.trajectory import Trajectory, ate, rpe

    from ..errors import NfexError

    if ground_truth is None or (res.failed if failed is None else failed) or len(res.frames) < 3:
        return RunErrors(None, None, None, None)
    ref = Trajectory(res.timestamps.copy(), np.asarray(ground_truth[: len(res.frames)], dtype=float))
    est = Trajectory(res.timestamps.copy(), res.poses.copy())
    try:
        a = ate(ref, est, align="sim3")
        r = rpe(ref, est, align="sim3")
    except (NfexError, np.linalg.LinAlgError):
        return RunErrors(None, None, None, None)
    if not math.isfinite(a.rmse):
        return RunErrors(None, None, None, None)
    return RunErrors(float(a.rmse), float(r.rmse), a.errors, r.errors)


def _rmse(x: np.ndarray) -> float | None:
    return float(np.sqrt(np.mean(x * x))) if x.size else None


def by_segment(errors: RunErrors, res: VOResult, schedule: Schedule, front: FrontEnd | None = None) -> list[dict[str, Any]]:
    """One row per segment: its frames, ATE and RPE, lost, coasted and rejected pairs, the extractors it ran,
    and (with ``front``) the pose AUC at 10° of its pairs."""
    from .outcomes import COASTED, LOST, outcome

    out = []
    for s in schedule.segments:
        frames = [f for f in res.frames if f.index in s]
        pairs = [f for f in frames if f.index > s.start]  # pairs (k−1, k) inside the segment
        kinds = [outcome(f) for f in pairs]
        row: dict[str, Any] = {"segment": s.label, "corruption": s.corruption, "frames": len(frames),
                               "lost": kinds.count(LOST), "coasted": kinds.count(COASTED),
                               "rejected": sum(f.rejected for f in pairs), "extractors": sorted({f.extractor for f in frames})}
        if front is not None:
            from nfex_slam.trajectory.frontend import pose_auc

            row["auc10"] = pose_auc(front.error_deg[[f.index - 1 for f in pairs]], [10.0])[10.0] if pairs else None
        if errors.frame_errors is not None and errors.pair_errors is not None:
            row["ate"] = _rmse(errors.frame_errors[[f.index for f in frames]])
            row["rpe"] = _rmse(errors.pair_errors[[f.index - 1 for f in pairs]])
        else:
            row["ate"] = row["rpe"] = None
        out.append(row)
    return out


def transitions(errors: RunErrors, res: VOResult, schedule: Schedule) -> list[dict[str, Any]]:
    """One row per frame pair that straddles a change of conditions (``lost``: not tracked, either way)."""
    from .outcomes import outcome

    out = []
    for k in schedule.transitions:
        if k >= len(res.frames):
            continue
        f = res.frames[k]
        out.append({
            "pair": f"{k - 1}-{k}", "transition": schedule.transition_name(k), "extractor": f.extractor,
            "lost": f.lost, "outcome": outcome(f), "rejected": f.rejected, "reason": f.reason,
            "rotation_error_deg": f.errors[0] if f.errors else None,
            "direction_error_deg": f.errors[1] if f.errors else None,
            "rpe": float(errors.pair_errors[k - 1]) if errors.pair_errors is not None else None,
        })
    return out
