"""What each frame pair of a VO run came to, the run's front-end figures, and the motion-prior control.

**Outcomes.** A pair (k−1, k) is *tracked* (its estimate was accepted), *coasted* (an estimate was made but
the front end fell back to the motion prior: a front-end check rejected it — ``FrameRecord.reason``
``check: …`` — or verification sent the pair to the prior — ``verify: …``), or *lost* (the geometry gave no
estimate: too few keypoints, matches or inliers, no essential matrix). A SLAM front end coasts for a frame or
two by design, so coasting is not tracking loss. A run **fails** where more than ``VOResult.max_lost_fraction``
(30 %) of its pairs were lost, or more than ``nfex:maxCoastedFraction`` (graph data,
``rules/pruning/thresholds.ttl``) coasted.

**Front-end figures** (``nfex_slam.trajectory.frontend``) from the run's estimated poses against the ground
truth, with every pair that was not tracked at 180°: pose AUC at 5°, 10° and 20°, and the front-end ATE
(each step's length from the ground truth, SE(3)). They use only the poses and the outcomes, so they hold
for any VO behind ``run_vo``.

**The motion-prior control** (``motion-prior``): frame 0 at the identity, then the first tracked step of a
reference run (the first static method of the evaluation, same condition and run) repeated at constant
velocity, P_k = V^k. It is what coasting alone gives; every pair after that step counts as coasted, and the
control is exempt from the coasting bound (it is all coasting by construction).
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np
from nfex_slam.trajectory.frontend import AUC_THRESHOLDS, frontend_ate, pair_errors
from nfex_slam.vo import FrameRecord, VOResult

if TYPE_CHECKING:
    from ..kg.storage.backends import GraphReader

TRACKED, COASTED, LOST = "tracked", "coasted", "lost"
COAST_REASONS = ("check:", "verify:", "prior:")
MOTION_PRIOR = "motion-prior"
DEFAULT_MAX_COASTED = 0.5  # where the graph states no nfex:maxCoastedFraction


def outcome(f: FrameRecord) -> str:
    """The outcome of the pair that ends at frame ``f`` (module docstring)."""
    if not f.lost:
        return TRACKED
    return COASTED if f.reason.startswith(COAST_REASONS) else LOST


@dataclass(frozen=True)
class Outcomes:
    pairs: int
    lost: int
    coasted: int

    @classmethod
    def of(cls, res: VOResult) -> Outcomes:
        kinds = [outcome(f) for f in res.frames[1:]]
        return cls(len(kinds), kinds.count(LOST), kinds.count(COASTED))

    def fails(self, max_lost: float, max_coasted: float | None) -> bool:
        n = max(self.pairs, 1)
        return self.pairs < 1 or self.lost / n > max_lost or (max_coasted is not None and self.coasted / n > max_coasted)


def max_coasted_fraction(kg: GraphReader) -> float:
    """``nfex:maxCoastedFraction``'s value in the graph (``DEFAULT_MAX_COASTED`` where it states none)."""
    from ..kg.rdf.terms import py

    rows = kg.select("SELECT ?v WHERE { nfex:maxCoastedFraction nfex:value ?v }").rows
    return float(py(rows[0]["v"])) if rows else DEFAULT_MAX_COASTED


@dataclass(frozen=True)
class FrontEnd:
    """A run's front-end figures; ``auc`` keyed by threshold (degrees)."""

    auc: dict[float, float]
    ate: float | None
    rotation_deg: np.ndarray  # per pair (k−1, k) at index k−1, of the trajectory's relative motion
    direction_deg: np.ndarray
    error_deg: np.ndarray  # max of the two; 180 where the pair was not tracked


def frontend(ground_truth: np.ndarray | None, res: VOResult) -> FrontEnd | None:
    """The front-end figures of ``res`` (None without ground truth for every frame or with under 2 frames)."""
    n = len(res.frames)
    if ground_truth is None or n < 2 or len(ground_truth) < n or not np.isfinite(ground_truth[:n]).all():
        return None
    gt = np.asarray(ground_truth[:n], dtype=float)
    failed = [outcome(f) != TRACKED for f in res.frames[1:]]
    e = pair_errors(res.poses, gt, failed)
    ate = frontend_ate(res.poses, gt, res.timestamps) if n >= 3 else None
    return FrontEnd(e.auc(AUC_THRESHOLDS), ate, e.rotation, e.direction, e.error)


def motion_prior(reference: VOResult) -> VOResult:
    """The motion-prior control run from ``reference`` (module docstring)."""
    frames = reference.frames
    first = next((k for k in range(1, len(frames)) if outcome(frames[k]) == TRACKED), None)
    velocity = np.eye(4) if first is None else np.linalg.inv(reference.poses[first - 1]) @ reference.poses[first]
    poses = np.empty((len(frames), 4, 4))
    pose = np.eye(4)
    for k in range(len(frames)):
        poses[k] = pose
        pose = pose @ velocity
    records: list[FrameRecord] = []
    source = f"prior: constant velocity from pair {first - 1}-{first}" if first is not None else "prior: nothing tracked"
    for k, f in enumerate(frames):
        if first is not None and k <= first and (k == 0 or k == first):
            records.append(f)  # the measured steps the prior comes from (frame 0 and the first tracked pair)
        else:
            records.append(replace(f, keypoints=0, matches=0, inliers=0, extraction_ms=0.0, matching_ms=0.0,
                                   lost=k > 0, reason=source if k > 0 else "", estimate=None, errors=None, tries=0,
                                   verdict=None, metrics={}))
    return VOResult(poses, reference.timestamps.copy(), records, reference.max_lost_fraction, reference.width,
                    reference.height)
