"""The VO's local map: window bundle adjustment, PnP tracking on real frames, and a configuration switch that keeps
the trajectory's scale."""
from __future__ import annotations

from typing import Any

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from nfex_slam.datasets import ArraySequence
from nfex_slam.datasets.base import Sequence
from nfex_slam.features import Features
from nfex_slam.motion import rotation_deg
from nfex_slam.trajectory.frontend import pair_errors
from nfex_slam.vo import Choice, VOParams, fixed, run_vo, window_errors
from nfex_slam.vo.bundle import HUBER_PX, adjust

from nfex_core.vision.registry import ExtractorRegistry

K = np.array([[500.0, 0, 320], [0, 500, 240], [0, 0, 1]])

# the seed spread (std/mean of the monocular ATE over RANSAC seeds) the map is held to (docs/vo.md has the measured
# spreads)
SEED_SPREAD = 0.25


def _pose(yaw: float, x: float, z: float) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = _yaw(yaw)
    T[:3, 3] = [x, 0.1 * z, z]
    return T


def _project(T_wc: np.ndarray, X: np.ndarray) -> np.ndarray:
    T = np.linalg.inv(T_wc)
    c = X @ T[:3, :3].T + T[:3, 3]
    return (c[:, :2] / c[:, 2:]) @ np.diag([K[0, 0], K[1, 1]]) + K[:2, 2]


def _yaw(angle: float) -> np.ndarray:
    """The rotation by ``angle`` (radians) about the camera's vertical axis."""
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def _scene(seed: int) -> tuple[np.random.Generator, dict[int, np.ndarray], np.ndarray, list[tuple[int, int, np.ndarray, float]]]:
    """Five poses moving forward and turning, 60 points in front of them, and every exact observation (σ 1 px)."""
    rng = np.random.default_rng(seed)
    poses = {i: _pose(0.03 * i, 0.2 * i, 1.0 * i) for i in range(5)}
    X = rng.uniform([-4, -2, 8], [4, 2, 20], (60, 3))
    return rng, poses, X, [(i, j, xy, 1.0) for i, T in poses.items() for j, xy in enumerate(_project(T, X))]


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**16), noise=st.floats(0.02, 0.15))
def test_the_window_adjustment_recovers_poses_and_points_with_its_oldest_held(seed: int, noise: float) -> None:
    rng, poses, X, obs = _scene(seed)
    start = {i: T.copy() for i, T in poses.items()}
    for i in (2, 3, 4):
        start[i][:3, 3] += rng.normal(0, noise, 3)
    points = {j: X[j] + rng.normal(0, 3 * noise, 3) for j in range(len(X))}
    out_poses, out_points = adjust(start, [0, 1], points, obs, K, iterations=30)
    assert np.array_equal(out_poses[0], poses[0]) and np.allclose(out_poses[1], poses[1])  # the gauge: held
    for i in (2, 3, 4):
        assert np.linalg.norm(out_poses[i][:3, 3] - poses[i][:3, 3]) < 1e-3
    assert max(np.linalg.norm(out_points[j] - X[j]) for j in out_points) < 1e-2


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**16), noise=st.floats(0.005, 0.03))
def test_relative_rotations_that_agree_with_the_points_leave_the_adjustment_where_the_points_put_it(seed: int, noise: float) -> None:
    rng, poses, X, obs = _scene(seed)
    start = {i: T.copy() for i, T in poses.items()}
    for i in (2, 3, 4):  # each pose turned about its vertical axis by up to ~2°
        start[i][:3, :3] = start[i][:3, :3] @ _yaw(noise)
    R = {(i, i + 1): poses[i + 1][:3, :3].T @ poses[i][:3, :3] for i in range(4)}  # R_i+1←i, x_i+1 = R x_i + t
    out, _ = adjust(start, [0, 1], {j: X[j] for j in range(len(X))}, obs, K, iterations=30, rotations=R,
                    rotation_sigma=HUBER_PX / K[0, 0])
    for i in (2, 3, 4):
        assert np.linalg.norm(out[i][:3, 3] - poses[i][:3, 3]) < 1e-3
        assert np.degrees(np.arccos(np.clip((np.trace(out[i][:3, :3].T @ poses[i][:3, :3]) - 1) / 2, -1, 1))) < 0.01


def _window(seq: Sequence, n: int) -> ArraySequence:
    frames = [seq[i] for i in range(n)]
    poses = np.stack([f.pose for f in frames])  # type: ignore[arg-type]
    return ArraySequence(seq.dataset, seq.name, seq.intrinsics, [f.image for f in frames],
                         np.array([f.timestamp for f in frames]), poses, seq.context)


class _Counted:
    """The registry, extractions counted per frame image and memoised (identical images and configuration give
    identical features)."""

    def __init__(self, registry: ExtractorRegistry) -> None:
        self.registry = registry
        self.calls: list[int] = []
        self.memo: dict[tuple[str, str, int], Features] = {}

    def extract(self, name: str, image: np.ndarray, params: Any = None) -> Features:
        self.calls.append(id(image))
        key = (name, repr(sorted((params or {}).items())), id(image))
        if key not in self.memo:
            self.memo[key] = self.registry.extract(name, image, params)
        return self.memo[key]

    def resolve(self, name: str, params: Any = None) -> dict[str, Any]:
        return dict(self.registry.resolve(name, params))


def test_frames_are_located_on_the_map_and_keep_the_first_steps_scale(kitti00: Sequence, registry: ExtractorRegistry) -> None:
    seq = _window(kitti00, 12)
    res = run_vo(seq, fixed("ORB"), registry=registry, params=VOParams(scale="map"))
    assert res.lost_count == 0
    assert sum(f.located == "pnp" for f in res.frames) >= 8 and all(f.map_points >= 10 for f in res.frames if f.located == "pnp")
    steps = np.linalg.norm(np.diff(res.poses[:, :3, 3], axis=0), axis=1)
    # the map's scale is the first steps' (one step's length each), held by the window's oldest keyframes; frame 1 lies
    # at its share of the pairs' path on the line between the map's first two keyframes, shorter where the path bends
    assert steps[0] == pytest.approx(1.0, rel=0.05)
    ate = window_errors(seq, res)[0]
    path = np.linalg.norm(np.diff(seq.poses[:, :3, 3], axis=0), axis=1).sum()  # type: ignore[index]
    assert ate is not None and ate < 0.05 * path


def test_a_switch_re_extracts_the_last_two_keyframes(kitti00: Sequence, registry: ExtractorRegistry) -> None:
    seq = _window(kitti00, 8)
    counted = _Counted(registry)

    def switch_at_5(frame, history):  # type: ignore[no-untyped-def]
        return Choice("SIFT") if frame.index >= 5 else Choice("ORB")

    res = run_vo(seq, switch_at_5, registry=counted, params=VOParams(scale="map"))
    images = [id(seq[i].image) for i in range(8)]
    extracted = [images.index(c) for c in counted.calls]
    # frames 0-4 once each; at frame 5: frame 5, frame 4 (the pair's comparable descriptors) and keyframe 3
    assert extracted[:5] == [0, 1, 2, 3, 4]
    assert sorted(extracted[5:8]) == [3, 4, 5]
    assert res.lost_count == 0 and res.frames[5].located == "pnp"


@pytest.mark.slow
def test_alternating_two_equally_good_configurations_keeps_the_ate_of_either(kitti00: Sequence, registry: ExtractorRegistry) -> None:
    """Every 5 frames SIFT with 1500 ↔ 2000 features: the alternating run's monocular ATE lies within the seed
    spread of the two configurations' own."""
    seq = _window(kitti00, 20)
    counted = _Counted(registry)
    a, b = Choice("SIFT", {"nfeatures": 1500}), Choice("SIFT", {"nfeatures": 2000})
    alone = [window_errors(seq, run_vo(seq, lambda f, h, c=c: c, registry=counted, params=VOParams(seed=0, scale="map")))[0] for c in (a, b)]

    def alternate(frame, history):  # type: ignore[no-untyped-def]
        return a if (frame.index // 5) % 2 == 0 else b

    res = run_vo(seq, alternate, registry=counted, params=VOParams(seed=0, scale="map"))
    assert res.lost_count == 0
    assert {f.params.get("nfeatures") for f in res.frames} == {1500, 2000}
    both = window_errors(seq, res)[0]
    assert both is not None and all(x is not None for x in alone)
    mean = float(np.mean(alone))  # type: ignore[arg-type]
    assert abs(both - mean) <= SEED_SPREAD * mean + abs(alone[0] - alone[1]) / 2  # type: ignore[operator]


def _heading_error(res_pose: np.ndarray, truth: np.ndarray) -> float:
    return rotation_deg(res_pose[:3, :3].T @ truth[:3, :3])


@pytest.mark.slow
def test_the_map_keeps_its_heading_through_a_turn_it_could_fit_wrongly(kitti00: Sequence, registry: ExtractorRegistry) -> None:
    """KITTI 00, ORB_GRID defaults, seed 2, frames 0–169: few map points through the turn after frame 140 can fit a
    wrong heading; the pairs' rotations, held between consecutive keyframes in the window's adjustment, keep the
    map's (docs/vo.md, Per frame)."""
    seq = _window(kitti00, 170)
    res = run_vo(seq, fixed("ORB_GRID"), registry=registry, params=VOParams(seed=2, scale="map"))
    assert res.lost_count == 0
    truth = np.linalg.inv(seq.poses[0]) @ seq.poses  # type: ignore[index]
    before, after = _heading_error(res.poses[140], truth[140]), _heading_error(res.poses[-1], truth[-1])
    assert after < before + 3.0  # the 2.5° the camera turns between them add less than 3° of heading error


def _one_pair_wrong(monkeypatch: pytest.MonkeyPatch, which: int) -> None:
    """The ``which``-th pair's estimate (1: the first) turned 1.7° in yaw and its direction 80° sideways: what
    MAGSAC++ returned for KITTI 01's first ORB_GRID pair in some RANSAC draws."""
    from nfex_slam.vo import twoview
    from nfex_slam.vo.geometry import RelativePose

    real = twoview.relative_pose
    calls = {"n": 0}

    def wrong(p1: np.ndarray, p2: np.ndarray, K: np.ndarray, **kw: Any) -> RelativePose | None:
        rel = real(p1, p2, K, **kw)
        calls["n"] += 1
        if calls["n"] != which or rel is None:
            return rel
        return RelativePose(_yaw(np.radians(1.7)) @ rel.R, _yaw(np.radians(80.0)) @ rel.t, rel.inliers, rel.parallax_px)

    monkeypatch.setattr(twoview, "relative_pose", wrong)


def test_a_map_started_on_a_wrong_pair_is_given_up_and_started_again_from_its_first_keyframe(
        kitti01: Sequence, registry: ExtractorRegistry, monkeypatch: pytest.MonkeyPatch) -> None:
    """The map starts on the wrong first pair (frames 0, 1); its first PnP placement disagrees with the next pair's
    rotation, and so does the essential matrix of frames 0 and 2: the map starts again from frame 0, which the wrong
    pair did not place, and the heading error of the run's last frame is not the first pair's."""
    _one_pair_wrong(monkeypatch, 1)
    seq = _window(kitti01, 14)
    res = run_vo(seq, fixed("SIFT"), registry=registry, params=VOParams(seed=0, scale="map"))
    assert [f.located for f in res.frames].count("restart") == 1 and res.lost_count == 0
    truth = np.linalg.inv(seq.poses[0]) @ seq.poses  # type: ignore[index]
    first, last = _heading_error(res.poses[1], truth[1]), _heading_error(res.poses[-1], truth[-1])
    assert first > 1.0 and last < 0.5


def test_a_wrong_pair_right_after_the_start_does_not_give_the_map_up(
        kitti01: Sequence, registry: ExtractorRegistry, monkeypatch: pytest.MonkeyPatch) -> None:
    """The pair after the start (frames 1, 2) is the wrong one: the map's first PnP placement disagrees with it, the
    essential matrix of frames 0 and 2 agrees with the map, and the map is kept."""
    _one_pair_wrong(monkeypatch, 2)
    seq = _window(kitti01, 14)
    res = run_vo(seq, fixed("SIFT"), registry=registry, params=VOParams(seed=0, scale="map"))
    assert [f.located for f in res.frames][:3] == ["", "essential", "pnp"] and res.lost_count == 0
    assert "restart" not in [f.located for f in res.frames]
    truth = np.linalg.inv(seq.poses[0]) @ seq.poses  # type: ignore[index]
    assert max(_heading_error(res.poses[k], truth[k]) for k in range(len(seq))) < 0.5


def test_the_frames_placed_before_the_map_lie_on_the_line_between_its_first_two_keyframes(
        kitti01: Sequence, registry: ExtractorRegistry, monkeypatch: pytest.MonkeyPatch) -> None:
    """The wrong first pair sends frame 1 80° sideways; once the map has started again from frame 0, frame 1 lies on
    the line from frame 0 to the map's second keyframe, within a few degrees of the road."""
    _one_pair_wrong(monkeypatch, 1)
    seq = _window(kitti01, 14)
    res = run_vo(seq, fixed("SIFT"), registry=registry, params=VOParams(seed=0, scale="map"))
    truth = np.linalg.inv(seq.poses[0]) @ seq.poses  # type: ignore[index]
    assert pair_errors(res.poses[:2], truth[:2]).direction[0] < 5.0


def test_the_trial_chains_every_pair_since_the_maps_first_keyframe(
        kitti01: Sequence, registry: ExtractorRegistry, monkeypatch: pytest.MonkeyPatch) -> None:
    """KITTI 01, ORB_GRID, seed 8: the map started on frames 0 and 4 makes frame 5, placed by its pair, a keyframe, and
    its first PnP placement, frame 6, disagrees with the pair. The rotation the trial compares the third estimate with
    chains all six pairs from frame 0 (within 0.5° of the truth), those from frame 5 too."""
    from nfex_slam.vo.tracking import MapTracker

    chained: list[tuple[int, int, np.ndarray | None]] = []
    real = MapTracker._arbitrate

    def arbitrate(self: MapTracker, T: np.ndarray, taken: Any, xy: np.ndarray) -> tuple[str, float]:
        chained.append((self.map.keyframes[0].id, self.placed, self.started))
        return real(self, T, taken, xy)

    monkeypatch.setattr(MapTracker, "_arbitrate", arbitrate)
    seq = _window(kitti01, 8)
    run_vo(seq, fixed("ORB_GRID"), registry=registry, params=VOParams(seed=8, scale="map"))
    assert [(s, k) for s, k, _ in chained] == [(0, 6)]
    R = chained[0][2]
    assert R is not None
    truth = seq.poses[6][:3, :3].T @ seq.poses[0][:3, :3]  # type: ignore[index]
    assert rotation_deg(R @ truth.T) < 0.5


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**16), yaw=st.floats(-0.3, 0.3))
def test_the_step_sigma_is_the_least_squares_covariance_of_the_camera_centre(seed: int, yaw: float) -> None:
    """``LocalMap.step_sigma`` against the same covariance from a Jacobian by finite differences."""
    from nfex_slam.vo.localmap import LocalMap, MapPoint

    rng = np.random.default_rng(seed)
    T = _pose(yaw, 0.5, 2.0)
    X = T[:3, 3] + rng.uniform([-6, -3, 4], [6, 3, 30], (25, 3)) @ T[:3, :3].T
    m = LocalMap(K)
    m.points = {j: MapPoint(x) for j, x in enumerate(X)}
    sigma = rng.uniform(1, 3, len(X))

    def residuals(p: np.ndarray) -> np.ndarray:
        T2 = T.copy()
        T2[:3, :3] = cv2.Rodrigues(p[:3])[0] @ T[:3, :3]
        T2[:3, 3] = T[:3, 3] + p[3:]
        return ((_project(T2, X) - _project(T, X)) / sigma[:, None]).ravel()

    h = 1e-6
    J = np.stack([(residuals(h * e) - residuals(-h * e)) / (2 * h) for e in np.eye(6)], axis=1)
    C = np.linalg.inv(J.T @ J)
    u = T[:3, 3] / np.linalg.norm(T[:3, 3])
    expected = float(np.sqrt(u @ C[3:, 3:] @ u))
    assert m.step_sigma(T, _project(T, X), sigma, {j: j for j in range(len(X))}, np.zeros(3)) == pytest.approx(expected, rel=1e-4)


def test_points_far_ahead_leave_a_forward_step_undetermined() -> None:
    """A forward step of 1 among 16 points 60–170 steps ahead near the line of sight (KITTI 01's first map with
    ORB_GRID: a highway's far points lie about its vanishing point) is left to a σ beyond the gate's bound,
    (1 − 1/2) / 1.96 of the step; among points 5–20 steps away across the view, to a few per cent of it."""
    from nfex_slam.vo.localmap import LocalMap, MapPoint

    rng = np.random.default_rng(0)
    T = np.eye(4)
    T[2, 3] = 1.0
    for side, depth, (low, high) in ((0.15, (60, 170), (0.5 / 1.96, 10.0)), (0.4, (5, 20), (0.0, 0.05))):
        X = np.c_[rng.uniform(-side, side, (16, 2)), np.ones(16)] * rng.uniform(*depth, (16, 1))
        m = LocalMap(K)
        m.points = {j: MapPoint(x) for j, x in enumerate(X)}
        ratio = m.step_sigma(T, _project(T, X), np.full(16, 1.2), {j: j for j in range(16)}, np.zeros(3))
        assert low < ratio < high


def test_a_first_placement_its_far_points_leave_undetermined_is_made_by_the_pair(
        kitti01: Sequence, registry: ExtractorRegistry) -> None:
    """KITTI 01, ORB_GRID, seed 7: the map's first PnP placement sees 17 points 60–170 steps ahead and puts the step
    at about half the truth's, and the map went on at that scale until its window had grown it back 8 % past the
    start's. The gate leaves that step to the pair's essential matrix and the last step's length: the last ten steps of
    25 frames keep the start's scale within 5 %."""
    seq = _window(kitti01, 25)
    res = run_vo(seq, fixed("ORB_GRID"), registry=registry, params=VOParams(seed=7, scale="map"))
    c = res.poses[:, :3, 3]
    truth = np.asarray(seq.poses)[:, :3, 3]  # type: ignore[index]
    ratio = np.linalg.norm(np.diff(c, axis=0), axis=1) / np.linalg.norm(np.diff(truth, axis=0), axis=1)
    ratio /= ratio[:4].mean()  # the start's scale: frames 1–4 are placed at one step's length
    assert abs(ratio[-10:].mean() - 1) < 0.05, ratio.round(2)
