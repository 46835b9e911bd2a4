"""Monocular frame-to-frame visual odometry where the extractor may change every frame.

For each frame k (DESIGN.md, "Evaluation"; the paper's §V runs its extractors inside a SLAM front end):

1. ``chooser(frame, history)`` names the extractor α and parameters Θ′ for this frame (a fixed
   configuration, a sweep cell, or the nFEX advisor);
2. the frame's features are extracted with (α, Θ′); when the choice differs from frame k−1's, frame
   k−1 is re-extracted with it so that the descriptors are comparable (its cost is counted in frame
   k's extraction time — a real front end would pay it too);
3. ratio-test matching with the extractor's norm, essential matrix with RANSAC, ``recoverPose``
   (``geometry``);
4. the pose is chained: T_w,k = T_w,k−1 · T_k←k−1⁻¹ with T_k←k−1 = [R | s·t].

Scale s (one camera cannot observe it). ``scale="triangulated"`` (default) keeps one consistent,
arbitrary scale along the run: the first step has length 1; each later step's inliers are
triangulated (camera k−1 at [I|0], camera k at [R|t], |t| = 1) and the points also seen in the
previous step (same keypoints of frame k−1, so only while the configuration is unchanged) give
s_k = median(‖X_prev‖ / ‖X_cur‖) of their distances from camera k−1 — the previous step's points
being already in the run's scale. Without enough common points (< ``min_scale_points``, or after a
configuration change) the previous step's length is kept (constant speed). ``scale="unit"`` takes
every step as length 1. Either way a step whose median inlier parallax is below ``still_px`` has no
translation, and monocular ATE is computed after Sim(3) alignment (evo ``-as``), which absorbs the
one global scale. ``scale="gt"`` takes each step's length from the ground truth — a diagnostic that
isolates rotation and direction errors, never used for the reported tables.

Tracking loss (too few keypoints, matches or inliers, or no essential matrix) never raises: the frame
is marked lost, its pose follows the last good motion (constant velocity), and the next frame is
matched against it again (frame-to-frame VO has no map to re-initialise). A run whose lost fraction of
frame pairs exceeds ``max_lost_fraction`` is *failed* (the paper's "fail").

Front-end checks (``nfex_core.motion.StepChecks``, per agent from the graph; off by default): a pair whose rotation
or change of heading exceeds what the agent's motion allows is treated as lost in the same way — every
method of an evaluation gets the same checks. Every pair's estimate (R, unit t) is kept in its
FrameRecord, with its rotation and direction errors against the ground truth where the frames have poses.
"""
from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..datasets.base import Frame, Sequence
from ..motion import NO_CHECKS, StepChecks, pair_errors, relative_truth
from ..vision.features import Features
from ..vision.registry import ExtractorRegistry
from .geometry import match, relative_pose, triangulate, undistort


@dataclass(frozen=True)
class Choice:
    extractor: str
    params: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class VOParams:
    ratio: float = 0.8  # Lowe's ratio test
    min_keypoints: int = 8
    min_matches: int = 15
    min_inliers: int = 10
    ransac_threshold_px: float = 1.0
    still_px: float = 0.5  # median inlier parallax below which a step has no translation
    scale: str = "triangulated"  # "triangulated" | "unit" | "gt"
    min_scale_points: int = 8
    max_scale_change: float = 2.0  # per step, against a bad triangulation
    max_lost_fraction: float = 0.3
    seed: int | None = None  # None: deterministic; else the correspondences are shuffled per frame
    # before RANSAC (OpenCV seeds its RANSAC itself, so this is what makes runs differ)


@dataclass(frozen=True)
class FrameRecord:
    index: int
    timestamp: float
    extractor: str
    params: dict[str, Any]
    keypoints: int
    matches: int
    inliers: int
    extraction_ms: float
    matching_ms: float
    lost: bool
    reason: str = ""  # why tracking was lost (a failed front-end check starts with "check:")
    metrics: dict[str, float] = field(default_factory=dict)
    estimate: tuple[np.ndarray, np.ndarray] | None = field(default=None, compare=False, repr=False)  # (R, unit t)
    errors: tuple[float, float] | None = None  # (rotation, direction) error of the estimate vs ground truth, degrees
    parallax_px: float = 0.0

    @property
    def rejected(self) -> bool:
        """Whether a front-end check (not the geometry) lost this pair."""
        return self.reason.startswith("check:")


@dataclass
class VOResult:
    poses: np.ndarray  # (N, 4, 4) camera-to-world, frame 0 at the identity, arbitrary scale
    timestamps: np.ndarray  # (N,)
    frames: list[FrameRecord]
    max_lost_fraction: float = 0.3
    width: int = 0
    height: int = 0

    @property
    def lost(self) -> list[int]:
        return [f.index for f in self.frames if f.lost]

    @property
    def lost_count(self) -> int:
        return len(self.lost)

    @property
    def failed(self) -> bool:
        pairs = max(len(self.frames) - 1, 1)
        return len(self.frames) < 2 or self.lost_count / pairs > self.max_lost_fraction

    def mean(self, attr: str, skip_first: bool = False) -> float:
        frames = self.frames[1:] if skip_first else self.frames
        return float(np.mean([getattr(f, attr) for f in frames])) if frames else 0.0

    def metric_means(self) -> dict[str, float]:
        keys = sorted({k for f in self.frames for k in f.metrics})
        return {k: float(np.mean([f.metrics[k] for f in self.frames if k in f.metrics])) for k in keys}


Chooser = Callable[[Frame, list[FrameRecord]], "Choice | tuple[str, Mapping[str, Any]]"]
Measure = Callable[[Features, np.ndarray, "tuple[Features, np.ndarray] | None"], Mapping[str, float]]


def fixed(extractor: str, params: Mapping[str, Any] | None = None) -> Chooser:
    """A chooser that always answers the same configuration."""
    choice = Choice(extractor, dict(params or {}))
    return lambda _frame, _history: choice


def _as_choice(c: Choice | tuple[str, Mapping[str, Any]]) -> Choice:
    return c if isinstance(c, Choice) else Choice(c[0], dict(c[1]))


def run_vo(
    sequence: Sequence,
    chooser: Chooser,
    *,
    registry: ExtractorRegistry,
    params: VOParams | None = None,
    measure: Measure | None = None,
    start: int = 0,
    stop: int | None = None,
    checks: StepChecks = NO_CHECKS,
) -> VOResult:
    """Run the VO over ``sequence[start:stop]``; never raises on tracking loss (module docstring)."""
    p = params or VOParams()
    stop = len(sequence) if stop is None else min(stop, len(sequence))
    K = sequence.intrinsics.K
    poses: list[np.ndarray] = []
    records: list[FrameRecord] = []
    stamps: list[float] = []
    velocity = np.eye(4)  # last good T_k-1←k (camera k in camera k-1)
    moving: tuple[np.ndarray, np.ndarray] | None = None  # the last accepted step that translated (R, t)
    scale = _Scale(p, K)
    prev: tuple[Frame, Choice, Features] | None = None
    shape = (0, 0)
    for i in range(start, stop):
        frame = sequence[i]
        shape = frame.image.shape[:2]
        choice = _as_choice(chooser(frame, records))
        feats = registry.extract(choice.extractor, frame.image, choice.params)
        extraction_ms = feats.elapsed_ms
        matching_ms = 0.0
        matches = inliers = 0
        lost, reason = False, ""
        metrics: dict[str, float] = {}
        estimate: tuple[np.ndarray, np.ndarray] | None = None
        errors: tuple[float, float] | None = None
        parallax = 0.0
        if prev is None:
            pose = np.eye(4)
            if measure is not None:
                metrics = dict(measure(feats, frame.image, None))
        else:
            prev_frame, prev_choice, prev_feats = prev
            same = prev_choice == choice
            if not same:
                prev_feats = registry.extract(choice.extractor, prev_frame.image, choice.params)
                extraction_ms += prev_feats.elapsed_ms
            if measure is not None:
                metrics = dict(measure(feats, frame.image, (prev_feats, prev_frame.image)))
            step, matches, inliers, matching_ms, reason = _step(prev_feats, feats, sequence, K, p)
            if step is not None:
                estimate, parallax = (step.R, step.t), step.parallax_px
                if prev_frame.pose is not None and frame.pose is not None:
                    errors = pair_errors(step.R, step.t, relative_truth(prev_frame.pose, frame.pose))
                moved = step.parallax_px >= p.still_px
                reason = checks.verdict(step.R, step.t, frame.timestamp - prev_frame.timestamp, moving, moved)
                if reason:
                    step = None
                elif moved:
                    moving = estimate
            lost = step is None
            if step is not None:
                length = scale.step(step, same, prev_frame, frame)
                forward = np.eye(4)  # camera k-1 → camera k
                forward[:3, :3] = step.R
                forward[:3, 3] = length * step.t
                velocity = np.asarray(np.linalg.inv(forward), dtype=float)
            else:
                scale.reset()
            pose = poses[-1] @ velocity
        poses.append(pose)
        stamps.append(frame.timestamp)
        records.append(
            FrameRecord(
                i, frame.timestamp, choice.extractor, registry.resolve(choice.extractor, choice.params), len(feats),
                matches, inliers, extraction_ms, matching_ms, lost, reason, metrics, estimate, errors, parallax,
            )
        )
        prev = (frame, choice, feats)
    return VOResult(np.array(poses).reshape(-1, 4, 4), np.array(stamps), records, p.max_lost_fraction, shape[1], shape[0])


@dataclass
class _Step:
    R: np.ndarray
    t: np.ndarray  # unit
    query: np.ndarray  # inlier keypoint indices in frame k-1
    train: np.ndarray  # inlier keypoint indices in frame k
    p1: np.ndarray
    p2: np.ndarray
    parallax_px: float


def _step(a: Features, b: Features, seq: Sequence, K: np.ndarray, p: VOParams) -> tuple[_Step | None, int, int, float, str]:
    """The relative motion of one frame pair (or None and why), with match/inlier counts and matching time."""
    if len(a) < p.min_keypoints or len(b) < p.min_keypoints:
        return None, 0, 0, 0.0, f"too few keypoints ({len(a)}, {len(b)})"
    m = match(a, b, p.ratio)
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
    step = _Step(rel.R, rel.t, m.query[inl], m.train[inl], p1[inl], p2[inl], rel.parallax_px)
    return step, n, k, m.elapsed_ms, ""


class _Scale:
    """The length of each step in the run's one scale (module docstring, "Scale")."""

    def __init__(self, p: VOParams, K: np.ndarray) -> None:
        self.p = p
        self.K = K
        self.length = 1.0
        self.points: dict[int, float] = {}  # keypoint index in the last frame -> distance from that camera

    def reset(self) -> None:
        self.points = {}

    def step(self, s: _Step, same_features: bool, fa: Frame, fb: Frame) -> float:
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
