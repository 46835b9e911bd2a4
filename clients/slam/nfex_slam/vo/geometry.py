"""Two-view geometry of the monocular VO: descriptor matching and relative pose.

Matching (Lowe's ratio test, Lowe 2004 §7.1): for each descriptor of frame k−1 the two nearest
descriptors of frame k under the extractor's own norm (Hamming for ORB/BRISK/AKAZE, L2 for SIFT, as
the graph says); a match is kept when d₁ < ρ·d₂ (ρ = 0.8 by default). Where the graph's matcher for
the extractor is ``mutual-ratio`` (XFeat), a match is also kept only when the previous feature is the
current one's nearest neighbour (mutual nearest neighbours, as XFeat's authors match).

Relative pose (Nistér's five-point algorithm in MAGSAC++, ``cv2.findEssentialMat(method=cv2.USAC_MAGSAC)``, then
the chirality check of ``cv2.recoverPose``): x₂ᵀ E x₁ = 0 with E = [t]ₓR, giving R and a unit-length t such that a
point X₁ in camera k−1 is X₂ = R X₁ + t in camera k. MAGSAC++ (Barath et al. 2020) scores a model by its
likelihood marginalised over the noise scale up to the threshold and polishes the best one on its inliers, with a
failure probability of 10⁻⁵ and at most 10,000 iterations: against plain RANSAC at 0.999 it halves the pair error
on KITTI, and a RANSAC draw moves a SIFT pair's rotation an eighth as much and an ORB_GRID pair's half as much
(``bench/essential_estimators.py``, docs/vo.md). The scale of t is unobservable for one camera; ``pipeline`` decides it.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import cv2
import numpy as np

from ..datasets.base import Intrinsics
from ..datasets.camera import undistort_points
from ..features import Features


@dataclass(frozen=True)
class MatchResult:
    query: np.ndarray  # (M,) indices into the previous frame's features
    train: np.ndarray  # (M,) indices into the current frame's features
    elapsed_ms: float


@dataclass(frozen=True)
class RelativePose:
    R: np.ndarray  # 3×3, camera k−1 → camera k
    t: np.ndarray  # (3,), unit length
    inliers: np.ndarray  # (M,) bool over the matches given
    parallax_px: float  # median image motion of the inliers (undistorted pixels)


def match(prev: Features, cur: Features, ratio: float = 0.8) -> MatchResult:
    """Ratio-test matches from ``prev`` to ``cur`` with the descriptors' norm; timed."""
    t0 = time.perf_counter()
    empty = np.zeros(0, dtype=np.int64)
    if len(prev) < 2 or len(cur) < 2 or prev.descriptors.shape[1] != cur.descriptors.shape[1]:
        return MatchResult(empty, empty, (time.perf_counter() - t0) * 1000)
    if "mutual-ratio" in (prev.matcher, cur.matcher) and cur.norm == cv2.NORM_L2:
        qm, tm = mutual_ratio_l2(prev.descriptors, cur.descriptors, ratio)
        return MatchResult(qm, tm, (time.perf_counter() - t0) * 1000)
    matcher = cv2.BFMatcher(cur.norm, crossCheck=False)
    pairs = matcher.knnMatch(prev.descriptors, cur.descriptors, k=2)
    q: list[int] = []
    t: list[int] = []
    for pair in pairs:
        if len(pair) == 2 and pair[0].distance < ratio * pair[1].distance:
            q.append(pair[0].queryIdx)
            t.append(pair[0].trainIdx)
    # one current feature may win several previous ones: keep the first (they are geometric outliers anyway)
    train = np.asarray(t, dtype=np.int64)
    _, first = np.unique(train, return_index=True)
    keep = np.sort(first)
    return MatchResult(np.asarray(q, dtype=np.int64)[keep], train[keep], (time.perf_counter() - t0) * 1000)


def mutual_ratio_l2(a: np.ndarray, b: np.ndarray, ratio: float, chunk: int = 1024) -> tuple[np.ndarray, np.ndarray]:
    """Mutual nearest neighbours under L2 that pass the ratio test: (indices into a, indices into b).

    Squared distances from one matrix product, ‖x‖² + ‖y‖² − 2x·y, in row chunks (memory stays
    chunk × len(b)); the same pairs as BFMatcher(NORM_L2) knnMatch + a reverse match, at BLAS speed.
    """
    a = np.asarray(a, np.float32)
    b = np.asarray(b, np.float32)
    aa = np.einsum("ij,ij->i", a, a)
    bb = np.einsum("ij,ij->i", b, b)
    col_best = np.full(len(b), np.inf, np.float32)
    col_arg = np.zeros(len(b), np.int64)
    first = np.zeros(len(a), np.int64)
    passes = np.zeros(len(a), bool)
    cols = np.arange(len(b))
    for start in range(0, len(a), chunk):
        x = a[start:start + chunk]
        rows = np.arange(len(x))
        d2 = x @ b.T  # becomes ‖x‖² + ‖y‖² − 2x·y in place: one chunk × len(b) array
        d2 *= -2.0
        d2 += aa[start:start + chunk, None]
        d2 += bb[None, :]
        best = np.argmin(d2, axis=1)
        d1 = d2[rows, best].copy()
        d2[rows, best] = np.inf
        second = d2.min(axis=1)
        d2[rows, best] = d1
        first[start:start + len(x)] = best
        passes[start:start + len(x)] = np.sqrt(np.maximum(d1, 0)) < ratio * np.sqrt(np.maximum(second, 0))
        arg = np.argmin(d2, axis=0)
        val = d2[arg, cols]
        better = val < col_best
        col_best[better], col_arg[better] = val[better], arg[better] + start
    q = np.flatnonzero(passes & (col_arg[first] == np.arange(len(a))))
    return q.astype(np.int64), first[q].astype(np.int64)


def undistort(xy: np.ndarray, intrinsics: Intrinsics) -> np.ndarray:
    """Pixel coordinates with lens distortion removed, for any lens model the loaders know
    (``datasets.camera``: OpenCV radial-tangential, the handheld set's radial model on pixels)."""
    return undistort_points(intrinsics, xy).astype(np.float64)


def relative_pose(
    p1: np.ndarray, p2: np.ndarray, K: np.ndarray, *, threshold_px: float = 1.0, prob: float = 0.99999,
    max_iterations: int = 10_000,
) -> RelativePose | None:
    """R, t from point correspondences (undistorted pixels), or None when MAGSAC++ finds no model."""
    if len(p1) < 5:
        return None
    E, mask = cv2.findEssentialMat(p1, p2, K, method=cv2.USAC_MAGSAC, prob=prob, threshold=threshold_px,
                                   maxIters=max_iterations)
    if E is None or mask is None or E.shape != (3, 3):
        return None  # degenerate, or several solutions stacked (3k×3): take it as no model
    # a large distance threshold: with |t| = 1 the default (50) would drop the far points of a
    # fast-moving car (KITTI highway: most points lie beyond 50 baselines) and fake a tracking loss
    _, R, t, pose_mask, _ = cv2.recoverPose(E, p1, p2, K, distanceThresh=1e6, mask=mask.copy())
    inliers = pose_mask.ravel().astype(bool)
    flow = np.linalg.norm(p2[inliers] - p1[inliers], axis=1) if inliers.any() else np.zeros(1)
    return RelativePose(R, t.ravel() / max(float(np.linalg.norm(t)), 1e-12), inliers, float(np.median(flow)))


def triangulate(p1: np.ndarray, p2: np.ndarray, K: np.ndarray, R: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """3-D points in camera k's frame (camera k−1 at [I|0], camera k at [R|t]) and a validity mask.

    Valid: in front of both cameras (positive depth) and finite.
    """
    if len(p1) == 0:
        return np.zeros((0, 3)), np.zeros(0, dtype=bool)
    P1 = K @ np.hstack([np.eye(3), np.zeros((3, 1))])
    P2 = K @ np.hstack([R, t.reshape(3, 1)])
    X = cv2.triangulatePoints(P1, P2, p1.T.astype(np.float64), p2.T.astype(np.float64))
    w = X[3]
    with np.errstate(divide="ignore", invalid="ignore"):
        X1 = (X[:3] / w).T  # in camera k−1
    X2 = X1 @ R.T + t.reshape(1, 3)
    ok = np.isfinite(X2).all(axis=1) & (X1[:, 2] > 0) & (X2[:, 2] > 0)
    return X2, ok
