"""Umeyama alignment: the round trip align(T·traj, traj) == traj for random similarity transforms T."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from nfex_slam.trajectory import Trajectory, align, umeyama
from nfex_slam.trajectory.io import quaternion_to_matrix

from nfex_core.errors import BadInput


def _walk(seed: int, n: int = 30) -> Trajectory:
    rng = np.random.default_rng(seed)
    poses = np.tile(np.eye(4), (n, 1, 1))
    poses[:, :3, 3] = np.cumsum(rng.normal(size=(n, 3)), axis=0)
    q = rng.normal(size=(n, 4))
    poses[:, :3, :3] = quaternion_to_matrix(q)
    return Trajectory(np.arange(n, dtype=float), poses)


quaternions = st.lists(st.floats(-1, 1, allow_nan=False), min_size=4, max_size=4).filter(
    lambda q: np.linalg.norm(q) > 0.1
)


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 10_000),
    q=quaternions,
    t=st.lists(st.floats(-100, 100), min_size=3, max_size=3),
    s=st.floats(0.05, 20.0),
)
def test_align_undoes_a_similarity(seed: int, q: list[float], t: list[float], s: float) -> None:
    ref = _walk(seed)
    r = quaternion_to_matrix(np.array(q))
    moved = ref.poses.copy()
    moved[:, :3, :3] = r @ ref.poses[:, :3, :3]
    moved[:, :3, 3] = s * ref.positions @ r.T + np.array(t)
    est = Trajectory(ref.timestamps, moved)

    aligned, a = align(est, ref, "sim3")
    assert a.scale == pytest.approx(1 / s, rel=1e-7)
    assert np.allclose(aligned.poses, ref.poses, atol=1e-6)

    rigid = est.poses.copy()
    rigid[:, :3, 3] = ref.positions @ r.T + np.array(t)
    aligned, a = align(Trajectory(ref.timestamps, rigid), ref, "se3")
    assert a.scale == 1.0
    assert np.allclose(aligned.poses, ref.poses, atol=1e-6)


def test_reflection_is_never_returned() -> None:
    rng = np.random.default_rng(3)
    x = rng.normal(size=(50, 3))
    y = x * np.array([1, 1, -1])  # a mirror image: the best proper rotation is not a reflection
    a = umeyama(x, y)
    assert np.linalg.det(a.rotation) == pytest.approx(1.0)


def test_degenerate_points_are_refused() -> None:
    x = np.zeros((10, 3))
    with pytest.raises(BadInput, match="degenerate"):
        umeyama(x, x)


def test_none_is_identity() -> None:
    ref = _walk(1)
    aligned, a = align(ref, ref, "none")
    assert aligned is ref and a.scale == 1.0
