"""Datasets: loaders for KITTI, EuRoC, TUM RGB-D and the handheld set, corruptions, a synthetic generator.

``open_sequence(path, format, sequence=None)`` is the one entry point; every loader yields a
``Sequence`` of grey frames with timestamps, intrinsics and camera-to-world ground truth.
"""
from __future__ import annotations

from pathlib import Path

from ..errors import BadInput
from .base import Frame, Intrinsics, Sequence
from .corruptions import corrupt
from .frames import ArraySequence, ImageSequence
from .synthetic import make_sequence

FORMATS = ("kitti", "euroc", "tum", "handheld")


def open_sequence(path: str | Path, format: str, sequence: str | None = None) -> Sequence:  # noqa: A002
    """Open a sequence of a dataset in ``format`` (kitti | euroc | tum | handheld).

    ``path`` is the sequence folder itself, or the dataset folder with ``sequence`` naming one
    (KITTI: ``kitti`` + ``"00"``; EuRoC: ``euroc`` + ``"V1_01_easy_micro"``; handheld: ``handheld`` +
    ``"checkerboard"``). A missing folder or file raises ``DataMissing`` naming it.
    """
    fmt = format.lower()
    if fmt == "kitti":
        from .kitti import load_kitti

        return load_kitti(path, sequence)
    if fmt == "euroc":
        from .euroc import load_euroc

        return load_euroc(path, sequence)
    if fmt == "tum":
        from .tum import load_tum

        return load_tum(path, sequence)
    if fmt == "handheld":
        from .handheld import load_handheld

        return load_handheld(path, sequence)
    raise BadInput(f"unknown dataset format {format!r}; known: {', '.join(FORMATS)}")


__all__ = [
    "FORMATS",
    "ArraySequence",
    "Frame",
    "ImageSequence",
    "Intrinsics",
    "Sequence",
    "corrupt",
    "make_sequence",
    "open_sequence",
]
