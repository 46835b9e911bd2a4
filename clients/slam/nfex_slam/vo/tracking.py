"""How the VO with a local map (``VOParams.scale = "map"``) places an accepted frame (``localmap`` has the map).

For an accepted pair (frame k−1, frame k) whose two-view estimate passed the checks and the judge:

1. With no map yet, frame k−1 becomes its first keyframe (its pose is known: the identity at the start), and frames
   are placed by their pairs' essential matrices at one step's length until one has parallax enough with it to start
   the map (``_start``). The frames placed between the map's first two keyframes are then tied to them, each at its
   share of the pairs' path on the line between the two (``_between``): a pair's direction over one short step can be
   tens of degrees off, the line between the keyframes is the start pair's, which has the parallax. A map just
   started is on trial: where its first PnP placement turns from frame k−1 to frame k by more than the window's
   bound on a pair's rotation (√7.815 σ_R) away from the pair's own estimate, one of them is wrong, and a third
   estimate decides which (``_arbitrate``): the essential matrix of the map's first keyframe and frame k. Agreeing
   with the map, it makes the pair the outlier, and the map is kept; agreeing with the pairs' rotations chained
   since the first keyframe, it makes the map's points distorted (every placement on them would follow the
   distortion), and the map starts again from frame k−1; agreeing with neither, it makes the pair the map was
   started on wrong, and the map starts again from its first keyframe, which that pair did not place
   (``_restart``). The frames placed so far keep their poses, or take their share of the line between the new map's
   first two keyframes.
2. Where the pair's configuration is not the map's, the last two keyframes are re-extracted with it and their
   matches triangulated at their known poses (``LocalMap.switch``); the extractions count in frame k's cost.
3. Frame k is matched against the last keyframe (the pair's own matches where frame k−1 is that keyframe) and
   located by PnP + RANSAC on the map points among the matches; with too few, or a step they leave undetermined or
   out of bounds (``_gate``), the essential matrix's R and unit t scaled by the last step's length place it (t = 0
   where the pair did not move).
4. A frame that moved becomes a keyframe: its matches extend the map's points and tracks, tracks with parallax
   enough are triangulated, and the window is bundle-adjusted (``bundle.adjust``) with its rotation from the last
   keyframe held to the pairs' rotations chained since that keyframe (where no pair between them was lost).

Every frame is anchored to the last keyframe at the time it was placed (T_kf⁻¹ · T_k), or tied to the line between
the map's first two keyframes; ``trajectory`` gives each frame its keyframe's refined pose times that anchor, or its
share of the line between the refined keyframes, so frames between keyframes (still, or coasted on the motion prior)
follow their keyframes' refinement.
"""
from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from ..datasets.base import Frame, Sequence
from ..features import Features
from ..motion import rotation_deg
from .bundle import HUBER_ROTATION
from .geometry import match, relative_pose, triangulate, undistort
from .localmap import Keyframe, LocalMap, keypoint_sigma

if TYPE_CHECKING:
    from .pipeline import Choice, Extractors, VOParams
    from .twoview import Try


class MapTracker:
    def __init__(self, seq: Sequence, p: VOParams, registry: Extractors) -> None:
        self.seq, self.p, self.registry = seq, p, registry
        self.map = self._new_map()
        self.retired: dict[int, np.ndarray] = {}  # the keyframe poses of maps given up (their frames stay anchored)
        self.on_trial = False  # a map just started, whose first PnP placement is checked against its pair
        self.length = 1.0  # the last step's length in the map's scale: the essential matrix's fallback
        self.anchors: dict[int, tuple[int, np.ndarray]] = {}  # frame index → (keyframe id, T_kf⁻¹ · T_k)
        self.start: Keyframe | None = None  # the frame the map will start from, with no map yet
        # the pairs' rotations chained from the last keyframe (with no map yet: the start) to the last frame placed,
        # R_k←kf (None: a pair between them lost)
        self.turned: np.ndarray | None = None
        self.placed = -1  # the index of the last frame placed
        # the pairs' rotations chained from the map's first keyframe to the last frame placed (None: a pair between them
        # lost, or a restart that gave the chain up)
        self.started: np.ndarray | None = None
        # the poses of the frames placed with no map yet, or one on trial (``_between`` reads them at a start)
        self.unmapped: dict[int, np.ndarray] = {}
        # frame index → (keyframe a, keyframe b, share, R): a frame placed at its share of the line from a to b, turned
        # R from a (T_wc = [R_a R | (1 − share) c_a + share c_b])
        self.between: dict[int, tuple[int, int, float, np.ndarray]] = {}

    def place(self, frame: Frame, taken: Try, prev: Frame, prev_cache: dict[str, Features],
              prev_pose: np.ndarray) -> tuple[np.ndarray, float, float, str, int]:
        """Frame k's camera-to-world pose, the extraction and matching ms it added, how it was located
        ("pnp" | "essential" | "restart") and its PnP inliers."""
        placed = self._place(frame, taken, prev, prev_cache, prev_pose)
        if self.map.last is None or self.on_trial:
            self.unmapped[frame.index] = placed[0]
        else:  # the map passed its trial, and is never given up: no start is to come
            self.unmapped = {}
        return placed

    def _place(self, frame: Frame, taken: Try, prev: Frame, prev_cache: dict[str, Features],
               prev_pose: np.ndarray) -> tuple[np.ndarray, float, float, str, int]:
        step = taken.step
        assert step is not None
        p, key = self.p, taken.choice.key
        extra_ms = match_ms = 0.0
        self.turned = step.R @ self.turned if self.turned is not None and self.placed == prev.index else None
        self.started = step.R @ self.started if self.started is not None and self.placed == prev.index else None
        self.placed = frame.index
        if self.map.last is None:
            return self._start(frame, taken, prev, prev_cache, prev_pose)
        if self.map.last.key != key:
            extra_ms, match_ms = self._switch(taken.choice, prev, prev_cache)
        ref = self.map.last
        assert ref is not None
        if ref.id == prev.index:
            q, t = step.matches
        else:
            q, t, ms = self._match(ref.feats, taken.feats)
            match_ms += ms
        xy = self._xy(taken.feats)
        seen = self.map.correspondences(ref, q, t)
        moved = step.parallax_px >= p.still_px
        sigma = keypoint_sigma(taken.feats)
        located = self._gate(self.map.locate(xy, seen, min_points=p.min_map_points, min_inliers=p.min_inliers),
                             prev_pose, moved, xy, sigma)
        if located is not None:
            T = located[0]
        else:
            forward = np.eye(4)  # camera k-1 → camera k
            forward[:3, :3] = step.R
            forward[:3, 3] = (self.length if moved else 0.0) * step.t
            T = prev_pose @ np.linalg.inv(forward)
        # the window's points projected where the first pose puts them find the keypoints the matches missed
        found = self.map.search(T, key, taken.feats, xy, radius=p.search_radius_px, ratio=p.ratio,
                                taken=set(located[1]) if located is not None else set())
        both = {**found, **(located[1] if located is not None else {})}
        again = self._gate(self.map.locate(xy, both, min_points=p.min_map_points, min_inliers=p.min_inliers),
                           prev_pose, moved, xy, sigma)
        if again is not None:
            T, located = again[0], again
        if self.on_trial and located is not None:
            self.on_trial = False
            if self._disagrees(prev_pose, T, step.R):
                wrong, ms = self._arbitrate(T, taken, xy)
                match_ms += ms
                if wrong != "pair":
                    T, _, restart_ms, _, _ = self._restart(frame, taken, prev, prev_cache, prev_pose,
                                                           from_first=wrong == "start")
                    return T, extra_ms, match_ms + restart_ms, "restart", 0
        how = "pnp" if located is not None else "essential"
        inliers = len(located[1]) if located is not None else 0
        if moved:
            kf = Keyframe(frame.index, T, key, taken.feats, xy, frame.image, sigma)
            self.map.add(kf)
            if self.turned is not None:
                self.map.relate(ref.id, kf.id, self.turned)
            self.turned = np.eye(3)
            if located is not None:
                self.map.observe(kf, located[1])
            self.map.associate(ref, kf, q, t)
            self.map.refine()
            self.map.forget(p.window + 2)
            T = kf.T_wc
            self.length = max(float(np.linalg.norm(T[:3, 3] - prev_pose[:3, 3])), 1e-9)
        self.anchor(frame.index, T)
        return T, extra_ms, match_ms, how, inliers

    def anchor(self, index: int, T: np.ndarray) -> None:
        """Tie frame ``index``'s pose T to the last keyframe (a lost frame's too, coasting from it)."""
        kf = self.map.last
        if kf is not None:
            self.anchors[index] = (kf.id, np.linalg.inv(kf.T_wc) @ T)

    def trajectory(self, indices: list[int], poses: np.ndarray) -> np.ndarray:
        """The run's poses with every anchored frame moved with its keyframe's refinement."""
        out = poses.copy()
        keyframes = {**self.retired, **self.map.poses}
        for n, i in enumerate(indices):
            if i in self.between:
                a, b, share, R = self.between[i]
                out[n] = keyframes[a].copy()
                out[n][:3, :3] = keyframes[a][:3, :3] @ R
                out[n][:3, 3] = (1 - share) * keyframes[a][:3, 3] + share * keyframes[b][:3, 3]
            elif i in self.anchors:
                kf, rel = self.anchors[i]
                out[n] = keyframes[kf] @ rel
        return out

    def _start(self, frame: Frame, taken: Try, prev: Frame, prev_cache: dict[str, Features],
               prev_pose: np.ndarray) -> tuple[np.ndarray, float, float, str, int]:
        """With no map yet: place frame k by the pair's essential matrix, and start the map from the first frame of
        the run's configuration (the start) and frame k once at least ``start_points`` of their matches triangulate
        with ``start_angle_deg`` between their rays — ORB-SLAM's monocular initialisation (Mur-Artal et al. 2015, §IV:
        50 points, 1°) keeps its reference frame until a frame has such parallax with it — or until fewer than twice
        that many matches are left with it, when the frame becomes the start; a pair that mostly turned has no such
        parallax, and a map started on it is distorted."""
        step = taken.step
        assert step is not None
        p, key = self.p, taken.choice.key
        moved = step.parallax_px >= p.still_px
        xy = self._xy(taken.feats)
        pair: tuple[np.ndarray, np.ndarray, np.ndarray] | None = (step.R, step.t, step.inlying)
        forward = np.eye(4)  # camera k-1 → camera k
        forward[:3, :3] = step.R
        forward[:3, 3] = (self.length if moved else 0.0) * step.t
        T = prev_pose @ np.linalg.inv(forward)
        if self.start is None or self.start.key != key:
            feats = prev_cache[key]
            self.start = Keyframe(prev.index, prev_pose, key, feats, self._xy(feats), prev.image, keypoint_sigma(feats))
            self.turned = step.R
        s, match_ms = self.start, 0.0
        if s.id == prev.index:
            q, t = step.matches
        else:
            q, t, match_ms = self._match(s.feats, taken.feats)
            pair = self._two_view(s.xy, xy, q, t)
        if len(q) < 2 * p.start_points:  # too few matches left with the start (ORB-SLAM: 100): frame k starts again
            self.start = Keyframe(frame.index, T, key, taken.feats, xy, frame.image, keypoint_sigma(taken.feats))
            self.turned = np.eye(3)
            return T, 0.0, match_ms, "essential", 0
        if not moved or pair is None or self._parallax_points(s.xy[q[pair[2]]], xy[t[pair[2]]], pair[0], pair[1]) < p.start_points:
            return T, 0.0, match_ms, "essential", 0
        self._between(s, frame.index, T)
        length = max(float(np.linalg.norm(T[:3, 3] - s.T_wc[:3, 3])), 1e-9)
        forward[:3, :3], forward[:3, 3] = pair[0], length * pair[1]
        T = s.T_wc @ np.linalg.inv(forward)
        kf = Keyframe(frame.index, T, key, taken.feats, xy, frame.image, keypoint_sigma(taken.feats))
        self.map.add(s)
        self.anchors[s.id] = (s.id, np.eye(4))
        self.map.add(kf)
        self.map.associate(s, kf, q, t)
        self.length = length / (frame.index - s.id)  # the mean step since the start: frame k−1 was placed by its pair
        if self.turned is not None:
            self.map.relate(s.id, kf.id, self.turned)
        self.started = self.turned
        self.start = None
        self.turned = np.eye(3)
        self.on_trial = True
        self.anchor(frame.index, T)
        return T, 0.0, match_ms, "essential", 0

    def _between(self, s: Keyframe, k: int, T: np.ndarray) -> None:
        """Tie the frames placed between the map's first keyframe s and frame k (at T where the pairs put it) to the map's
        first two keyframes: each at its share of the path the pairs placed from s to k, on the line between the two
        keyframes, turned from s as the pairs turn it."""
        placed = {**self.unmapped, s.id: s.T_wc, k: T}
        ids = list(range(s.id, k + 1))
        if any(i not in placed for i in ids):  # a frame between them was lost: the pairs placed no path
            return
        steps = np.linalg.norm(np.diff([placed[i][:3, 3] for i in ids], axis=0), axis=1)
        share = np.cumsum(steps) / max(steps.sum(), 1e-12)
        for n, i in enumerate(ids[1:-1]):
            self.between[i] = (s.id, k, float(share[n]), s.T_wc[:3, :3].T @ placed[i][:3, :3])

    def _disagrees(self, from_pose: np.ndarray, T: np.ndarray, R: np.ndarray) -> bool:
        """Whether the rotation from the camera at ``from_pose`` to frame k that the map's placement T gives differs
        from R (x_k = R x + t) by more than the window's bound on a pair's rotation (√7.815 σ_R, χ² with 3 degrees of
        freedom at 95 %: 0.53° on KITTI)."""
        return self._apart(T[:3, :3].T @ from_pose[:3, :3], R)

    def _apart(self, Ra: np.ndarray, Rb: np.ndarray) -> bool:
        """Whether two rotations differ by more than √7.815 σ_R."""
        return rotation_deg(Ra @ Rb.T) > np.degrees(HUBER_ROTATION * self.map.rotation_sigma)

    def _arbitrate(self, T: np.ndarray, taken: Try, xy: np.ndarray) -> tuple[str, float]:
        """Which of the map on trial and the pair (frame k−1, frame k) that disagree with it is wrong, and the ms of
        matching spent on deciding: a third estimate, the essential matrix of the map's first keyframe s and frame k
        (a pair not used to start the map nor to place frame k), sides with the one it agrees with. "pair": it agrees
        with the map, and the pair is the outlier (the map is kept); "map": it agrees with the pairs' rotations chained
        from s to frame k, and the map's points are distorted (the map starts again from frame k−1); "start": it
        agrees with neither, so the chain holds a wrong pair as well — the start pair the map was built on — and the map
        starts again from s, which that pair did not place. Without a third estimate (s has another configuration,
        too few matches, no model): "map"."""
        s = self.map.keyframes[0]
        if s.key != taken.choice.key:
            return "map", 0.0
        q, t, ms = self._match(s.feats, taken.feats)
        third = self._two_view(s.xy, xy, q, t) if len(q) >= 2 * self.p.start_points else None
        if third is None:
            return "map", ms
        if not self._disagrees(s.T_wc, T, third[0]):
            return "pair", ms
        if self.started is not None and not self._apart(self.started, third[0]):
            return "map", ms
        return "start", ms

    def _restart(self, frame: Frame, taken: Try, prev: Frame, prev_cache: dict[str, Features],
                 prev_pose: np.ndarray, from_first: bool = False) -> tuple[np.ndarray, float, float, str, int]:
        """Give the map up and start again (``_start``) from frame k−1 at the pose it has, or ``from_first``: from the
        map's first keyframe, with no rotation chained to frame k (the chain holds the wrong pair). The frames placed so
        far keep their poses."""
        first = self.map.keyframes[0]
        self.retired.update(self.map.poses)
        self.map = self._new_map()
        self.start = None
        if from_first:
            self.start = replace(first, points={}, tracks={})
            self.turned = None
        return self._start(frame, taken, prev, prev_cache, prev_pose)

    def _new_map(self) -> LocalMap:
        p = self.p
        return LocalMap(self.seq.intrinsics.K, window=p.window, fixed=p.window_fixed, min_angle_deg=p.min_angle_deg,
                        ba_iterations=p.ba_iterations,
                        rotation_sigma=None if p.rotation_sigma_deg is None else float(np.radians(p.rotation_sigma_deg)))

    def _parallax_points(self, x0: np.ndarray, x1: np.ndarray, R: np.ndarray, t: np.ndarray) -> int:
        """How many correspondences triangulate in front of both cameras ([I|0], [R|t]) with rays ``start_angle_deg``
        apart."""
        if not len(x0):
            return 0
        X, ok = triangulate(x0, x1, self.seq.intrinsics.K, R, t)
        Kinv = np.linalg.inv(self.seq.intrinsics.K)
        r0 = np.c_[x0, np.ones(len(x0))] @ Kinv.T
        r1 = (np.c_[x1, np.ones(len(x1))] @ Kinv.T) @ R  # camera k's rays in camera k−1's frame (Rᵀ r)
        cos = np.einsum("ij,ij->i", r0, r1) / (np.linalg.norm(r0, axis=1) * np.linalg.norm(r1, axis=1))
        return int((ok & (cos < np.cos(np.radians(self.p.start_angle_deg)))).sum())

    def _two_view(self, xa: np.ndarray, xb: np.ndarray, q: np.ndarray,
                  t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """R, unit t and the inlier mask of matches (q, t) between undistorted keypoints ``xa`` and ``xb``, by the
        front end's estimator (``geometry.relative_pose``); None where it finds no model."""
        rel = relative_pose(xa[q], xb[t], self.seq.intrinsics.K, threshold_px=self.p.ransac_threshold_px)
        return (rel.R, rel.t, rel.inliers) if rel is not None else None

    def _gate(self, located: tuple[np.ndarray, dict[int, int]] | None, prev_pose: np.ndarray, moved: bool,
              xy: np.ndarray, sigma: np.ndarray) -> tuple[np.ndarray, dict[int, int]] | None:
        """A PnP pose whose step from frame k−1 changes the last step's length by more than ``max_scale_change`` b (the
        bound the two-view chain puts on a step, against a bad triangulation), or whose step its points leave
        undetermined — its 95 % interval (± 1.96 σ, ``LocalMap.step_sigma``) reaches below (1 − 1/b) of it, a step 1/b
        as long — is no pose: PnP on points that all lie far, or along one line of sight, fits a wrong step as well as
        the right one. The pair's essential matrix with the last step's length places the frame instead."""
        if located is None or not moved:
            return located
        T, inliers = located
        step = float(np.linalg.norm(T[:3, 3] - prev_pose[:3, 3]))
        bound = self.p.max_scale_change
        if not self.length / bound <= step <= self.length * bound:
            return None
        spread = self.map.step_sigma(T, xy, sigma, inliers, prev_pose[:3, 3])
        return located if 1.96 * spread <= (1 - 1 / bound) * step else None

    def _xy(self, feats: Features) -> np.ndarray:
        return undistort(feats.xy, self.seq.intrinsics) if len(feats) else np.zeros((0, 2))

    def _match(self, a: Features, b: Features) -> tuple[np.ndarray, np.ndarray, float]:
        m = getattr(self.registry, "match", match)(a, b, self.p.ratio)
        q, t = m.query, m.train
        if self.p.seed is not None and len(q):
            order = np.random.default_rng((self.p.seed, len(a), len(b), len(q))).permutation(len(q))
            q, t = q[order], t[order]
        return q, t, m.elapsed_ms

    def _switch(self, choice: Choice, prev: Frame, prev_cache: dict[str, Features]) -> tuple[float, float]:
        """Re-extract the last two keyframes with ``choice`` and triangulate their matches at their poses."""
        kfs = self.map.keyframes[-2:]
        feats: list[Features] = []
        ms = 0.0
        for kf in kfs:
            f = prev_cache.get(choice.key) if kf.id == prev.index else None
            if f is None:
                assert kf.image is not None
                f = self.registry.extract(choice.extractor, kf.image, choice.params)
                ms += f.elapsed_ms
            feats.append(f)
        if len(kfs) == 1:
            kf = kfs[0]
            kf.key, kf.feats, kf.xy, kf.sigma, kf.points, kf.tracks = choice.key, feats[0], self._xy(feats[0]), keypoint_sigma(feats[0]), {}, {}
            self.map.tracks = {}
            return ms, 0.0
        q, t, match_ms = self._match(feats[0], feats[1])
        self.map.switch(kfs[0], kfs[1], choice.key, feats[0], feats[1], self._xy(feats[0]), self._xy(feats[1]), q, t)
        return ms, match_ms
