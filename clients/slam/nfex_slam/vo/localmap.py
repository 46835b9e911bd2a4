"""The monocular VO's local map: keyframes, points with their descriptors' keyframe, tracks waiting for parallax.

A keyframe is an accepted frame that moved (median inlier parallax ≥ ``still_px``), with its camera-to-world pose,
its features under the map's configuration (the descriptors its points are matched through) and which of its
keypoints see which map point (``points``) or extend which pending track (``tracks``).

- **Tracking** (``locate``): the ratio-test matches from the last keyframe to frame k that land on a map point give
  3-D–2-D correspondences; with at least ``min_map_points`` of them, PnP in RANSAC (``cv2.solvePnPRansac``,
  EPnP hypotheses, reprojection threshold √5.991 px, then Levenberg–Marquardt on the inliers) gives T_wc,k in the
  map's scale.
- **Association** (``associate``): a match whose keypoint in the reference keyframe sees a point adds an observation
  where it reprojects within √5.991 px; any other match starts or extends a track. A track is triangulated
  (DLT, ``cv2.triangulatePoints``, from its first and last views, whose poses are known) once the angle between
  those two rays reaches ``min_angle_deg`` and the point lies in front of, and reprojects within √5.991 px in,
  every view of the track — ORB-SLAM's tests for a new point (Mur-Artal et al. 2015, §IV-D and §VI-C).
- **Search by projection** (``search``): the map points are projected where the first pose puts frame k, each
  matched to the nearest descriptor within ``radius`` px that passes the ratio test; PnP is re-run on all
  correspondences, and a keyframe observes the inlying ones.
- **Refinement**: after each new keyframe, ``bundle.adjust`` over the last ``window`` keyframes with the oldest
  ``fixed`` held (with one held, its distance to the second oldest too) and each two consecutive keyframes' rotation
  held to what their frame pairs' two-view estimates chain to (``relate``; σ_R = √5.991 px over the focal length,
  the angle an inlier's tolerance subtends); observations that reproject beyond
  √5.991 σ afterwards are dropped, and points left with fewer than two.
- **A change of configuration** (``switch``): the last two keyframes are re-extracted with the new configuration and
  their matches triangulated from their known poses, so the new points are in the map's scale.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

from ..features import Features
from .bundle import HUBER_PX, adjust

Obs = tuple[int, int, np.ndarray, float]  # (keyframe id, keypoint index, undistorted pixel, σ in px)


@dataclass
class Keyframe:
    id: int  # the frame's index in the sequence
    T_wc: np.ndarray  # 4×4 camera-to-world
    key: str  # the configuration its features were extracted with (Choice.key)
    feats: Features
    xy: np.ndarray  # (N, 2) undistorted keypoints
    image: np.ndarray | None = None  # kept for the last two keyframes (a switch re-extracts them)
    sigma: np.ndarray = field(default_factory=lambda: np.zeros(0))  # (N,) each keypoint's σ in px (``keypoint_sigma``)
    points: dict[int, int] = field(default_factory=dict)  # keypoint index → point id
    tracks: dict[int, int] = field(default_factory=dict)  # keypoint index → track id


@dataclass
class MapPoint:
    X: np.ndarray  # (3,) world
    obs: dict[int, tuple[int, np.ndarray, float]] = field(default_factory=dict)  # keyframe id → (keypoint, pixel, σ)
    key: str = ""  # the configuration of its descriptor
    descriptor: np.ndarray | None = None  # its latest observation's descriptor


class LocalMap:
    def __init__(self, K: np.ndarray, *, window: int = 7, fixed: int = 1, min_angle_deg: float = 0.36,
                 ba_iterations: int = 10, rotation_sigma: float | None = None) -> None:
        self.K = K
        # σ_R of a pair's rotation (radians): the angle √5.991 px subtends at the focal length (bundle.adjust)
        self.rotation_sigma = HUBER_PX / float(K[0, 0]) if rotation_sigma is None else rotation_sigma
        self.rotations: dict[tuple[int, int], np.ndarray] = {}  # (keyframe i, keyframe j) → R_j←i from the pairs
        self.window, self.fixed, self.ba_iterations = window, fixed, ba_iterations
        self.min_cos = float(np.cos(np.radians(min_angle_deg)))
        self.keyframes: list[Keyframe] = []
        self.poses: dict[int, np.ndarray] = {}  # every keyframe's pose, refined in place
        self.points: dict[int, MapPoint] = {}
        self.tracks: dict[int, list[Obs]] = {}
        self._next = 0

    @property
    def last(self) -> Keyframe | None:
        return self.keyframes[-1] if self.keyframes else None

    def add(self, kf: Keyframe) -> None:
        self.keyframes.append(kf)
        self.poses[kf.id] = kf.T_wc
        for old in self.keyframes[:-2]:
            old.image = None

    def relate(self, i: int, j: int, R: np.ndarray) -> None:
        """Keyframe j's rotation from keyframe i, R_j←i (x_j = R x_i + t), as the frame pairs between them chain it."""
        self.rotations[(i, j)] = R

    def correspondences(self, ref: Keyframe, query: np.ndarray, train: np.ndarray) -> dict[int, int]:
        """Frame keypoint → map point, through the matches from ``ref`` whose keypoint there sees a point."""
        out: dict[int, int] = {}
        for q, t in zip(query.tolist(), train.tolist(), strict=True):
            pid = ref.points.get(q)
            if pid is not None and pid in self.points:
                out.setdefault(t, pid)
        return out

    def locate(self, xy: np.ndarray, seen: dict[int, int], *, min_points: int,
               min_inliers: int) -> tuple[np.ndarray, dict[int, int]] | None:
        """T_wc of the frame whose undistorted keypoints are ``xy`` from its keypoint → point correspondences (PnP +
        RANSAC), with the inlying ones; None with too few points or inliers."""
        if len(seen) < min_points:
            return None
        kps = list(seen)
        X = np.array([self.points[seen[k]].X for k in kps], np.float64)
        x = xy[kps].astype(np.float64)
        ok, rvec, tvec, inl = cv2.solvePnPRansac(X, x, self.K, None, reprojectionError=HUBER_PX, confidence=0.999,
                                                 iterationsCount=200, flags=cv2.SOLVEPNP_EPNP)
        if not ok or inl is None or len(inl) < min_inliers:
            return None
        idx: np.ndarray = inl.ravel().astype(np.int64)
        rvec, tvec = cv2.solvePnPRefineLM(X[idx], x[idx], self.K, None, rvec, tvec)
        T_cw = np.eye(4)
        T_cw[:3, :3] = cv2.Rodrigues(rvec)[0]
        T_cw[:3, 3] = tvec.ravel()
        return np.linalg.inv(T_cw), {kps[int(n)]: seen[kps[int(n)]] for n in idx}

    def step_sigma(self, T_wc: np.ndarray, xy: np.ndarray, sigma: np.ndarray, located: dict[int, int],
                   origin: np.ndarray) -> float:
        """The standard deviation of a located frame's distance along its step from ``origin`` (a position), as its
        map points (``located``: keypoint → point id, keypoints ``xy`` with σ ``sigma`` in px) determine it: the
        camera-centre block of (JᵀΣ⁻¹J)⁻¹, J the projections' Jacobian in the pose's six degrees of freedom (a rotation
        in the world frame and the centre) at T_wc, projected on the step's direction (Hartley & Zisserman §5.2, the
        covariance of a least-squares estimate). Points that all lie far ahead, many steps away, hardly move as the
        camera moves along its line of sight: the step's length is then left undetermined, however well they fit."""
        d = T_wc[:3, 3] - origin
        length = float(np.linalg.norm(d))
        if length == 0 or not located:
            return float("inf")
        kps = list(located)
        X = np.array([self.points[located[k]].X for k in kps], np.float64) - T_wc[:3, 3]  # X − c, world frame
        R = T_wc[:3, :3]
        Xc = X @ R  # Rᵀ (X − c): camera frame
        z = Xc[:, 2:3]
        f = np.array([self.K[0, 0], self.K[1, 1]])
        d_proj = np.zeros((len(kps), 2, 3))  # ∂(u, v)/∂X_c
        d_proj[:, 0, 0], d_proj[:, 1, 1] = f[0] / z[:, 0], f[1] / z[:, 0]
        d_proj[:, :, 2] = -f * Xc[:, :2] / z**2
        skew = np.zeros((len(kps), 3, 3))  # [X − c]×
        skew[:, 0, 1], skew[:, 0, 2], skew[:, 1, 2] = -X[:, 2], X[:, 1], -X[:, 0]
        skew -= skew.transpose(0, 2, 1)
        d_rot = R.T @ skew  # ∂X_c/∂δθ for R ← exp(δθ) R
        J = np.concatenate([d_proj @ d_rot, d_proj @ -R.T], axis=2) / np.asarray(sigma, np.float64)[kps, None, None]
        J = J.reshape(-1, 6)
        try:
            C = np.linalg.inv(J.T @ J)
        except np.linalg.LinAlgError:
            return float("inf")
        u = d / length
        return float(np.sqrt(max(u @ C[3:, 3:] @ u, 0.0)))

    def associate(self, ref: Keyframe, cur: Keyframe, query: np.ndarray, train: np.ndarray) -> int:
        """Carry ``ref``'s points and tracks to ``cur`` through the matches; triangulate tracks with parallax enough.
        Returns the number of new points."""
        live: dict[int, list[Obs]] = {}
        for q, t in zip(query.tolist(), train.tolist(), strict=True):
            if t in cur.points or t in cur.tracks:
                continue
            pid = ref.points.get(q)
            if pid is not None and pid in self.points:
                self.observe(cur, {t: pid})
                continue
            tid = ref.tracks.get(q)
            obs = self.tracks.get(tid) if tid is not None else None
            if obs is None or tid is None or tid in live:
                obs, tid = [(ref.id, q, ref.xy[q], float(ref.sigma[q]))], self._new_id()
            live[tid] = [*obs, (cur.id, t, cur.xy[t], float(cur.sigma[t]))]
            cur.tracks[t] = tid
        self.tracks = live
        return self._triangulate(cur)

    def observe(self, cur: Keyframe, seen: dict[int, int]) -> None:
        """Add ``cur``'s observations of map points (keypoint → point id) that reproject within √5.991 px."""
        T_cw = np.linalg.inv(cur.T_wc)
        for t, pid in seen.items():
            pt = self.points.get(pid)
            if pt is None or cur.id in pt.obs or t in cur.points or self._error(T_cw, pt.X, cur.xy[t]) > HUBER_PX * cur.sigma[t]:
                continue
            pt.obs[cur.id] = (t, cur.xy[t], float(cur.sigma[t]))
            pt.key, pt.descriptor = cur.key, cur.feats.descriptors[t]
            cur.points[t] = pid

    def search(self, T_wc: np.ndarray, key: str, feats: Features, xy: np.ndarray, *, radius: float, ratio: float,
               taken: set[int]) -> dict[int, int]:
        """Map points with a descriptor of configuration ``key`` projected into a frame at ``T_wc``: each matched to
        the keypoint within ``radius`` px of its projection whose descriptor is nearest, where that one passes the
        ratio test against the second nearest (Lowe 2004 §7.1; ORB-SLAM's search of the local map, §V-D).
        Keypoints in ``taken`` are skipped. Returns keypoint → point id."""
        pids = [pid for pid, pt in self.points.items() if pt.key == key and pt.descriptor is not None]
        if not pids or not len(xy):
            return {}
        X = np.array([self.points[pid].X for pid in pids])
        T_cw = np.linalg.inv(T_wc)
        c = X @ T_cw[:3, :3].T + T_cw[:3, 3]
        front = c[:, 2] > 0
        uv = (c[:, :2] / np.where(front, c[:, 2], 1.0)[:, None]) * [self.K[0, 0], self.K[1, 1]] + [self.K[0, 2], self.K[1, 2]]
        best: dict[int, tuple[float, int]] = {}  # keypoint → (distance, point id)
        for n in np.flatnonzero(front):
            near = np.flatnonzero(np.abs(xy - uv[n]).max(axis=1) <= radius)
            near = near[[k not in taken for k in near.tolist()]] if taken else near
            if not len(near):
                continue
            d = _distances(self.points[pids[n]].descriptor, feats.descriptors[near], feats.descriptor_kind)
            order = np.argsort(d)
            if len(order) > 1 and not d[order[0]] < ratio * d[order[1]]:
                continue
            k, dist = int(near[order[0]]), float(d[order[0]])
            if k not in best or dist < best[k][0]:
                best[k] = (dist, pids[n])
        return {k: pid for k, (_, pid) in best.items()}

    def switch(self, a: Keyframe, b: Keyframe, key: str, fa: Features, fb: Features, xa: np.ndarray, xb: np.ndarray,
               query: np.ndarray, train: np.ndarray) -> int:
        """Keyframes ``a`` then ``b`` (the last two) re-extracted with configuration ``key`` and matched; their matches
        triangulated from the poses they have. Returns the number of new points."""
        for kf, f, x in ((a, fa, xa), (b, fb, xb)):
            kf.key, kf.feats, kf.xy, kf.sigma, kf.points, kf.tracks = key, f, x, keypoint_sigma(f), {}, {}
        self.tracks = {}
        return self.associate(a, b, query, train)

    def refine(self) -> None:
        """Bundle-adjust the window (module docstring); drop observations it leaves beyond √5.991 px."""
        win = self.keyframes[-self.window:]
        if len(win) <= self.fixed:
            return
        ids = {kf.id for kf in win}
        seen = {pid: pt for pid, pt in self.points.items() if sum(i in ids for i in pt.obs) >= 2}
        if not seen:
            return
        obs = [(i, pid, xy, sigma) for pid, pt in seen.items() for i, (_, xy, sigma) in pt.obs.items() if i in ids]
        poses, xs = adjust({kf.id: kf.T_wc for kf in win}, [kf.id for kf in win[: self.fixed]],
                           {pid: pt.X for pid, pt in seen.items()}, obs, self.K, iterations=self.ba_iterations,
                           hold_range=(win[0].id, win[1].id) if self.fixed == 1 else None,
                           rotations=self.rotations, rotation_sigma=self.rotation_sigma)
        for kf in win:
            kf.T_wc = self.poses[kf.id] = poses[kf.id]
        by_id = {kf.id: kf for kf in win}
        T_cw = {kf.id: np.linalg.inv(kf.T_wc) for kf in win}
        for pid, pt in seen.items():
            pt.X = xs[pid]
            for i in [i for i in pt.obs if i in ids]:
                if self._error(T_cw[i], pt.X, pt.obs[i][1]) > HUBER_PX * pt.obs[i][2]:
                    self._drop(pid, i, by_id[i])
            if len(pt.obs) < 2:
                for i in list(pt.obs):
                    if i in by_id:
                        self._drop(pid, i, by_id[i])
                del self.points[pid]

    def forget(self, keep: int) -> None:
        """Drop points no keyframe among the last ``keep`` sees (they can no longer be matched)."""
        ids = {kf.id for kf in self.keyframes[-keep:]}
        self.points = {pid: pt for pid, pt in self.points.items() if any(i in ids for i in pt.obs)}
        self.keyframes = self.keyframes[-keep:]
        kept = {kf.id for kf in self.keyframes}
        self.rotations = {ij: R for ij, R in self.rotations.items() if ij[0] in kept and ij[1] in kept}

    def _drop(self, pid: int, i: int, kf: Keyframe) -> None:
        kp = self.points[pid].obs.pop(i)[0]
        if kf.points.get(kp) == pid:
            del kf.points[kp]

    def _new_id(self) -> int:
        self._next += 1
        return self._next

    def _T_cw(self, cache: dict[int, np.ndarray], i: int) -> np.ndarray:
        if i not in cache:
            cache[i] = np.linalg.inv(self.poses[i])
        return cache[i]

    def _error(self, T_cw: np.ndarray, X: np.ndarray, xy: np.ndarray) -> float:
        """Pixels between the projection of world point X by a camera at T_cw (world → camera) and ``xy``."""
        c = T_cw[:3, :3] @ X + T_cw[:3, 3]
        if c[2] <= 0:
            return float("inf")
        u = self.K @ (c / c[2])
        return float(np.hypot(u[0] - xy[0], u[1] - xy[1]))

    def _triangulate(self, cur: Keyframe) -> int:
        made = 0
        T_cw: dict[int, np.ndarray] = {}
        for tid, obs in list(self.tracks.items()):
            (i0, _, x0, _), (i1, _, x1, _) = obs[0], obs[-1]
            T0, T1 = self.poses[i0], self.poses[i1]
            r0 = T0[:3, :3] @ np.linalg.solve(self.K, [x0[0], x0[1], 1.0])
            r1 = T1[:3, :3] @ np.linalg.solve(self.K, [x1[0], x1[1], 1.0])
            if float(r0 @ r1) / (np.linalg.norm(r0) * np.linalg.norm(r1)) > self.min_cos:
                continue
            P0 = self.K @ self._T_cw(T_cw, i0)[:3]
            P1 = self.K @ self._T_cw(T_cw, i1)[:3]
            h = cv2.triangulatePoints(P0, P1, np.asarray(x0, np.float64).reshape(2, 1), np.asarray(x1, np.float64).reshape(2, 1))
            if abs(float(h[3, 0])) < 1e-12:
                continue
            X = h[:3, 0] / h[3, 0]
            if not np.isfinite(X).all() or any(
                    self._error(self._T_cw(T_cw, i), X, x) > HUBER_PX * sg for i, _, x, sg in obs):
                continue
            pid = self._new_id()
            self.points[pid] = MapPoint(X, {i: (kp, x, sg) for i, kp, x, sg in obs}, cur.key, cur.feats.descriptors[obs[-1][1]])
            for kf in self.keyframes[-len(obs) - 1:]:
                for i, kp, _, _ in obs:
                    if kf.id == i:
                        kf.points[kp] = pid
                        kf.tracks.pop(kp, None)
            del self.tracks[tid]
            made += 1
        return made


def _distances(d: np.ndarray | None, many: np.ndarray, kind: str) -> np.ndarray:
    """Hamming distances (binary descriptors) or L2 distances (real ones) from ``d`` to each row of ``many``."""
    assert d is not None
    if kind == "binary":
        return np.unpackbits(np.bitwise_xor(many, d[None, :]), axis=1).sum(axis=1).astype(np.float64)
    return np.linalg.norm(many.astype(np.float64) - d[None, :].astype(np.float64), axis=1)


def keypoint_sigma(feats: Features) -> np.ndarray:
    """Each keypoint's standard deviation in px: its size over the frame's smallest, at least 1 — a keypoint found
    at a coarser scale is located as coarsely (ORB-SLAM weighs an observation by the scale of its pyramid level,
    σ = 1.2^level, which this is for ORB: size = 31 × 1.2^level)."""
    size = np.asarray(feats.size, np.float64)
    if not len(size) or not (size > 0).any():
        return np.ones(len(size))
    return np.maximum(size / size[size > 0].min(), 1.0)
