"""Front-end accuracy: a perfect estimate scores AUC 1 and errors 0; a similarity transform of the estimate
changes nothing; failed pairs count 180°; the AUC matches SuperGlue's definition on known curves."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from nfex_slam.trajectory.frontend import (
    LOST_DEG,
    frontend_ate,
    pair_errors,
    pose_auc,
    rechain_with_truth_lengths,
)
from nfex_slam.trajectory.io import quaternion_to_matrix


def _walk(seed: int, n: int = 25) -> np.ndarray:
    """A car-like trajectory: small yaw per step, forward motion of varying length."""
    rng = np.random.default_rng(seed)
    poses = np.tile(np.eye(4), (n, 1, 1))
    for k in range(1, n):
        yaw = rng.normal(0.0, 0.05)
        step = np.eye(4)
        step[:3, :3] = [[np.cos(yaw), 0, np.sin(yaw)], [0, 1, 0], [-np.sin(yaw), 0, np.cos(yaw)]]
        step[:3, 3] = [rng.normal(0, 0.05), rng.normal(0, 0.02), rng.uniform(0.5, 1.5)]
        poses[k] = poses[k - 1] @ step
    return poses


def _similarity(poses: np.ndarray, q: np.ndarray, t: np.ndarray, s: float) -> np.ndarray:
    r = quaternion_to_matrix(q)
    out = poses.copy()
    out[:, :3, :3] = r @ poses[:, :3, :3]
    out[:, :3, 3] = s * poses[:, :3, 3] @ r.T + t
    return out


def _noisy(poses: np.ndarray, seed: int) -> np.ndarray:
    """Each step perturbed in rotation and direction, its length scaled (a monocular estimate)."""
    rng = np.random.default_rng(seed + 1)
    out = poses.copy()
    for k in range(1, len(poses)):
        step = np.linalg.inv(poses[k - 1]) @ poses[k]
        step[:3, :3] = quaternion_to_matrix(np.r_[1.0, rng.normal(0, 0.01, 3)]) @ step[:3, :3]
        step[:3, 3] = (step[:3, 3] + rng.normal(0, 0.05, 3)) * rng.uniform(0.3, 3.0)
        out[k] = out[k - 1] @ step
    return out


quaternions = st.lists(st.floats(-1, 1, allow_nan=False), min_size=4, max_size=4).filter(lambda q: np.linalg.norm(q) > 0.1)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 10_000), q=quaternions, t=st.lists(st.floats(-100, 100), min_size=3, max_size=3),
       s=st.floats(0.05, 20.0))
def test_a_perfect_estimate_in_any_frame_and_scale_scores_auc_one_and_no_error(seed: int, q: list[float], t: list[float],
                                                                              s: float) -> None:
    truth = _walk(seed)
    est = _similarity(truth, np.array(q), np.array(t), s)
    e = pair_errors(est, truth)
    assert np.allclose(e.rotation, 0, atol=1e-4) and np.allclose(e.direction, 0, atol=1e-4)
    assert all(v == pytest.approx(1.0, abs=1e-4) for v in e.auc().values())
    assert frontend_ate(est, truth) == pytest.approx(0.0, abs=1e-6)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 10_000), q=quaternions, t=st.lists(st.floats(-100, 100), min_size=3, max_size=3),
       s=st.floats(0.05, 20.0), lost=st.lists(st.booleans(), min_size=24, max_size=24))
def test_a_similarity_transform_of_the_estimate_changes_no_figure(seed: int, q: list[float], t: list[float], s: float,
                                                                  lost: list[bool]) -> None:
    truth = _walk(seed)
    est = _noisy(truth, seed)
    moved = _similarity(est, np.array(q), np.array(t), s)
    a, b = pair_errors(est, truth, lost), pair_errors(moved, truth, lost)
    assert np.allclose(a.rotation, b.rotation, atol=1e-5) and np.allclose(a.direction, b.direction, atol=1e-5)
    assert a.auc() == pytest.approx(b.auc(), abs=1e-6)
    fa, fb = frontend_ate(est, truth), frontend_ate(moved, truth)
    assert fa is not None and fb == pytest.approx(fa, rel=1e-6, abs=1e-9)
    assert fa > 0


def test_failed_pairs_count_180_degrees_and_lower_the_auc() -> None:
    truth = _walk(3)
    failed = np.zeros(len(truth) - 1, dtype=bool)
    failed[[2, 5, 7]] = True
    e = pair_errors(truth, truth, failed)
    assert list(np.flatnonzero(e.error == LOST_DEG)) == [2, 5, 7]
    assert e.auc()[5.0] == pytest.approx(1 - 3 / 24, abs=1e-6)  # 21 perfect pairs of 24


def test_pose_auc_is_the_normalised_area_under_the_cumulative_error_curve() -> None:
    # one pair at 0°, one at 10°: the curve rises linearly from 0.5 at 0° to 1 at 10° (SuperGlue's trapezoids)
    assert pose_auc([0.0, 10.0], [5.0, 10.0, 20.0]) == pytest.approx({5.0: 0.5, 10.0: 0.5, 20.0: 0.875})
    # errors spread evenly on [0, 20]: the curve is the diagonal, AUC@20 = 1/2
    assert pose_auc(np.linspace(0, 20, 2001), [20.0])[20.0] == pytest.approx(0.5, abs=1e-3)
    assert pose_auc([LOST_DEG] * 4) == {5.0: 0.0, 10.0: 0.0, 20.0: 0.0}
    assert pose_auc([]) == {5.0: 0.0, 10.0: 0.0, 20.0: 0.0}


def test_direction_error_is_90_degrees_where_the_estimate_stands_still_and_the_truth_moves() -> None:
    truth = _walk(1, 3)
    est = truth.copy()
    est[2] = est[1]  # the second step did not translate (nor rotate)
    e = pair_errors(est, truth)
    assert e.direction[1] == pytest.approx(90.0) and e.direction[0] == pytest.approx(0.0, abs=1e-5)


def test_rechaining_takes_the_truth_step_lengths_and_keeps_directions() -> None:
    truth = _walk(5)
    est = _noisy(truth, 5)
    chained = rechain_with_truth_lengths(est, truth)
    step_len = np.linalg.norm(np.diff(chained[:, :3, 3], axis=0), axis=1)
    assert np.allclose(step_len, np.linalg.norm(np.diff(truth[:, :3, 3], axis=0), axis=1))
    assert np.allclose(pair_errors(chained, truth).direction, pair_errors(est, truth).direction, atol=1e-6)


def test_shapes_are_checked() -> None:
    with pytest.raises(ValueError, match="one shape"):
        pair_errors(_walk(0, 5), _walk(0, 6))
    with pytest.raises(ValueError, match="4 pairs"):
        pair_errors(_walk(0, 5), _walk(0, 5), [True])
