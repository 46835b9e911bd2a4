"""The one type every dataset loader yields: a sequence of grey frames with timestamps, intrinsics
and (where the dataset has them) ground-truth camera poses.

Poses are camera-to-world 4×4 matrices of the frame's camera (not the body or IMU), in metres, one
per frame; ``None`` for a frame without ground truth. Loaders convert from their dataset's convention
(KITTI 3×4 rows, EuRoC body poses + T_BS, TUM quaternions, the handheld set's world-to-camera
rotation vectors) so that everything downstream — VO, ATE, sweeps, corruptions — sees one convention.
"""
from __future__ import annotations

from collections.abc import Iterator
from collections.abc import Sequence as Seq
from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class Intrinsics:
    """Pinhole intrinsics and (optional) distortion of the frames as loaded."""

    fx: float
    fy: float
    cx: float
    cy: float
    width: int
    height: int
    distortion: tuple[float, ...] = ()  # OpenCV order (k1, k2, p1, p2[, k3…]); () = none
    distortion_model: str = "radtan"  # "radtan" (OpenCV) or a dataset-specific model name

    @property
    def K(self) -> np.ndarray:  # noqa: N802 - the conventional name
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])


@dataclass(frozen=True)
class Frame:
    index: int
    timestamp: float  # seconds
    image: np.ndarray  # uint8, H×W, grey
    pose: np.ndarray | None = None  # 4×4 camera-to-world, metres
    context: dict[str, str] = field(default_factory=dict)  # known condition labels (e.g. from a corruption)


class Sequence(Seq[Frame]):
    """A finite, indexable sequence of frames; images are read lazily on access."""

    dataset: str  # "kitti" | "euroc" | "tum" | "handheld" | "synthetic" | …
    name: str  # e.g. "00", "V1_01_easy_micro"
    intrinsics: Intrinsics
    context: dict[str, str]  # labels known for the whole sequence (agent, scene, …)

    def __len__(self) -> int:
        raise NotImplementedError

    def __getitem__(self, i):
        raise NotImplementedError

    def __iter__(self) -> Iterator[Frame]:
        for i in range(len(self)):
            yield self[i]

    @property
    def timestamps(self) -> np.ndarray:
        raise NotImplementedError

    @property
    def poses(self) -> np.ndarray | None:
        """(N, 4, 4) camera-to-world ground truth, or None when the sequence has none."""
        raise NotImplementedError

    @property
    def key(self) -> str:
        return f"{self.dataset}/{self.name}"
