"""The synthetic generator: images agree with its ground-truth poses (plane-induced homography)."""
from __future__ import annotations

import cv2
import numpy as np
import pytest
from nfex_slam.datasets.synthetic import PLANES, make_sequence

from nfex_core.errors import ParameterError


def _wall_homography(seq, i: int, j: int) -> np.ndarray:  # type: ignore[no-untyped-def]
    """H mapping frame i's pixels on the wall to frame j's: K (R − t nᵀ/d) K⁻¹ in camera i's frame."""
    t_ji = np.linalg.inv(seq.poses[j]) @ seq.poses[i]
    r, t = t_ji[:3, :3], t_ji[:3, 3]
    wall = PLANES["wall"]
    r_wi = seq.poses[i][:3, :3]
    n = r_wi.T @ np.cross(wall.e1, wall.e2)  # plane normal in camera i
    d = float(n @ (r_wi.T @ (wall.origin - seq.poses[i][:3, 3])))  # n·X = d for points X on the wall
    k = seq.intrinsics.K
    return k @ (r + np.outer(t, n) / d) @ np.linalg.inv(k)


def test_images_follow_the_ground_truth() -> None:
    seq = make_sequence(6, planes=("wall",), seed=3)
    orb = cv2.ORB_create(1500)
    kp0, d0 = orb.detectAndCompute(seq[0].image, None)
    kp5, d5 = orb.detectAndCompute(seq[5].image, None)
    matches = cv2.BFMatcher(cv2.NORM_HAMMING, crossCheck=True).match(d0, d5)
    p0 = np.float32([kp0[m.queryIdx].pt for m in matches])
    p5 = np.float32([kp5[m.trainIdx].pt for m in matches])
    h_true = _wall_homography(seq, 0, 5)
    pred = cv2.perspectiveTransform(p0.reshape(-1, 1, 2), h_true).reshape(-1, 2)
    err = np.linalg.norm(pred - p5, axis=1)
    assert len(matches) > 200
    assert np.median(err) < 1.0  # ORB's own localisation noise; a wrong pose convention gives tens of px
    # and the poses are not trivial: the frames moved by many pixels
    assert np.median(np.linalg.norm(p5 - p0, axis=1)) > 10


def test_sequence_properties() -> None:
    seq = make_sequence(5, 160, 120, context={"scene": "indoor"})
    assert len(seq) == 5 and seq[0].image.shape == (120, 160) and seq[0].image.dtype == np.uint8
    assert seq.poses.shape == (5, 4, 4) and seq.context == {"scene": "indoor"}
    assert seq[4].context == {"scene": "indoor"}
    assert (seq[0].image > 0).mean() > 0.99  # the planes fill the view
    assert np.array_equal(make_sequence(2, 160, 120)[1].image, make_sequence(2, 160, 120)[1].image)
    assert not np.array_equal(make_sequence(2, 160, 120, seed=1)[1].image, seq[1].image)
    with pytest.raises(ParameterError):
        make_sequence(3, planes=("ceiling",))


def test_ground_truth_warp_is_sub_pixel() -> None:
    """Warping frame 0 by the ground-truth homography reproduces frame 5 far better than the same
    warp shifted by one pixel: the poses explain the images to a fraction of a pixel."""
    seq = make_sequence(6, planes=("wall",), seed=3)
    size = (seq.intrinsics.width, seq.intrinsics.height)
    h = _wall_homography(seq, 0, 5)
    inside = cv2.warpPerspective(np.full(seq[0].image.shape, 255, np.uint8), h, size) == 255
    inside = cv2.erode(inside.astype(np.uint8), np.ones((5, 5))) > 0
    target = seq[5].image.astype(float)

    def residual(shift: float) -> float:
        s = np.array([[1.0, 0, shift], [0, 1.0, 0], [0, 0, 1.0]])
        return float(np.abs(cv2.warpPerspective(seq[0].image, s @ h, size).astype(float) - target)[inside].mean())

    assert residual(0.0) < 0.5 * residual(1.0) < residual(2.0)
