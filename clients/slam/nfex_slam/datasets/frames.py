"""Concrete ``Sequence`` types: frames read lazily from image files, and frames held in memory.

Both support ``seq[i]`` (a ``Frame``; negative indices count from the end) and ``seq[a:b]`` (a
sequence over those frames, e.g. a sweep window), so loaders, corruptions and the synthetic
generator all hand the rest of nFEX one type. A frame keeps its index in the full sequence when it
is reached through a slice (``seq[10:20][0].index == 10``), so windows report dataset frame numbers
and seeded corruptions give a frame the same noise however the sequence was sliced.
"""
from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

from ..errors import DataMissing
from .base import Frame, Intrinsics, Sequence


def read_grey(path: Path) -> np.ndarray:
    """An image file as uint8 grey (colour files are converted); a missing or unreadable file is DataMissing."""
    import cv2

    image = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
    if image is None:
        raise DataMissing(f"image {path} is missing or not readable")
    return image


class _Indexed(Sequence):
    """Shared indexing: ``_frame(i)`` for a valid index, slices by ``_take(indices)``."""

    _n: int
    _ids: list[int]
    _timestamps: np.ndarray
    _poses: np.ndarray | None

    def __len__(self) -> int:
        return self._n

    def __getitem__(self, i):
        if isinstance(i, slice):
            return self._take(list(range(*i.indices(self._n))))
        idx = int(i)
        if idx < 0:
            idx += self._n
        if not 0 <= idx < self._n:
            raise IndexError(f"frame {i} out of range for {self.key} ({self._n} frames)")
        return self._frame(idx)

    @property
    def timestamps(self) -> np.ndarray:
        return self._timestamps.copy()

    @property
    def poses(self) -> np.ndarray | None:
        """(N, 4, 4) camera-to-world; NaN rows where a frame has no ground truth; None when none has."""
        if self._poses is None or np.all(np.isnan(self._poses)):
            return None
        return self._poses.copy()

    def _pose(self, i: int) -> np.ndarray | None:
        """Frame ``i``'s pose, or None where it has no ground truth."""
        if self._poses is None or np.isnan(self._poses[i]).any():
            return None
        return self._poses[i].copy()

    def _frame(self, i: int) -> Frame:
        raise NotImplementedError

    def _take(self, ids: list[int]) -> Sequence:
        raise NotImplementedError


class ImageSequence(_Indexed):
    """Frames whose images are files, read on access; ``poses`` rows of NaN mark frames without ground truth."""

    def __init__(
        self,
        dataset: str,
        name: str,
        intrinsics: Intrinsics,
        paths: list[Path],
        timestamps: np.ndarray,
        poses: np.ndarray | None,
        context: dict[str, str] | None = None,
        loader: Callable[[Path], np.ndarray] = read_grey,
        frame_ids: list[int] | None = None,
    ) -> None:
        self.dataset = dataset
        self.name = name
        self.intrinsics = intrinsics
        self.context = dict(context or {})
        self._paths = list(paths)
        self._timestamps = np.asarray(timestamps, dtype=float)
        self._poses = None if poses is None else np.asarray(poses, dtype=float)
        self._loader = loader
        self._n = len(self._paths)
        self._ids = list(range(self._n)) if frame_ids is None else list(frame_ids)
        if self._timestamps.shape != (self._n,):
            raise ValueError(f"{self._n} images but {self._timestamps.shape[0]} timestamps")
        if self._poses is not None and self._poses.shape != (self._n, 4, 4):
            raise ValueError(f"{self._n} images but poses of shape {self._poses.shape}")

    @property
    def paths(self) -> list[Path]:
        return list(self._paths)

    def _frame(self, i: int) -> Frame:
        return Frame(self._ids[i], float(self._timestamps[i]), self._loader(self._paths[i]), self._pose(i), dict(self.context))

    def _take(self, ids: list[int]) -> Sequence:
        return ImageSequence(
            self.dataset,
            self.name,
            self.intrinsics,
            [self._paths[i] for i in ids],
            self._timestamps[ids],
            None if self._poses is None else self._poses[ids],
            self.context,
            self._loader,
            [self._ids[i] for i in ids],
        )


class ArraySequence(_Indexed):
    """Frames held in memory (synthetic sequences, tests); ``frame_context`` adds per-frame labels."""

    def __init__(
        self,
        dataset: str,
        name: str,
        intrinsics: Intrinsics,
        images: list[np.ndarray],
        timestamps: np.ndarray,
        poses: np.ndarray | None,
        context: dict[str, str] | None = None,
        frame_context: list[dict[str, str]] | None = None,
        frame_ids: list[int] | None = None,
    ) -> None:
        self.dataset = dataset
        self.name = name
        self.intrinsics = intrinsics
        self.context = dict(context or {})
        self._images = list(images)
        self._n = len(self._images)
        self._ids = list(range(self._n)) if frame_ids is None else list(frame_ids)
        self._timestamps = np.asarray(timestamps, dtype=float)
        self._poses = None if poses is None else np.asarray(poses, dtype=float)
        self._frame_context = frame_context or [{} for _ in range(self._n)]
        if self._timestamps.shape != (self._n,) or len(self._frame_context) != self._n:
            raise ValueError("images, timestamps and frame contexts differ in length")

    def _frame(self, i: int) -> Frame:
        ctx = dict(self.context) | self._frame_context[i]
        return Frame(self._ids[i], float(self._timestamps[i]), self._images[i], self._pose(i), ctx)

    def _take(self, ids: list[int]) -> Sequence:
        return ArraySequence(
            self.dataset,
            self.name,
            self.intrinsics,
            [self._images[i] for i in ids],
            self._timestamps[ids],
            None if self._poses is None else self._poses[ids],
            self.context,
            [self._frame_context[i] for i in ids],
            [self._ids[i] for i in ids],
        )
