"""Monocular visual odometry on OpenCV with a per-frame choice of extractor (``pipeline``)."""
from __future__ import annotations

from ..motion import NO_CHECKS, StepChecks, pair_errors, relative_truth
from .accuracy import window_errors
from .geometry import MatchResult, RelativePose, match, relative_pose
from .pipeline import Choice, Chooser, Extractors, FrameRecord, Proposals, VOParams, VOResult, fixed, run_vo
from .reuse import Reusing

__all__ = [
    "NO_CHECKS", "Choice", "Chooser", "Extractors", "FrameRecord", "MatchResult", "Proposals", "RelativePose", "Reusing", "StepChecks", "VOParams", "VOResult",
    "fixed", "match", "pair_errors", "relative_pose", "relative_truth", "run_vo", "window_errors",
]
