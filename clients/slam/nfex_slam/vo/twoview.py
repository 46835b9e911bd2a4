"""One frame pair as the VO estimates it: the candidates tried on it, their relative pose, and the two-view scale chain.

A *try* (``Try``) extracts frame k with a candidate configuration (and frame k−1, unless it was already extracted
with it), matches (``geometry.match``), and estimates R and a unit t from the essential matrix
(``geometry.relative_pose``). Every try's estimate is what the front-end checks, the verification judge and
``FrameRecord.estimate`` see, whichever way the trajectory is then scaled.

``ScaleChain`` is the two-view VO's scale (``VOParams.scale`` = ``"triangulated"``, ``"unit"``, ``"gt"``): the first
step has length 1; each later step's inliers are triangulated (camera k−1 at [I|0], camera k at [R|t], |t| = 1) and
the points also seen in the previous step (same keypoints of frame k−1, so only while the configuration is
unchanged) give s_k = median(‖X_prev‖ / ‖X_cur‖) of their distances from camera k−1, clipped to a factor
``max_scale_change`` of the previous length; without enough common points the previous length is kept.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from ..datasets.base import Frame, Sequence
from ..features import Features
from ..pairs import PairEvidence
from .geometry import MatchResult, match, relative_pose, triangulate, undistort

if TYPE_CHECKING:
    from .pipeline import Choice, Extractors, Measure, VOParams


@dataclass
class Step:
    R: np.ndarray
    t: np.ndarray  # unit
    p1: np.ndarray  # the inliers' undistorted pixels in frame k-1
    p2: np.ndarray  # and in frame k
    parallax_px: float
    matches: tuple[np.ndarray, np.ndarray] = field(default_factory=lambda: (np.zeros(0, np.int64), np.zeros(0, np.int64)))
    # every ratio-test match (query, train), in the seed's order: the local map tracks its points through them
    inlying: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))  # which of ``matches`` are the inliers

    @property
    def query(self) -> np.ndarray:
        """The inliers' keypoint indices in frame k-1."""
        return self.matches[0][self.inlying]

    @property
    def train(self) -> np.ndarray:
        """The inliers' keypoint indices in frame k."""
        return self.matches[1][self.inlying]


@dataclass
class Try:
    """One candidate tried on a frame pair."""

    choice: Choice
    feats: Features
    step: Step | None = None
    matches: int = 0
    inliers: int = 0
    extraction_ms: float = 0.0
    matching_ms: float = 0.0
    reason: str = ""  # why the geometry lost it, or why a front-end check rejected it
    metrics: dict[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not self.extraction_ms:
            self.extraction_ms = self.feats.elapsed_ms

    def evidence(self) -> PairEvidence:
        s = self.step
        return PairEvidence.of(
            self.choice.extractor, self.choice.params, s.R if s is not None else None, s.t if s is not None else None,
            keypoints=len(self.feats), matches=self.matches, inliers=self.inliers,
            parallax_px=s.parallax_px if s is not None else 0.0, extraction_ms=self.extraction_ms, rejected=self.reason,
        )


def try_pair(
    choice: Choice, frame: Frame, prev_frame: Frame, prev_cache: dict[str, Features], seq: Sequence, K: np.ndarray,
    p: VOParams, registry: Extractors, measure: Measure | None,
) -> Try:
    """Extract frame k with ``choice`` (and frame k−1, unless it was extracted with it), match, estimate."""
    feats = registry.extract(choice.extractor, frame.image, choice.params)
    ms = feats.elapsed_ms
    prev_feats = prev_cache.get(choice.key)
    if prev_feats is None:
        prev_feats = prev_cache[choice.key] = registry.extract(choice.extractor, prev_frame.image, choice.params)
        ms += prev_feats.elapsed_ms
    t = Try(choice, feats, extraction_ms=ms)
    if measure is not None:
        t.metrics = dict(measure(feats, frame.image, (prev_feats, prev_frame.image)))
    t.step, t.matches, t.inliers, t.matching_ms, t.reason = estimate(prev_feats, feats, seq, K, p,
                                                                     getattr(registry, "match", match))
    return t


def estimate(a: Features, b: Features, seq: Sequence, K: np.ndarray, p: VOParams,
             matcher: Callable[[Features, Features, float], MatchResult] = match) -> tuple[Step | None, int, int, float, str]:
    """The relative motion of one frame pair (or None and why), with match/inlier counts and matching time;
    ``matcher`` is ``geometry.match`` or an ``Extractors``' own (``reuse.Reusing`` keeps its matches)."""
    if len(a) < p.min_keypoints or len(b) < p.min_keypoints:
        return None, 0, 0, 0.0, f"too few keypoints ({len(a)}, {len(b)})"
    m = matcher(a, b, p.ratio)
    n = len(m.query)
    if n < p.min_matches:
        return None, n, 0, m.elapsed_ms, f"too few matches ({n} < {p.min_matches})"
    if p.seed is not None:
        order = np.random.default_rng((p.seed, len(a), len(b), n)).permutation(n)
        m = type(m)(m.query[order], m.train[order], m.elapsed_ms)
    p1 = undistort(a.xy[m.query], seq.intrinsics)
    p2 = undistort(b.xy[m.train], seq.intrinsics)
    rel = relative_pose(p1, p2, K, threshold_px=p.ransac_threshold_px)
    if rel is None:
        return None, n, 0, m.elapsed_ms, "no essential matrix"
    k = int(rel.inliers.sum())
    if k < p.min_inliers:
        return None, n, k, m.elapsed_ms, f"too few inliers ({k} < {p.min_inliers})"
    inl = rel.inliers
    step = Step(rel.R, rel.t, p1[inl], p2[inl], rel.parallax_px, (m.query, m.train), inl)
    return step, n, k, m.elapsed_ms, ""


class ScaleChain:
    """The length of each step in the two-view VO's one scale (module docstring)."""

    def __init__(self, p: VOParams, K: np.ndarray) -> None:
        self.p = p
        self.K = K
        self.length = 1.0
        self.points: dict[int, float] = {}  # keypoint index in the last frame -> distance from that camera

    def reset(self) -> None:
        self.points = {}

    def step(self, s: Step, same_features: bool, fa: Frame, fb: Frame) -> float:
        p = self.p
        if s.parallax_px < p.still_px:
            self.points = {}
            return 0.0
        if p.scale == "gt" and fa.pose is not None and fb.pose is not None:
            return float(np.linalg.norm(fb.pose[:3, 3] - fa.pose[:3, 3]))
        if p.scale == "unit":
            return 1.0
        X2, ok = triangulate(s.p1, s.p2, self.K, s.R, s.t)
        X1 = (X2 - s.t.reshape(1, 3)) @ s.R  # the same points in camera k-1
        d1 = np.linalg.norm(X1, axis=1)
        if same_features and self.points:
            ratios = [self.points[int(q)] / d for q, d, o in zip(s.query, d1, ok, strict=True) if o and int(q) in self.points and d > 0]
            if len(ratios) >= p.min_scale_points:
                r = float(np.median(ratios))
                self.length = float(np.clip(r, self.length / p.max_scale_change, self.length * p.max_scale_change))
        d2 = np.linalg.norm(X2, axis=1) * self.length
        self.points = {int(t): float(d) for t, d, o in zip(s.train, d2, ok, strict=True) if o}
        return self.length
