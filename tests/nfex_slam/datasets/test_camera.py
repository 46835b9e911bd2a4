"""Lens models: undistort(distort(p)) == p for both models the datasets use."""
from __future__ import annotations

import numpy as np
import pytest
from nfex_slam.datasets.base import Intrinsics
from nfex_slam.datasets.camera import distort_points, undistort_points

from nfex_core.errors import BadInput

EUROC = Intrinsics(458.654, 457.296, 367.215, 248.375, 752, 480, (-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05))
HANDHELD = Intrinsics(420.5, 420.6, 355.2, 250.3, 752, 480, (-1.6774e-06, 2.5847e-12), "radial_pixel")


@pytest.mark.parametrize("intr", [EUROC, HANDHELD], ids=["radtan", "radial_pixel"])
def test_round_trip(intr: Intrinsics) -> None:
    rng = np.random.default_rng(0)
    ideal = rng.uniform([100, 80], [650, 400], size=(200, 2))
    distorted = distort_points(intr, ideal)
    assert np.abs(distorted - ideal).max() > 1.0  # the model does something
    assert np.allclose(undistort_points(intr, distorted), ideal, atol=1e-3)


def test_radial_pixel_formula() -> None:
    p = np.array([[355.2 + 100.0, 250.3]])
    d = distort_points(HANDHELD, p)
    assert d[0, 0] == pytest.approx(355.2 + 100 * (1 - 1.6774e-06 * 1e4 + 2.5847e-12 * 1e8))


def test_unknown_model() -> None:
    with pytest.raises(BadInput, match="unknown distortion model"):
        undistort_points(Intrinsics(1, 1, 0, 0, 2, 2, (0.1,), "fisheye"), np.zeros((1, 2)) + 1)
