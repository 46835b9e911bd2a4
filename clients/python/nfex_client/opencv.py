"""Build the OpenCV objects a selection names (needs opencv; imported lazily).

A selection's ``opencv`` says how: ``constructor`` (a path under cv2), ``norm``, ``args`` (the
constructor's keyword arguments) and ``grid`` — None, or ``{"cell_size", "keep"}`` when the detected
keypoints are to be spread over square cells before descriptors are computed (ORB_GRID).
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any


def extractor_from_selection(selection: Mapping[str, Any]) -> Any:
    """``cv2.<constructor>(**args)`` for a selection (``opencv.constructor`` may be dotted, e.g.
    ``xfeatures2d.AKAZE_create``), wrapped in a ``GridSpread`` when the selection asks for a grid.
    A service without ``opencv.args`` (before issue 19) gets ``params`` as the arguments."""
    import cv2

    opencv = selection["opencv"]
    target: Any = cv2
    for part in opencv["constructor"].split("."):
        target = getattr(target, part)
    detector = target(**opencv.get("args", selection["params"]))
    grid = opencv.get("grid")
    return GridSpread(detector, int(grid["cell_size"]), int(grid["keep"])) if grid else detector


class GridSpread:
    """An OpenCV detector whose keypoints are spread over square cells (``spread_keypoints``) before the
    descriptors are computed: ``detect``, ``compute`` and ``detectAndCompute`` as on a cv2.Feature2D."""

    def __init__(self, detector: Any, cell_size: int, keep: int) -> None:
        self.detector, self.cell_size, self.keep = detector, cell_size, keep

    def detect(self, image: Any, mask: Any = None) -> list[Any]:
        return spread_keypoints(self.detector.detect(image, mask), self.cell_size, self.keep)

    def compute(self, image: Any, keypoints: Sequence[Any]) -> tuple[Any, Any]:
        return self.detector.compute(image, list(keypoints))

    def detectAndCompute(self, image: Any, mask: Any = None) -> tuple[Any, Any]:  # noqa: N802 (OpenCV's name)
        return self.compute(image, self.detect(image, mask))

    def descriptorSize(self) -> int:  # noqa: N802
        return int(self.detector.descriptorSize())


def spread_keypoints(keypoints: Sequence[Any], cell: int, keep: int) -> list[Any]:
    """Keep ``keep`` keypoints (all when 0), round-robin over square cells of ``cell`` px by rank: every
    cell's strongest keypoint (by response) before any cell's second; within a rank the stronger first;
    ties in input order. The same order as the service's registry (nfex_core.vision.registry)."""
    kps = list(keypoints)
    if not kps:
        return kps
    cx = [math.floor(k.pt[0] / cell) for k in kps]
    width = max(cx) + 1
    cell_id = [math.floor(k.pt[1] / cell) * width + x for k, x in zip(kps, cx, strict=True)]
    by_cell = sorted(range(len(kps)), key=lambda i: (cell_id[i], -kps[i].response))
    rank = [0] * len(kps)
    for pos, i in enumerate(by_cell):
        if pos and cell_id[by_cell[pos - 1]] == cell_id[i]:
            rank[i] = rank[by_cell[pos - 1]] + 1
    chosen = sorted(range(len(kps)), key=lambda i: (rank[i], -kps[i].response))
    return [kps[i] for i in (chosen[:keep] if keep > 0 else chosen)]


def matcher_from_selection(selection: Mapping[str, Any], cross_check: bool = True) -> Any:
    """A brute-force matcher with the norm the selection's descriptor needs."""
    import cv2

    return cv2.BFMatcher(getattr(cv2, selection["opencv"]["norm"]), crossCheck=cross_check)


def encode_png(image: Any) -> bytes:
    import cv2

    ok, buf = cv2.imencode(".png", image)
    if not ok:
        raise ValueError("cv2.imencode could not encode the frame as PNG")
    return bytes(buf)
