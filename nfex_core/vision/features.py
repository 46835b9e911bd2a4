"""What every extractor returns: one typed result, whatever OpenCV class produced it.

Keypoints are kept as NumPy arrays (positions, size, angle, response, octave) so metrics and the VO
work on arrays; ``keypoints()`` rebuilds ``cv2.KeyPoint`` objects where OpenCV wants them.
Learned extractors (XFeat) fill the same arrays from their own outputs. Descriptors are an (N, D) array — uint8 for binary descriptors (matched with a Hamming norm),
float32 for real ones (L2) — and an (0, D) array when the frame yields no feature, never ``None``.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np


@dataclass(frozen=True, eq=False)
class Features:
    extractor: str
    xy: np.ndarray  # (N, 2) float32, pixel coordinates (x right, y down)
    size: np.ndarray  # (N,) float32, keypoint diameter in pixels
    angle: np.ndarray  # (N,) float32, degrees; -1 where the extractor gives none
    response: np.ndarray  # (N,) float32
    octave: np.ndarray  # (N,) int32, as OpenCV packs it
    descriptors: np.ndarray  # (N, D) uint8 (binary) or float32 (real)
    norm: int  # cv2.NORM_* for matching these descriptors
    norm_name: str  # "NORM_HAMMING" | "NORM_HAMMING2" | "NORM_L2"
    descriptor_kind: str  # "binary" | "real"
    image_shape: tuple[int, int]  # (H, W) of the image they were extracted from
    elapsed_ms: float  # wall time of detectAndCompute
    matcher: str = "ratio"  # the graph's matcher: "ratio" (Lowe's test) | "mutual-ratio" (and mutual nearest neighbours)

    def __len__(self) -> int:
        return int(self.xy.shape[0])

    @property
    def binary(self) -> bool:
        return self.descriptor_kind == "binary"

    def keypoints(self) -> list[Any]:
        """The keypoints as ``cv2.KeyPoint`` objects (for drawing or OpenCV APIs that need them)."""
        import cv2

        return [
            cv2.KeyPoint(float(x), float(y), float(s), float(a), float(r), int(o))
            for (x, y), s, a, r, o in zip(self.xy, self.size, self.angle, self.response, self.octave, strict=True)
        ]

    def subset(self, index: np.ndarray) -> Features:
        """The features at ``index`` (a boolean mask or integer indices), same metadata."""
        return Features(
            self.extractor,
            self.xy[index],
            self.size[index],
            self.angle[index],
            self.response[index],
            self.octave[index],
            self.descriptors[index],
            self.norm,
            self.norm_name,
            self.descriptor_kind,
            self.image_shape,
            self.elapsed_ms,
            self.matcher,
        )

    @classmethod
    def from_opencv(
        cls,
        extractor: str,
        keypoints: Any,
        descriptors: np.ndarray | None,
        *,
        width: int,
        norm: int,
        norm_name: str,
        descriptor_kind: str,
        image_shape: tuple[int, int],
        elapsed_ms: float,
        matcher: str = "ratio",
    ) -> Features:
        n = len(keypoints)
        dtype = np.uint8 if descriptor_kind == "binary" else np.float32
        if descriptors is None or n == 0:
            descriptors = np.zeros((0, max(width, 0)), dtype=dtype)
        return cls(
            extractor=extractor,
            xy=np.array([k.pt for k in keypoints], dtype=np.float32).reshape(n, 2),
            size=np.array([k.size for k in keypoints], dtype=np.float32),
            angle=np.array([k.angle for k in keypoints], dtype=np.float32),
            response=np.array([k.response for k in keypoints], dtype=np.float32),
            octave=np.array([k.octave for k in keypoints], dtype=np.int32),
            descriptors=np.ascontiguousarray(descriptors, dtype=dtype),
            norm=norm,
            norm_name=norm_name,
            descriptor_kind=descriptor_kind,
            image_shape=image_shape,
            elapsed_ms=elapsed_ms,
            matcher=matcher,
        )
