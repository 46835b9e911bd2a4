"""Front-end accuracy of a VO run: per-pair pose errors, pose AUC and the ATE with ground-truth step lengths.

What the extractor controls is each frame pair's relative pose; a monocular VO's end-to-end ATE also
carries its scale chain. These figures judge the pairs alone, from any VO's estimated trajectory
(camera-to-world poses P_k) and the ground truth (Q_k) of the same frames.

Per pair (k−1, k), the relative motion T = P_{k−1}⁻¹ P_k = [R | c] (camera k in camera k−1: c is the
direction the camera moved in) and likewise the truth [R* | c*]:

- rotation error  e_R = ∠(R*ᵀ R) = arccos((tr(R*ᵀR) − 1)/2), degrees;
- direction error e_t = ∠(c, c*), degrees — the scale is unobservable, only the direction counts; 0
  where the truth does not translate, 90° where the estimate does not translate but the truth does;
- pair error e = max(e_R, e_t) (SuperGlue, Sarlin et al. CVPR 2020, §5.2; LightGlue; XFeat), and
  e = 180° where the pair was lost or coasted (``failed``): a pair the front end did not measure
  earns nothing.

Pose AUC at a threshold τ: the area under the cumulative error curve (the share of pairs with e ≤ x,
for x from 0 to τ, interpolated linearly between the sorted errors), divided by τ — the trapezoid rule
of SuperGlue's ``pose_auc``. A perfect front end gives 1; one that loses every pair gives 0.

Front-end ATE: the estimate re-chained from P_0 with each step's rotation and direction and the ground
truth's step length, T_k = R, c·‖c*‖/‖c‖ (pySLAM's VO with ground-truth scale), then the ATE RMSE after
SE(3) Umeyama alignment (``ate``). It removes the scale chain and keeps the errors that accumulate from
rotations and directions. Each figure is unchanged by a similarity transform S·P_k of the estimate.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

LOST_DEG = 180.0
AUC_THRESHOLDS = (5.0, 10.0, 20.0)
_EPS = 1e-12


def relative(poses: np.ndarray) -> np.ndarray:
    """(N−1, 4, 4): T_k = P_{k−1}⁻¹ P_k for each consecutive pair of camera-to-world poses (N, 4, 4)."""
    p = np.asarray(poses, dtype=float)
    return np.asarray(np.linalg.inv(p[:-1]) @ p[1:])


def _angle_deg(cos: np.ndarray) -> np.ndarray:
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def rotation_errors(est: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """e_R per pair (degrees) between relative motions (M, 4, 4) of the estimate and the reference."""
    r = np.transpose(ref[:, :3, :3], (0, 2, 1)) @ est[:, :3, :3]
    return _angle_deg((np.trace(r, axis1=1, axis2=2) - 1.0) / 2.0)


def direction_errors(est: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """e_t per pair (degrees): the angle between the translations of two relative motions (module docstring)."""
    a, b = est[:, :3, 3], ref[:, :3, 3]
    na, nb = np.linalg.norm(a, axis=1), np.linalg.norm(b, axis=1)
    moved_a, moved_b = na > _EPS * np.maximum(1.0, nb), nb > _EPS
    cos = np.einsum("ij,ij->i", a, b) / np.where(moved_a & moved_b, na * nb, 1.0)
    out = np.where(moved_a & moved_b, _angle_deg(cos), 0.0)
    return np.where(moved_b & ~moved_a, 90.0, out)


@dataclass(frozen=True)
class PairErrors:
    """Per pair (k−1, k), k = 1..N−1 at index k−1: e_R, e_t and e (180° where failed), degrees."""

    rotation: np.ndarray
    direction: np.ndarray
    error: np.ndarray
    failed: np.ndarray  # bool: lost or coasted

    def auc(self, thresholds: Sequence[float] = AUC_THRESHOLDS) -> dict[float, float]:
        return pose_auc(self.error, thresholds)


def pair_errors(est_poses: np.ndarray, ref_poses: np.ndarray, failed: Sequence[bool] | np.ndarray | None = None) -> PairErrors:
    """The pair errors of an estimated trajectory against the reference (same frames); ``failed[k−1]``
    marks pair (k−1, k) as lost or coasted."""
    est, ref = np.asarray(est_poses, dtype=float), np.asarray(ref_poses, dtype=float)
    if est.shape != ref.shape or est.ndim != 3 or est.shape[1:] != (4, 4):
        raise ValueError(f"pair errors need two (N, 4, 4) trajectories of one shape, got {est.shape} and {ref.shape}")
    n = max(len(est) - 1, 0)
    bad = np.zeros(n, dtype=bool) if failed is None else np.asarray(failed, dtype=bool).reshape(-1)
    if bad.shape != (n,):
        raise ValueError(f"failed has {bad.size} entries for {n} pairs")
    if n == 0:
        empty = np.zeros(0)
        return PairErrors(empty, empty, empty, bad)
    te, tr = relative(est), relative(ref)
    rot, direction = rotation_errors(te, tr), direction_errors(te, tr)
    return PairErrors(rot, direction, np.where(bad, LOST_DEG, np.maximum(rot, direction)), bad)


def pose_auc(errors: Sequence[float] | np.ndarray, thresholds: Sequence[float] = AUC_THRESHOLDS) -> dict[float, float]:
    """AUC of the cumulative error curve up to each threshold, normalised by it (SuperGlue's ``pose_auc``);
    no errors give 0."""
    e = np.sort(np.asarray(errors, dtype=float).reshape(-1))
    if e.size == 0:
        return {float(t): 0.0 for t in thresholds}
    recall = np.arange(1, e.size + 1) / e.size
    e, recall = np.r_[0.0, e], np.r_[0.0, recall]
    out: dict[float, float] = {}
    for t in thresholds:
        last = int(np.searchsorted(e, t))
        r = np.r_[recall[:last], recall[last - 1]]
        x = np.r_[e[:last], t]
        out[float(t)] = float(np.sum((x[1:] - x[:-1]) * (r[1:] + r[:-1]) / 2.0) / t)
    return out


def rechain_with_truth_lengths(est_poses: np.ndarray, ref_poses: np.ndarray) -> np.ndarray:
    """The estimate chained from its first pose with each step's rotation and direction and the reference's
    step length; a step without translation in the estimate stays without."""
    est, ref = np.asarray(est_poses, dtype=float), np.asarray(ref_poses, dtype=float)
    steps = relative(est)
    lengths = np.linalg.norm(relative(ref)[:, :3, 3], axis=1)
    norms = np.linalg.norm(steps[:, :3, 3], axis=1)
    steps[:, :3, 3] *= np.where(norms > _EPS, lengths / np.where(norms > _EPS, norms, 1.0), 0.0)[:, None]
    out = np.empty_like(est)
    out[0] = est[0]
    for k, step in enumerate(steps, start=1):
        out[k] = out[k - 1] @ step
    return out


def frontend_ate(est_poses: np.ndarray, ref_poses: np.ndarray, timestamps: np.ndarray | None = None) -> float | None:
    """ATE RMSE (SE(3) alignment) of ``rechain_with_truth_lengths``; None where the alignment is degenerate."""
    from ..errors import NfexError
    from .ate import ate
    from .io import Trajectory

    ref = np.asarray(ref_poses, dtype=float)
    stamps = np.arange(len(ref), dtype=float) if timestamps is None else np.asarray(timestamps, dtype=float)
    try:
        chained = rechain_with_truth_lengths(est_poses, ref)
        value = ate(Trajectory(stamps.copy(), ref.copy()), Trajectory(stamps.copy(), chained), align="se3").rmse
    except (NfexError, np.linalg.LinAlgError):
        return None
    return float(value) if math.isfinite(value) else None


__all__ = ["AUC_THRESHOLDS", "LOST_DEG", "PairErrors", "frontend_ate", "pair_errors", "pose_auc", "rechain_with_truth_lengths",
           "relative"]
