"""The feature-quality metrics m1–m7 (paper §IV-B-3), each normalised to [0, 1].

F_metrics(α | Θ′, E) = Σ_x h_x(E)·m_x (``fitness.f_metrics``) sums them, so each is a number in [0, 1]
that means the same for every extractor: computed on the features' positions, on fixed-size
intensity patches around them (not on each extractor's own scale) and on descriptor distances
normalised by the largest distance the descriptor kind allows. Where the paper leaves a definition
open a standard one is used, named in each function. ``PATCH`` (7×7 px), ``SHIFT`` (2 px),
``GRID`` (16 cells on the longer side) and ``EPSILON`` (3 px) are at the scoring resolution (a QQVGA-sized copy, ``Advisor.score_pixels``).

Single-frame metrics: m1 texturedness, m2 dissimilarity, m5 density, m6 distinctiveness. Temporal
metrics — m3 motion (lower is better), m4 stability, m7 repeatability — need the previous frame's
features and are absent from the result without them (not 0). With no feature at all, single-frame
metrics are 0 and temporal ones their worst value (motion 1, stability and repeatability 0).
"""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from nfex_slam.features import Features, as_grey_u8

PATCH = 7  # side of the intensity patch around a feature (px)
SHIFT = 2  # Moravec shift (px)
GRID = 16  # density grid: cells along the longer image side
EPSILON = 3.0  # repeatability / inlier tolerance (px), as the ε-repeatability of Schmid et al. 2000
MOTION_SCALE = 0.1  # a median displacement of 10 % of the image diagonal gives motion 1
DISSIMILARITY_HALF = 8.0  # grey levels of mean absolute difference that give dissimilarity 0.5
RATIO = 0.8  # Lowe's (2004) ratio test for a correspondence
MAX_DESCRIPTORS = 1000  # strongest features used for descriptor metrics (bounds the O(N²) matching)
SINGLE_FRAME = ("texturedness", "dissimilarity", "density", "distinctiveness")  # what compute_metrics always gives
TEMPORAL = ("motion", "stability", "repeatability")  # what it adds with the previous frame's features
_SHIFTS = [(dy, dx) for dy in (-SHIFT, 0, SHIFT) for dx in (-SHIFT, 0, SHIFT) if (dy, dx) != (0, 0)]


def _patches(grey: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """(N, PATCH+2·SHIFT, PATCH+2·SHIFT) float32 intensity windows centred on the rounded keypoints."""
    r = PATCH // 2 + SHIFT
    padded = cv2.copyMakeBorder(grey, r, r, r, r, cv2.BORDER_REFLECT_101)
    h, w = grey.shape
    cx = np.clip(np.rint(xy[:, 0]).astype(np.intp), 0, w - 1) + r
    cy = np.clip(np.rint(xy[:, 1]).astype(np.intp), 0, h - 1) + r
    off = np.arange(-r, r + 1)
    return padded[(cy[:, None, None] + off[None, :, None]), (cx[:, None, None] + off[None, None, :])].astype(np.float32)


def texturedness(patches: np.ndarray) -> float:
    """m1 = √(Σ(I(a,b) − Ī)²) (paper), taken over each feature's PATCH×PATCH window and normalised.

    Per feature: the RMS deviation of the window from its mean, σ_i = √(Σ(I − Ī)²/n), divided by
    127.5 (the largest σ of 8-bit intensities); m1 = mean_i σ_i/127.5 ∈ [0, 1]. Dividing the paper's
    root sum of squares by √n makes it independent of patch size; taking it at the features measures
    the texture the extractor actually uses. A flat image gives 0.
    """
    if patches.shape[0] == 0:
        return 0.0
    s = SHIFT
    core = patches[:, s : s + PATCH, s : s + PATCH].reshape(patches.shape[0], -1)
    return float(np.clip(np.mean(core.std(axis=1)) / 127.5, 0.0, 1.0))


def dissimilarity(patches: np.ndarray) -> float:
    """m2 = Σ|I_feature − I_surrounding| (paper), as Moravec's self-dissimilarity (Moravec 1980).

    Per feature: D_i = min over the 8 shifts of ±SHIFT px of the mean absolute difference between the
    feature's window and the window shifted into its surroundings — how much the feature differs from
    its most similar neighbouring patch (0 on an edge or a flat area, large at a corner). Normalised as
    m2 = mean_i D_i/(D_i + κ), κ = 8 grey levels, so m2 ∈ [0, 1) and 0.5 at D = κ.
    """
    n = patches.shape[0]
    if n == 0:
        return 0.0
    s = SHIFT
    core = patches[:, s : s + PATCH, s : s + PATCH]
    d = np.full(n, np.inf, np.float32)
    for dy, dx in _SHIFTS:
        moved = patches[:, s + dy : s + dy + PATCH, s + dx : s + dx + PATCH]
        d = np.minimum(d, np.abs(core - moved).mean(axis=(1, 2)))
    return float(np.mean(d / (d + DISSIMILARITY_HALF)))


def density(features: Features) -> float:
    """m5 = number of features / area of region (paper), as grid coverage.

    The image is divided into square cells of side max(H, W)/GRID px; m5 is the share of cells that
    hold at least one feature ∈ [0, 1]. Features per area then counts how evenly the region is
    covered rather than how many points pile up in one textured corner (the coverage view of Ehsan
    et al. 2010, and ORB-SLAM's per-cell distribution of features).
    """
    h, w = features.image_shape
    cell = max(h, w) / GRID
    rows, cols = max(1, int(np.ceil(h / cell))), max(1, int(np.ceil(w / cell)))
    if len(features) == 0:
        return 0.0
    r = np.clip((features.xy[:, 1] / cell).astype(np.intp), 0, rows - 1)
    c = np.clip((features.xy[:, 0] / cell).astype(np.intp), 0, cols - 1)
    return float(np.unique(r * cols + c).size / (rows * cols))


def _strongest(features: Features) -> Features:
    if len(features) <= MAX_DESCRIPTORS:
        return features
    return features.subset(np.sort(np.argsort(-features.response, kind="stable")[:MAX_DESCRIPTORS]))


def _unit(features: Features) -> tuple[np.ndarray, int, float]:
    """Descriptors ready for matching, the norm, and the largest meaningful distance for normalising."""
    d = features.descriptors
    if features.binary:
        bits = d.shape[1] * 8
        # random binary strings are 0.5·bits apart; multi-bit (HAMMING2) norms count 2-bit cells
        return d, features.norm, (0.25 if features.norm == cv2.NORM_HAMMING2 else 0.5) * bits
    x = d.astype(np.float32)
    x = x / np.maximum(np.linalg.norm(x, axis=1, keepdims=True), 1e-12)
    return x, cv2.NORM_L2, float(np.sqrt(2.0))  # non-negative unit vectors are at most √2 apart


def distinctiveness(features: Features) -> float:
    """m6 = 1 / Σ similarity(feature, other features) (paper), as the nearest-other-descriptor distance.

    Per feature: the distance to the most similar other descriptor in the same image, divided by the
    distance of unrelated descriptors (0.5·bits for binary Hamming, √2 for unit-normalised real ones)
    and clipped to 1; m6 is the mean ∈ [0, 1]. Similarity is 1 − that normalised distance, and, as in
    Lowe's (2004) ratio test, a feature is ambiguous when its nearest other neighbour is close. Computed
    on the MAX_DESCRIPTORS strongest features; a single feature is fully distinctive, none gives 0.
    """
    f = _strongest(features)
    if len(f) == 0:
        return 0.0
    if len(f) == 1:
        return 1.0
    d, norm, scale = _unit(f)
    knn = cv2.BFMatcher(norm).knnMatch(d, d, k=2)
    nearest = np.array([m[1].distance if len(m) > 1 else scale for m in knn], np.float32)
    return float(np.mean(np.clip(nearest / scale, 0.0, 1.0)))


@dataclass(frozen=True)
class Correspondence:
    """Ratio-test matches between two frames and the homography H (previous → current)."""

    prev_xy: np.ndarray  # (M, 2) matched previous positions
    cur_xy: np.ndarray  # (M, 2) matched current positions
    inliers: np.ndarray  # (M,) bool: consistent with H within EPSILON
    homography: np.ndarray | None


def correspond(prev: Features, cur: Features) -> Correspondence:
    """Match descriptors (nearest neighbour passing Lowe's ratio test, RATIO) and fit H with RANSAC (EPSILON px).

    One k=2 search instead of a cross-checked pair of searches: half the cost, as selective.
    """
    p, c = _strongest(prev), _strongest(cur)
    empty = np.zeros((0, 2), np.float32)
    if len(p) == 0 or len(c) == 0 or p.descriptors.shape[1] != c.descriptors.shape[1]:
        return Correspondence(empty, empty, np.zeros(0, bool), None)
    dp, norm, _ = _unit(p)
    dc, _, _ = _unit(c)
    pairs = [
        (m[0].queryIdx, m[0].trainIdx)
        for m in cv2.BFMatcher(norm).knnMatch(dc, dp, k=2)
        if m and (len(m) == 1 or m[0].distance < RATIO * m[1].distance)
    ]
    if not pairs:
        return Correspondence(empty, empty, np.zeros(0, bool), None)
    ci, pi = np.array(pairs).T
    pxy, cxy = p.xy[pi], c.xy[ci]
    if len(pairs) < 4:
        return Correspondence(pxy, cxy, np.zeros(len(pairs), bool), None)
    H, mask = cv2.findHomography(pxy, cxy, cv2.RANSAC, EPSILON, maxIters=500, confidence=0.995)
    if H is None:
        return Correspondence(pxy, cxy, np.zeros(len(pairs), bool), None)
    return Correspondence(pxy, cxy, mask.ravel().astype(bool), H)


def _inside(xy: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    h, w = shape
    return (xy[:, 0] >= 0) & (xy[:, 0] <= w - 1) & (xy[:, 1] >= 0) & (xy[:, 1] <= h - 1)


def _project(H: np.ndarray, xy: np.ndarray) -> np.ndarray:
    if len(xy) == 0:
        return xy.reshape(0, 2)
    return cv2.perspectiveTransform(xy.reshape(-1, 1, 2).astype(np.float64), H).reshape(-1, 2)


def motion(corr: Correspondence, shape: tuple[int, int]) -> float:
    """m3 = ‖a_{t+1} − a_t‖ (paper): median displacement of the matched features, normalised.

    The median over the RANSAC-inlier matches (all ratio-test matches when H could not be fitted) of
    ‖a_{t+1} − a_t‖, divided by MOTION_SCALE × the image diagonal and clipped: m3 ∈ [0, 1], lower is
    better; a pure translation by t px gives t / (0.1·diagonal). No match at all gives 1 (lost).
    """
    use = corr.inliers if corr.inliers.any() else np.ones(len(corr.cur_xy), bool)
    if not use.any():
        return 1.0
    disp = np.linalg.norm(corr.cur_xy[use] - corr.prev_xy[use], axis=1)
    return float(np.clip(np.median(disp) / (MOTION_SCALE * np.hypot(*shape)), 0.0, 1.0))


def stability(corr: Correspondence, prev: Features, cur: Features) -> float:
    """m4 = stable features / total features (paper), as Mikolajczyk & Schmid's (2005) matching score.

    A feature is stable when it is tracked: its descriptor's nearest neighbour in the previous frame
    passes Lowe's ratio test and lies where the inter-frame homography H puts it (RANSAC inlier,
    EPSILON px). m4 = inliers /
    min(N_prev, N_cur) over the features used for matching, clipped to [0, 1]; the same frame twice
    gives 1.
    """
    n = min(len(_strongest(prev)), len(_strongest(cur)))
    return float(min(1.0, corr.inliers.sum() / n)) if n else 0.0


def repeatability(corr: Correspondence, prev: Features, cur: Features) -> float:
    """m7 = re-detected features / total features (paper), as the ε-repeatability of the detector.

    Following Schmid et al. (2000) and Mikolajczyk et al. (2005): previous keypoints are mapped into
    the current frame by the homography H estimated between the frames; one is re-detected when a
    current keypoint lies within EPSILON px of its image. Only the common region counts: m7 = repeated /
    min(previous keypoints mapped inside the current image, current keypoints mapped back inside the
    previous one) ∈ [0, 1]. Descriptors play no part (that is m4). Without H (fewer than 4 matches),
    0. H is exact for planar scenes and pure rotation and approximate under parallax, equally for
    every extractor.
    """
    if corr.homography is None or len(prev) == 0 or len(cur) == 0:
        return 0.0
    H = corr.homography
    projected = _project(H, prev.xy)
    keep = _inside(projected, cur.image_shape)
    try:
        back = _project(np.linalg.inv(H), cur.xy)
    except np.linalg.LinAlgError:
        return 0.0
    n = min(int(keep.sum()), int(_inside(back, prev.image_shape).sum()))
    if n == 0:
        return 0.0
    return float(min(1.0, _near(cur.xy, projected[keep], cur.image_shape).sum() / n))


def _near(targets: np.ndarray, queries: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """For each query point, whether a target point lies within EPSILON px (on the pixel grid).

    The targets are drawn into a mask dilated by a disc of radius EPSILON and the queries looked up:
    O(N + pixels) instead of a nearest-neighbour search.
    """
    h, w = shape
    mask = np.zeros((h, w), np.uint8)
    t = np.rint(targets).astype(np.intp)
    mask[np.clip(t[:, 1], 0, h - 1), np.clip(t[:, 0], 0, w - 1)] = 1
    r = int(EPSILON)
    near = cv2.dilate(mask, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1)))
    q = np.rint(queries).astype(np.intp)
    return near[np.clip(q[:, 1], 0, h - 1), np.clip(q[:, 0], 0, w - 1)].astype(bool)


def compute_metrics(
    features: Features, image: np.ndarray, previous: tuple[Features, np.ndarray] | None = None
) -> dict[str, float]:
    """m1–m7 of ``features`` extracted from ``image``, keyed by the graph's metric tokens.

    ``previous`` is ``(previous_features, previous_image)`` of the same extractor; without it the
    temporal metrics (motion, stability, repeatability) are absent from the result.
    """
    patches = _patches(as_grey_u8(image), features.xy)
    out = {
        "texturedness": texturedness(patches),
        "dissimilarity": dissimilarity(patches),
        "density": density(features),
        "distinctiveness": distinctiveness(features),
    }
    if previous is not None:
        prev = previous[0]
        corr = correspond(prev, features)
        out["motion"] = motion(corr, features.image_shape)
        out["stability"] = stability(corr, prev, features)
        out["repeatability"] = repeatability(corr, prev, features)
    return out
