"""Trajectories: reading and writing TUM / KITTI / EuRoC files, Umeyama alignment, ATE and RPE as evo, and the
front-end figures of a VO run (per-pair errors, pose AUC, the ATE with ground-truth step lengths: ``frontend``)."""
from __future__ import annotations

from .align import Alignment, align, umeyama
from .ate import ErrorStats, associate, associate_and_align, ate, rpe
from .frontend import frontend_ate, pose_auc
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
    "frontend_ate",
    "pose_auc",
    "read_trajectory",
    "rpe",
    "umeyama",
    "write_euroc",
    "write_kitti",
    "write_trajectory",
    "write_tum",
]
