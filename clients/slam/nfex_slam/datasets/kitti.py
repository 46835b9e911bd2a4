"""KITTI odometry: ``sequences/NN/{image_0/NNNNNN.png, times.txt, calib.txt}`` and ``poses/NN.txt``.

``poses/NN.txt`` holds one 3×4 row-major camera-to-world matrix of the left grey camera per frame
(already the convention of ``Sequence``); ``calib.txt``'s ``P0`` row is the left camera's 3×4
projection matrix K·[I|0], from which fx, fy, cx, cy are read. The images are rectified: no distortion.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import DataMissing, ParseError
from .base import Intrinsics
from .frames import ImageSequence, read_grey

CONTEXT = {"agent": "car", "scene": "outdoor"}


def _resolve(path: Path, sequence: str | None) -> tuple[Path, Path | None, str]:
    """(sequence folder, poses file or None, sequence id) from the KITTI root or a sequence folder."""
    if sequence is not None:
        seq = f"{int(sequence):02d}" if str(sequence).isdigit() else str(sequence)
        for folder in (path / "sequences" / seq, path / seq):
            if folder.is_dir():
                break
        else:
            raise DataMissing(f"KITTI sequence folder {path / 'sequences' / seq} does not exist")
    else:
        folder, seq = path, path.name
    for poses in (folder.parent.parent / "poses" / f"{seq}.txt", folder / "poses.txt"):
        if poses.is_file():
            return folder, poses, seq
    return folder, None, seq


def read_calib(path: Path) -> np.ndarray:
    """The P0 projection matrix (3×4) from a KITTI ``calib.txt``."""
    if not path.is_file():
        raise DataMissing(f"KITTI calibration {path} does not exist")
    for line in path.read_text().splitlines():
        if line.startswith("P0:"):
            values = line.split()[1:]
            if len(values) != 12:
                raise ParseError(f"{path}: P0 has {len(values)} numbers, expected 12")
            return np.array([float(v) for v in values]).reshape(3, 4)
    raise ParseError(f"{path}: no P0 row")


def load_kitti(path: str | Path, sequence: str | None = None) -> ImageSequence:
    """A KITTI odometry sequence: ``path`` is the KITTI root (with ``sequence``) or a sequence folder."""
    folder, poses_file, seq = _resolve(Path(path), sequence)
    times_file = folder / "times.txt"
    if not times_file.is_file():
        raise DataMissing(f"KITTI timestamps {times_file} do not exist")
    p0 = read_calib(folder / "calib.txt")
    image_dir = folder / "image_0"
    if not image_dir.is_dir():
        raise DataMissing(f"KITTI image folder {image_dir} does not exist")
    timestamps = np.loadtxt(times_file, ndmin=1)
    paths = [image_dir / f"{i:06d}.png" for i in range(timestamps.shape[0])]
    for p in paths:
        if not p.is_file():
            raise DataMissing(f"KITTI image {p} does not exist ({times_file.name} lists {len(paths)} frames)")
    poses = None
    if poses_file is not None:
        rows = np.loadtxt(poses_file, ndmin=2)
        if rows.shape != (len(paths), 12):
            raise ParseError(f"{poses_file}: {rows.shape[0]} poses of {rows.shape[1]} numbers; expected {len(paths)} × 12")
        poses = np.tile(np.eye(4), (len(paths), 1, 1))
        poses[:, :3, :4] = rows.reshape(-1, 3, 4)
    h, w = read_grey(paths[0]).shape[:2]
    intr = Intrinsics(float(p0[0, 0]), float(p0[1, 1]), float(p0[0, 2]), float(p0[1, 2]), int(w), int(h))
    return ImageSequence("kitti", seq, intr, paths, timestamps, poses, CONTEXT)
