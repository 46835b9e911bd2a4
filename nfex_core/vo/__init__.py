"""Monocular visual odometry on OpenCV with a per-frame choice of extractor (``pipeline``)."""
from __future__ import annotations

from .geometry import MatchResult, RelativePose, match, relative_pose
from .pipeline import Choice, Chooser, FrameRecord, VOParams, VOResult, fixed, run_vo

__all__ = [
    "Choice", "Chooser", "FrameRecord", "MatchResult", "RelativePose", "VOParams", "VOResult",
    "fixed", "match", "relative_pose", "run_vo",
]
