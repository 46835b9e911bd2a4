"""Lens models of the loaded datasets: undistort pixel coordinates to the ideal pinhole image.

- ``radtan`` (EuRoC, TUM; OpenCV's model on normalised coordinates, k1 k2 p1 p2 [k3]): ``cv2.undistortPoints``.
- ``radial_pixel`` (the handheld set): p_d = c + (p − c)(1 + k1 r² + k2 r⁴), r = ‖p − c‖ in pixels;
  inverted by fixed-point iteration p ← c + (p_d − c) / (1 + k1 r(p)² + k2 r(p)⁴).
"""
from __future__ import annotations

import numpy as np

from ..errors import BadInput
from .base import Intrinsics


def distort_points(intr: Intrinsics, pts: np.ndarray) -> np.ndarray:
    """Ideal pixel coordinates (N, 2) → distorted ones, the forward model of ``intr``."""
    pts = np.asarray(pts, dtype=float).reshape(-1, 2)
    if not intr.distortion:
        return pts.copy()
    if intr.distortion_model == "radial_pixel":
        c = np.array([intr.cx, intr.cy])
        k1, k2 = (list(intr.distortion) + [0.0, 0.0])[:2]
        d = pts - c
        r2 = np.sum(d * d, axis=1, keepdims=True)
        return c + d * (1 + k1 * r2 + k2 * r2 * r2)
    if intr.distortion_model == "radtan":
        import cv2

        x = (pts - [intr.cx, intr.cy]) / [intr.fx, intr.fy]
        obj = np.c_[x, np.ones(len(x))].astype(np.float64)
        out, _ = cv2.projectPoints(obj, np.zeros(3), np.zeros(3), intr.K, np.array(intr.distortion, dtype=float))
        return out.reshape(-1, 2)
    raise BadInput(f"unknown distortion model {intr.distortion_model!r}; known: radtan, radial_pixel")


def undistort_points(intr: Intrinsics, pts: np.ndarray, iterations: int = 20) -> np.ndarray:
    """Distorted pixel coordinates (N, 2) → ideal pinhole pixel coordinates under ``intr.K``."""
    pts = np.asarray(pts, dtype=float).reshape(-1, 2)
    if not intr.distortion or len(pts) == 0:
        return pts.copy()
    if intr.distortion_model == "radial_pixel":
        c = np.array([intr.cx, intr.cy])
        k1, k2 = (list(intr.distortion) + [0.0, 0.0])[:2]
        d_obs = pts - c
        d = d_obs.copy()
        for _ in range(iterations):
            r2 = np.sum(d * d, axis=1, keepdims=True)
            d = d_obs / (1 + k1 * r2 + k2 * r2 * r2)
        return c + d
    if intr.distortion_model == "radtan":
        import cv2

        # OpenCV's default stops after 5 iterations, too few for EuRoC's strong barrel at the corners
        criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 10 * iterations, 1e-10)
        out = cv2.undistortPoints(
            pts.reshape(-1, 1, 2), intr.K, np.array(intr.distortion, dtype=float), R=None, P=intr.K, criteria=criteria
        )
        return out.reshape(-1, 2)
    raise BadInput(f"unknown distortion model {intr.distortion_model!r}; known: radtan, radial_pixel")
