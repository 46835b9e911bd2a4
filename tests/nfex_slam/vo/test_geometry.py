from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from nfex_slam.vo.geometry import relative_pose, triangulate

K = np.array([[700.0, 0, 620], [0, 700.0, 190], [0, 0, 1]])


def _rot(rx: float, ry: float, rz: float) -> np.ndarray:
    import cv2

    return cv2.Rodrigues(np.array([rx, ry, rz]))[0]


def _project(X: np.ndarray) -> np.ndarray:
    x = X @ K.T
    return x[:, :2] / x[:, 2:]


@settings(max_examples=10, deadline=None)
@given(
    angles=st.tuples(*[st.floats(-0.05, 0.05)] * 3),
    direction=st.tuples(st.floats(-0.3, 0.3), st.floats(-0.1, 0.1), st.just(1.0)),
    seed=st.integers(0, 10_000),
)
def test_relative_pose_recovers_rotation_and_direction(angles, direction, seed) -> None:  # type: ignore[no-untyped-def]
    """X₂ = R X₁ + t for random scenes: R to 2e-3 rad, t's direction to 2e-2 (what a 1 px threshold leaves on exact
    points), every exact point an inlier."""
    rng = np.random.default_rng(seed)
    X1 = np.column_stack([rng.uniform(-20, 20, 300), rng.uniform(-5, 5, 300), rng.uniform(4, 40, 300)])
    R = _rot(*angles)
    t = np.array(direction) / np.linalg.norm(direction)
    X2 = X1 @ R.T + t
    rel = relative_pose(_project(X1), _project(X2), K)
    assert rel is not None
    dR = rel.R @ R.T
    assert np.arccos(np.clip((np.trace(dR) - 1) / 2, -1, 1)) < 2e-3
    assert np.linalg.norm(rel.t - t) < 2e-2
    assert rel.inliers.mean() > 0.95
    # triangulation with the true motion puts the points back where they were, in camera 2
    Y, ok = triangulate(_project(X1), _project(X2), K, R, t)
    assert ok.all()
    assert np.allclose(Y, X2, rtol=1e-6, atol=1e-6)


def test_too_few_points_is_no_model() -> None:
    p = np.zeros((4, 2))
    assert relative_pose(p, p, K) is None


def test_mutual_ratio_matching_equals_opencv_knn_and_reverse_match() -> None:
    """The mutual-ratio matcher (XFeat's, from the graph) at BLAS speed gives the pairs that OpenCV's
    brute-force knnMatch (ratio test) plus a reverse match (mutual check) give."""
    import cv2
    from nfex_slam.vo.geometry import mutual_ratio_l2

    rng = np.random.default_rng(3)
    a = rng.normal(size=(700, 64)).astype(np.float32)
    b = np.concatenate([a[:400] + 0.3 * rng.normal(size=(400, 64)).astype(np.float32),
                        rng.normal(size=(500, 64)).astype(np.float32)])
    q, t = mutual_ratio_l2(a, b, 0.8, chunk=128)
    bf = cv2.BFMatcher(cv2.NORM_L2)
    back = bf.match(b, a)
    expected = {(m[0].queryIdx, m[0].trainIdx) for m in bf.knnMatch(a, b, k=2)
                if m[0].distance < 0.8 * m[1].distance and back[m[0].trainIdx].trainIdx == m[0].queryIdx}
    assert 300 < len(expected) <= 400
    assert set(zip(q.tolist(), t.tolist(), strict=True)) == expected
