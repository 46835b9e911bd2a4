"""What every extractor returns: one typed result, whatever OpenCV class produced it; and how an OpenCV
extractor is run from its recipe (a Selection's ``opencv``: constructor, args, norm, grid, matcher).

Keypoints are kept as NumPy arrays (positions, size, angle, response, octave) so metrics and the VO
work on arrays; ``keypoints()`` rebuilds ``cv2.KeyPoint`` objects where OpenCV wants them.
Learned extractors (XFeat) fill the same arrays from their own outputs. Descriptors are an (N, D) array — uint8 for binary descriptors (matched with a Hamming norm),
float32 for real ones (L2) — and an (0, D) array when the frame yields no feature, never ``None``.
"""
from __future__ import annotations

import threading
import time
from collections import OrderedDict
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .errors import BadInput


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

    @property
    def nbytes(self) -> int:
        """The bytes its arrays hold (keypoints and descriptors)."""
        return int(sum(a.nbytes for a in (self.xy, self.size, self.angle, self.response, self.octave, self.descriptors)))

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


@dataclass(frozen=True)
class Recipe:
    """How to build and run one OpenCV extractor configuration: ``cv2.<constructor>(**args)``, its descriptors
    matched with ``norm`` (``cv2.NORM_*`` name) by ``matcher``; ``grid`` = (cell px, keypoints to keep, 0 = all)
    when detections are spread over square cells before descriptors are computed (ORB_GRID). The service
    sends it as a Selection's ``opencv`` (``from_selection``); the server's registry builds it from the graph."""

    constructor: str
    norm: str
    args: dict[str, Any] = field(default_factory=dict)
    grid: tuple[int, int] | None = None
    matcher: str = "ratio"
    descriptor_kind: str = ""  # "binary" | "real"; "" (a service before issue 19): read from the norm

    @property
    def kind(self) -> str:
        return self.descriptor_kind or ("binary" if self.norm.startswith("NORM_HAMMING") else "real")

    @classmethod
    def from_selection(cls, opencv: Mapping[str, Any]) -> Recipe:
        """From a Selection's (or a proposal's) ``opencv`` object."""
        if not opencv.get("constructor"):
            raise BadInput("this extractor runs on a learned backend, not an OpenCV constructor: it cannot be built from its recipe")
        grid = opencv.get("grid")
        return cls(str(opencv["constructor"]), str(opencv["norm"]), dict(opencv.get("args") or {}),
                   None if not grid else (int(grid["cell_size"]), int(grid["keep"])), str(opencv.get("matcher") or "ratio"),
                   str(opencv.get("descriptor_kind") or ""))


def resolve_constructor(path: str) -> Callable[..., Any]:
    """``cv2.<path>`` for a dotted path; a clear error when this OpenCV build lacks it."""
    import cv2

    obj: Any = cv2
    for part in path.split("."):
        if not hasattr(obj, part):
            raise BadInput(
                f"OpenCV {cv2.__version__} has no constructor cv2.{path} "
                "(AKAZE and BRISK need the contrib build: opencv-contrib-python-headless)"
            )
        obj = getattr(obj, part)
    if not callable(obj):
        raise BadInput(f"cv2.{path} is not callable")
    return obj


def as_grey_u8(image: np.ndarray) -> np.ndarray:
    """A uint8 single-channel view of ``image`` (BGR/BGRA converted, other dtypes clipped)."""
    import cv2

    if image.ndim == 3:
        code = cv2.COLOR_BGRA2GRAY if image.shape[2] == 4 else cv2.COLOR_BGR2GRAY
        image = cv2.cvtColor(image, code)
    elif image.ndim != 2:
        raise BadInput(f"an image must be H×W or H×W×C, got shape {image.shape}")
    if image.dtype != np.uint8:
        image = np.clip(image, 0, 255).astype(np.uint8)
    return image


CACHE_SIZE = 64
_LOCAL = threading.local()


def detector(recipe: Recipe) -> Any:
    """The OpenCV detector of a recipe. Detectors are cheap to build but not safe to share between threads:
    cached per thread (the ``CACHE_SIZE`` most recent configurations)."""
    key = (recipe.constructor, tuple(sorted(recipe.args.items())))
    cache: OrderedDict[tuple[Any, ...], Any] | None = getattr(_LOCAL, "cache", None)
    if cache is None:
        cache = _LOCAL.cache = OrderedDict()
    found = cache.get(key)
    if found is None:
        found = cache[key] = resolve_constructor(recipe.constructor)(**recipe.args)
        if len(cache) > CACHE_SIZE:
            cache.popitem(last=False)
    else:
        cache.move_to_end(key)
    return found


def extract(name: str, recipe: Recipe, image: np.ndarray, mask: np.ndarray | None = None) -> Features:
    """Run ``recipe`` on ``image`` (grey or colour): ``detectAndCompute``, or under a grid detect, spread
    (``spread_over_grid``), compute. ``elapsed_ms`` times the OpenCV calls."""
    import cv2

    grey = as_grey_u8(image)
    det = detector(recipe)
    t0 = time.perf_counter()
    if recipe.grid is None:
        keypoints, descriptors = det.detectAndCompute(grey, mask)
    else:
        keypoints = spread_over_grid(det.detect(grey, mask), recipe.grid[0], recipe.grid[1])
        keypoints, descriptors = det.compute(grey, keypoints)
    elapsed = (time.perf_counter() - t0) * 1000
    try:
        width = int(det.descriptorSize())
    except cv2.error:
        width = 0
    return Features.from_opencv(
        name, keypoints, descriptors, width=width, norm=int(getattr(cv2, recipe.norm)), norm_name=recipe.norm,
        descriptor_kind=recipe.kind, image_shape=(int(grey.shape[0]), int(grey.shape[1])),
        elapsed_ms=elapsed, matcher=recipe.matcher,
    )


def spread_over_grid(keypoints: Any, cell: int, keep: int) -> list[Any]:
    """Keep ``keep`` keypoints (all when 0) spread over square cells of ``cell`` px.

    Round-robin by rank: every cell's strongest keypoint (by response) comes before any cell's second,
    and within one rank the stronger first — so each textured cell gets its share (ORB-SLAM's grid
    quota) and the strongest cells fill the remainder. Deterministic (stable sorts).
    """
    kps = list(keypoints)
    if not kps:
        return kps
    xy = np.array([k.pt for k in kps], dtype=np.float64)
    response = np.array([k.response for k in kps], dtype=np.float64)
    cx = np.floor(xy[:, 0] / cell).astype(np.int64)
    cy = np.floor(xy[:, 1] / cell).astype(np.int64)
    cell_id = cy * (int(cx.max()) + 1) + cx
    order = np.lexsort((-response, cell_id))  # by cell, strongest first within a cell
    sorted_cells = cell_id[order]
    starts = np.r_[0, np.flatnonzero(np.diff(sorted_cells)) + 1]
    rank = np.empty(len(kps), dtype=np.int64)
    rank[order] = np.arange(len(kps)) - np.repeat(starts, np.diff(np.r_[starts, len(kps)]))
    chosen = np.lexsort((-response, rank))
    if keep > 0:
        chosen = chosen[:keep]
    return [kps[i] for i in chosen]
