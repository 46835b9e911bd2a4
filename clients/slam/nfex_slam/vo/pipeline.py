"""Monocular visual odometry where the extractor may change every frame, with a local map (default) or two-view.

For each frame k (DESIGN.md, "Evaluation"; the paper's §V runs its extractors inside a SLAM front end):

1. ``chooser(frame, history)`` names the extractor α and parameters Θ′ for this frame (a fixed
   configuration, a sweep cell, or the nFEX advisor) — or ``Proposals``, candidates a judge verifies in turn;
2. the frame's features are extracted with (α, Θ′); when the choice differs from frame k−1's, frame
   k−1 is re-extracted with it so that the descriptors are comparable (its cost is counted in frame
   k's extraction time — a real front end would pay it too);
3. ratio-test matching with the extractor's norm, essential matrix with MAGSAC++, ``recoverPose``
   (``geometry``, ``twoview``): the pair's estimate (R, unit t), which the front-end checks and the judge see and
   ``FrameRecord.estimate`` keeps, whichever way the trajectory is then scaled;
4. the accepted pair places frame k.

Placing it, ``scale="map"`` (``tracking``, ``localmap``, ``bundle``; ``nfex evaluate --vo map``): frame k is located against a local
map of points triangulated from two or more keyframes — PnP + RANSAC where enough map points are seen, the
essential matrix scaled by the last step's length otherwise — and a frame that moved becomes a keyframe, after
which a sliding-window bundle adjustment (GTSAM) refines the last keyframes and their points, its oldest held so
that the map keeps its scale. A change of configuration re-extracts the last two keyframes with the new one and
triangulates their matches at their known poses: a switch costs those extractions, not the trajectory's scale.
The returned poses are the refined ones (a frame between keyframes moves with its keyframe).

The two-view VO (``twoview.ScaleChain``, the default while the map's seed spread with ORB_GRID on KITTI 01 exceeds 0.25 and
it costs 5–8× the time: docs/vo.md) chains T_w,k = T_w,k−1 · T_k←k−1⁻¹ with T_k←k−1 = [R | s·t]:
``scale="triangulated"`` takes s from the points the previous step also triangulated (only while the
configuration is unchanged, so a switch restarts it at constant speed), ``"unit"`` takes s = 1, and ``"gt"`` each
step's length from the ground truth — a diagnostic that isolates rotation and direction errors. Either way a step
whose median inlier parallax is below ``still_px`` has no translation, and monocular ATE is computed after Sim(3)
alignment (evo ``-as``), which absorbs the one global scale.

Tracking loss (too few keypoints, matches or inliers, or no essential matrix) never raises: the frame
is marked lost, its pose follows the last good motion (constant velocity), and the next frame is
matched against it again (the map, where there is one, locates the next accepted frame against its last keyframe).
A run whose lost fraction of frame pairs exceeds ``max_lost_fraction`` is *failed* (the paper's "fail").

Front-end checks (``nfex_slam.motion.StepChecks``, per agent from the graph; off by default): a pair whose rotation
or change of heading exceeds what the agent's motion allows is treated as lost in the same way — every
method of an evaluation gets the same checks. Every pair's estimate (R, unit t) is kept in its
FrameRecord, with its rotation and direction errors against the ground truth where the frames have poses.
"""
from __future__ import annotations

import json
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from ..datasets.base import Frame, Sequence
from ..features import Features
from ..motion import NO_CHECKS, StepChecks, pair_errors, relative_truth
from ..pairs import ACCEPT, NEXT, STILL_PX, PairEvidence, Verdict
from .tracking import MapTracker
from .twoview import ScaleChain, Try, try_pair


class Extractors(Protocol):
    """What the VO runs a choice with: the server's graph-built registry (nfex_core.vision.registry), or a
    client's recipes from the service's selections (``nfex_slam.replay.SelectionExtractors``). One that also has
    ``match(a, b, ratio)`` matches the frame pairs (``reuse.Reusing``, which computes each match once)."""

    def extract(self, name: str, image: np.ndarray, params: Mapping[str, Any] | None = None) -> Features: ...

    def resolve(self, name: str, params: Mapping[str, Any] | None = None) -> dict[str, Any]: ...


@dataclass(frozen=True)
class Choice:
    extractor: str
    params: dict[str, Any] = field(default_factory=dict)

    @property
    def key(self) -> str:
        return self.extractor + json.dumps(self.params, sort_keys=True, default=str)


@dataclass(frozen=True)
class VOParams:
    ratio: float = 0.8  # Lowe's ratio test
    min_keypoints: int = 8
    min_matches: int = 15
    min_inliers: int = 10
    ransac_threshold_px: float = 1.0
    still_px: float = STILL_PX  # median inlier parallax below which a step has no translation
    scale: str = "triangulated"  # two-view: "triangulated" | "unit" | "gt"; "map": the local map (docs/vo.md)
    min_scale_points: int = 8
    max_scale_change: float = 2.0  # per step, against a bad triangulation
    max_lost_fraction: float = 0.3
    seed: int | None = None  # None: deterministic; else the correspondences are shuffled per frame
    # before RANSAC (OpenCV seeds its RANSAC itself, so this is what makes runs differ)
    # the local map (scale="map"; localmap, bundle): PnP needs min_map_points map points among the matches
    # (ORB-SLAM tracks a reference keyframe on ≥ 15 matches); new points need rays min_angle_deg apart (ORB-SLAM's
    # initialiser: cos < 0.99998, 0.36°; keyframes here are consecutive moving frames, closer than ORB-SLAM's);
    # the map starts on a pair where start_points points (enough to track on) have start_angle_deg of parallax
    # (ORB-SLAM's initialisation: 1°); the window's oldest window_fixed keyframes are held, and with one held the
    # distance to the next one too (the seven degrees of freedom of the gauge)
    min_map_points: int = 15
    min_angle_deg: float = 0.36
    start_points: int = 15
    start_angle_deg: float = 1.0
    window: int = 7
    window_fixed: int = 1
    ba_iterations: int = 10
    search_radius_px: float = 8.0  # a map point's projection to a keypoint (ORB-SLAM: 2.5–4 px × the pyramid scale)
    # the pairs' own rotations hold the map's heading: each two consecutive keyframes' rotation is held in the
    # window's adjustment to what the frame pairs between them chain to, with σ_R = rotation_sigma_deg (None: the
    # angle √5.991 px subtends at the focal length, 0.19° on KITTI; 0: no such factor)
    rotation_sigma_deg: float | None = None


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
    tries: int = 1  # candidates tried on this pair (verification; extraction and matching ms count them all)
    verdict: dict[str, Any] | None = field(default=None, compare=False)  # verification.Verdict.as_dict()
    located: str = ""  # how the local map placed the frame: "pnp" | "essential" | "restart" (the map, just started,
    # disagreed with this pair, was found wrong and started again: tracking._arbitrate) ("" without a map, or lost)
    map_points: int = 0  # PnP inliers among the map's points

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


@dataclass(frozen=True)
class Proposals:
    """A chooser's answer when the pair is verified: the candidates in the order to try them, and the judge that
    decides after each try, given the estimates tried so far and how many proposals remain — the stream's
    (``nfex_core.verification.PairJudge``, or a session's ``/verdict``), which keeps the motion prior it judges by."""

    choices: tuple[Choice, ...]
    judge: Callable[[list[PairEvidence], int], Verdict]


Chooser = Callable[[Frame, list[FrameRecord]], "Choice | Proposals | tuple[str, Mapping[str, Any]]"]
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
    registry: Extractors,
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
    moving: tuple[np.ndarray, np.ndarray] | None = None  # the last accepted step that translated (R, t): the front-end checks
    scale = ScaleChain(p, K)
    tracker = MapTracker(sequence, p, registry) if p.scale == "map" else None
    prev: tuple[Frame, Choice, dict[str, Features]] | None = None  # the last frame, its taken choice, every tried one's features
    shape = (0, 0)
    for i in range(start, stop):
        frame = sequence[i]
        shape = frame.image.shape[:2]
        proposed = chooser(frame, records)
        choices, judge = (proposed.choices, proposed.judge) if isinstance(proposed, Proposals) else ((_as_choice(proposed),), None)
        tries: list[Try] = []
        evidence: list[PairEvidence] = []
        verdict: Verdict | None = None
        estimate: tuple[np.ndarray, np.ndarray] | None = None
        errors: tuple[float, float] | None = None
        located, map_points, extra_ms, extra_match_ms = "", 0, 0.0, 0.0
        if prev is None:
            first = Try(choices[0], registry.extract(choices[0].extractor, frame.image, choices[0].params))
            tries.append(first)
            if measure is not None:
                first.metrics = dict(measure(first.feats, frame.image, None))
            taken: Try | None = first
            reason = ""
            pose = np.eye(4)
        else:
            prev_frame, prev_choice, prev_cache = prev
            for n, choice in enumerate(choices):
                t = try_pair(choice, frame, prev_frame, prev_cache, sequence, K, p, registry, measure)
                if t.step is not None:
                    moved = t.step.parallax_px >= p.still_px
                    t.reason = checks.verdict(t.step.R, t.step.t, frame.timestamp - prev_frame.timestamp, moving, moved)
                tries.append(t)
                evidence.append(t.evidence())
                if judge is None:
                    break
                verdict = judge(evidence, len(choices) - n - 1)
                if verdict.action != NEXT:
                    break
            if judge is None:
                taken = tries[0] if tries[0].step is not None and not tries[0].reason else None
            else:
                assert verdict is not None
                taken = tries[verdict.accepted] if verdict.action == ACCEPT and verdict.accepted is not None else None
            shown = taken or tries[0]
            if taken is not None:
                reason = ""
            elif judge is None or verdict is None:
                reason = tries[0].reason
            else:
                reason = f"verify: {verdict.reason}" + (f" (first try: {tries[0].reason})" if tries[0].reason else "")
            if shown.step is not None:
                estimate = (shown.step.R, shown.step.t)
                if prev_frame.pose is not None and frame.pose is not None:
                    errors = pair_errors(shown.step.R, shown.step.t, relative_truth(prev_frame.pose, frame.pose))
            if taken is not None and taken.step is not None:
                step = taken.step
                if step.parallax_px >= p.still_px:
                    moving = (step.R, step.t)
                if tracker is not None:
                    pose, extra_ms, extra_match_ms, located, map_points = tracker.place(frame, taken, prev_frame, prev_cache, poses[-1])
                    velocity = np.linalg.inv(poses[-1]) @ pose
                else:
                    length = scale.step(step, taken.choice == prev_choice, prev_frame, frame)
                    forward = np.eye(4)  # camera k-1 → camera k
                    forward[:3, :3] = step.R
                    forward[:3, 3] = length * step.t
                    velocity = np.asarray(np.linalg.inv(forward), dtype=float)
                    pose = poses[-1] @ velocity
            else:
                scale.reset()
                pose = poses[-1] @ velocity
                if tracker is not None:
                    tracker.anchor(i, pose)
        shown_try = taken or tries[0]
        poses.append(pose)
        stamps.append(frame.timestamp)
        records.append(
            FrameRecord(
                i, frame.timestamp, shown_try.choice.extractor, registry.resolve(shown_try.choice.extractor, shown_try.choice.params),
                len(shown_try.feats), shown_try.matches, shown_try.inliers, sum(t.extraction_ms for t in tries) + extra_ms,
                sum(t.matching_ms for t in tries) + extra_match_ms, taken is None, reason, shown_try.metrics, estimate, errors,
                shown_try.step.parallax_px if shown_try.step is not None else 0.0, len(tries),
                verdict.as_dict() if verdict is not None else None, located, map_points,
            )
        )
        accepted = taken or tries[0]
        prev = (frame, accepted.choice, {t.choice.key: t.feats for t in tries})
    out = np.array(poses).reshape(-1, 4, 4)
    if tracker is not None:
        out = tracker.trajectory([r.index for r in records], out)
    return VOResult(out, np.array(stamps), records, p.max_lost_fraction, shape[1], shape[0])
