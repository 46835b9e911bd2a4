"""Trajectories: reading and writing TUM / KITTI / EuRoC files, Umeyama alignment, ATE and RPE as evo."""
from __future__ import annotations

from .align import Alignment, align, umeyama
from .ate import ErrorStats, associate, associate_and_align, ate, rpe
from .io import (
    Trajectory,
    from_sequence,
    read_trajectory,
    write_euroc,
    write_kitti,
    write_trajectory,
    write_tum,
)

__all__ = [
    "Alignment",
    "ErrorStats",
    "Trajectory",
    "align",
    "associate",
    "associate_and_align",
    "ate",
    "from_sequence",
    "read_trajectory",
    "rpe",
    "umeyama",
    "write_euroc",
    "write_kitti",
    "write_trajectory",
    "write_tum",
]
