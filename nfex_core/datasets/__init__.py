"""Datasets: loaders for KITTI, EuRoC, TUM RGB-D and the handheld set, corruptions, a synthetic generator."""
from __future__ import annotations

from .base import Frame, Intrinsics, Sequence

__all__ = ["Frame", "Intrinsics", "Sequence"]
