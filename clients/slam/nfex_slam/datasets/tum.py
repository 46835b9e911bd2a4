"""TUM RGB-D: ``rgb.txt`` (``timestamp rgb/file.png``), ``rgb/``, ``groundtruth.txt`` (TUM format).

Ground truth is the pose of the colour camera's optical centre in the motion-capture world
(camera-to-world, ``t tx ty tz qx qy qz qw``); each image takes the nearest pose within
``gt_max_diff`` seconds (TUM's ``associate.py`` default is 0.02 s). The datasets ship no calibration
file: the published ROS-default intrinsics of freiburg1/2/3 are chosen by the folder name, or a
``K.txt`` (3×3) and optional ``D.txt`` (k1 k2 p1 p2 k3) in the folder take precedence.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import DataMissing, ParseError
from ..trajectory.ate import matching_indices
from ..trajectory.io import read_tum
from .base import Intrinsics
from .frames import ImageSequence, read_grey

CONTEXT = {"agent": "human", "scene": "indoor"}

# https://cvg.cit.tum.de/data/datasets/rgbd-dataset/file_formats#intrinsic_camera_calibration_of_the_kinect
PUBLISHED = {
    "freiburg1": ((517.3, 516.5, 318.6, 255.3), (0.2624, -0.9531, -0.0054, 0.0026, 1.1633)),
    "freiburg2": ((520.9, 521.0, 325.1, 249.7), (0.2312, -0.7849, -0.0033, -0.0001, 0.9172)),
    "freiburg3": ((535.4, 539.2, 320.1, 247.6), ()),
}


def _calibration(folder: Path) -> tuple[tuple[float, float, float, float], tuple[float, ...]]:
    k_file = folder / "K.txt"
    if k_file.is_file():
        k = np.loadtxt(k_file).reshape(3, 3)
        d_file = folder / "D.txt"
        dist = tuple(float(v) for v in np.loadtxt(d_file, ndmin=1)) if d_file.is_file() else ()
        return (float(k[0, 0]), float(k[1, 1]), float(k[0, 2]), float(k[1, 2])), dist
    for key, value in PUBLISHED.items():
        if key in folder.name:
            return value
    raise DataMissing(f"no calibration for {folder}: add {k_file} or name the folder after freiburg1/2/3")


def load_tum(path: str | Path, sequence: str | None = None, gt_max_diff: float = 0.02) -> ImageSequence:
    """A TUM RGB-D sequence (the grey-converted colour images) from its folder or root + ``sequence``."""
    folder = Path(path) / sequence if sequence else Path(path)
    index = folder / "rgb.txt"
    if not index.is_file():
        raise DataMissing(f"TUM image list {index} does not exist")
    stamps: list[float] = []
    paths: list[Path] = []
    for lineno, line in enumerate(index.read_text().splitlines(), start=1):
        if not line.strip() or line.startswith("#"):
            continue
        parts = line.split()
        try:
            stamps.append(float(parts[0]))
            paths.append(folder / parts[1])
        except (ValueError, IndexError):
            raise ParseError(f"{index}:{lineno}: expected 'timestamp filename'", line=lineno) from None
    if not paths:
        raise DataMissing(f"{index} lists no images")
    for p in paths:
        if not p.is_file():
            raise DataMissing(f"TUM image {p} does not exist (listed in {index.name})")
    (fx, fy, cx, cy), dist = _calibration(folder)
    timestamps = np.array(stamps)
    poses = None
    gt_file = folder / "groundtruth.txt"
    if gt_file.is_file():
        gt = read_tum(gt_file)
        poses = np.full((len(paths), 4, 4), np.nan)
        i_img, i_gt = matching_indices(timestamps, gt.timestamps, gt_max_diff)
        poses[i_img] = gt.poses[i_gt]
    h, w = read_grey(paths[0]).shape[:2]
    intr = Intrinsics(fx, fy, cx, cy, int(w), int(h), distortion=dist)
    return ImageSequence("tum", folder.name, intr, paths, timestamps, poses, CONTEXT)
