"""The handheld checkerboard set: ``images/img_NNNN.jpg`` (from 0001), ``poses.txt``, ``K.txt``, ``D.txt``.

``poses.txt`` gives per frame a rotation vector r and a translation t of the world-to-camera
transform (world = the checkerboard plane, metres): x_c = R(r)·x_w + t. The camera-to-world pose of
``Sequence`` is its inverse, [Rᵀ | −Rᵀ t]. ``D.txt`` holds radial k1 k2 applied to *pixel* offsets
from the principal point, p_d = c + (p − c)(1 + k1 r² + k2 r⁴) with r = ‖p − c‖ in pixels (model
name ``radial_pixel``; see ``camera.undistort_points``). The data has no clock: timestamps are the
frame numbers divided by an assumed 30 Hz.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import DataMissing, ParseError
from ..trajectory.ate import se3_inverse
from .base import Intrinsics
from .frames import ImageSequence, read_grey

CONTEXT = {"agent": "human", "scene": "indoor"}
ASSUMED_RATE_HZ = 30.0


def rodrigues(rvec: np.ndarray) -> np.ndarray:
    """Rotation matrix of a rotation vector (axis · angle), R = I + sin θ K + (1 − cos θ) K²."""
    theta = float(np.linalg.norm(rvec))
    if theta < 1e-12:
        return np.eye(3)
    x, y, z = np.asarray(rvec, dtype=float) / theta
    k = np.array([[0, -z, y], [z, 0, -x], [-y, x, 0]])
    return np.eye(3) + np.sin(theta) * k + (1 - np.cos(theta)) * (k @ k)


def _need(path: Path) -> Path:
    if not path.exists():
        raise DataMissing(f"handheld {path.name} {path} does not exist")
    return path


def load_handheld(path: str | Path, sequence: str | None = None) -> ImageSequence:
    """The handheld sequence in ``path`` (or ``path/sequence``, e.g. ``handheld`` + ``checkerboard``)."""
    folder = Path(path) / sequence if sequence else Path(path)
    image_dir = _need(folder / "images")
    rows = np.loadtxt(_need(folder / "poses.txt"), ndmin=2)
    if rows.shape[1] != 6:
        raise ParseError(f"{folder / 'poses.txt'}: {rows.shape[1]} numbers per line, expected 6 (rvec, tvec)")
    k = np.loadtxt(_need(folder / "K.txt"))
    if k.shape != (3, 3):
        raise ParseError(f"{folder / 'K.txt'}: expected a 3×3 matrix, got shape {k.shape}")
    dist = np.loadtxt(_need(folder / "D.txt"), ndmin=1)
    paths = [image_dir / f"img_{i:04d}.jpg" for i in range(1, rows.shape[0] + 1)]
    for p in paths:
        if not p.is_file():
            raise DataMissing(f"handheld image {p} does not exist (poses.txt has {len(paths)} lines)")
    world_to_cam = np.tile(np.eye(4), (len(paths), 1, 1))
    world_to_cam[:, :3, :3] = [rodrigues(row[:3]) for row in rows]
    world_to_cam[:, :3, 3] = rows[:, 3:6]
    poses = se3_inverse(world_to_cam)
    h, w = read_grey(paths[0]).shape[:2]
    intr = Intrinsics(
        float(k[0, 0]), float(k[1, 1]), float(k[0, 2]), float(k[1, 2]), int(w), int(h),
        distortion=tuple(float(v) for v in dist), distortion_model="radial_pixel",
    )
    ts = np.arange(len(paths), dtype=float) / ASSUMED_RATE_HZ
    return ImageSequence("handheld", folder.name, intr, paths, ts, poses, CONTEXT)
