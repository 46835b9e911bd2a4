"""The extractor registry, built from the knowledge graph alone (DESIGN.md, "Knowledge graph").

An extractor individual names its backend (``nfex:backend``, vision/backends.py: ``opencv`` unless it
says otherwise, or a learned model such as ``xfeat``), its matcher and its Parameters. An OpenCV
extractor names its OpenCV constructor (``nfex:opencvConstructor``, a dotted path
under ``cv2`` such as ``ORB_create`` or ``xfeatures2d.AKAZE_create``), its matching norm and its
Parameters, each with the OpenCV keyword name, datatype, default and range. The registry turns that
into a callable extractor: nothing here is specific to ORB, SIFT, AKAZE or BRISK, so adding an
extractor is a Turtle file, not code.

    >>> reg = ExtractorRegistry.from_vocabulary(kg.vocabulary())       # doctest: +SKIP
    >>> feats = reg.extract("ORB", image, {"nfeatures": 1000})          # doctest: +SKIP

A parameter with an ``nfex:gridRole`` (ontology/grid.ttl) is not a constructor argument: when an
extractor declares a grid cell size, the registry detects ``oversample`` × NF keypoints and keeps NF
of them spread over square cells (``spread_over_grid``), then computes descriptors for those only —
ORB-SLAM's idea, available to any extractor as data (ORB_GRID).

Parameter sets are validated against the graph (an out-of-range or unknown parameter raises
ParameterError / UnknownName naming it and its allowed range). OpenCV detector objects are cached per
thread and per parameter set: they are cheap to build but not safe to share between threads. A learned
backend loads its model once per process, on its first extraction.
"""
from __future__ import annotations

import threading
import time
from collections import OrderedDict
from collections.abc import Callable, Mapping
from typing import Any

import cv2
import numpy as np

from ..config import Settings
from ..errors import BadInput, UnknownName
from ..kg.vocab import ExtractorSpec, Value, Vocabulary
from .backends import backend
from .features import Features

CACHE_SIZE = 64


def resolve_constructor(path: str) -> Callable[..., Any]:
    """``cv2.<path>`` for a dotted path; a clear error when this OpenCV build lacks it."""
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
    if image.ndim == 3:
        code = cv2.COLOR_BGRA2GRAY if image.shape[2] == 4 else cv2.COLOR_BGR2GRAY
        image = cv2.cvtColor(image, code)
    elif image.ndim != 2:
        raise BadInput(f"an image must be H×W or H×W×C, got shape {image.shape}")
    if image.dtype != np.uint8:
        image = np.clip(image, 0, 255).astype(np.uint8)
    return image


class ExtractorRegistry:
    """Extractors by name, as the graph describes them; each runs on its backend (vision.backends)."""

    def __init__(self, specs: Mapping[str, ExtractorSpec], settings: Settings | None = None) -> None:
        self.specs = dict(specs)
        self.settings = settings or Settings.from_env()  # a learned backend's runtime, threads, weights, cache
        self._extract_fns: dict[str, Callable[..., Features]] = {}

    @classmethod
    def from_vocabulary(cls, vocab: Vocabulary, settings: Settings | None = None) -> ExtractorRegistry:
        return cls(vocab.extractors, settings)

    @property
    def names(self) -> list[str]:
        return sorted(self.specs)

    def spec(self, name: str) -> ExtractorSpec:
        try:
            return self.specs[name]
        except KeyError:
            raise UnknownName("extractor", name, self.specs) from None

    def resolve(self, name: str, params: Mapping[str, Any] | None = None) -> dict[str, Value]:
        """The full parameter set: the graph's defaults overridden by ``params``, each validated."""
        return self.spec(name).resolve(params)

    def constructor_args(self, name: str, params: Mapping[str, Any] | None = None) -> dict[str, Value]:
        """The validated parameters the OpenCV constructor takes: grid settings and oversampling applied."""
        spec = _opencv_spec(self.spec(name))
        return spec.constructor_args(spec.resolve(params))

    def create(self, name: str, params: Mapping[str, Any] | None = None) -> Any:
        """A (thread-local, cached) OpenCV detector for ``name`` with ``params`` (OpenCV backends only)."""
        spec = _opencv_spec(self.spec(name))
        return _detector(spec, spec.constructor_args(spec.resolve(params)))

    def descriptor_size(self, name: str, params: Mapping[str, Any] | None = None) -> int:
        """Descriptor length: the graph's ``nfex:descriptorSize``, else what the OpenCV detector reports."""
        spec = self.spec(name)
        if spec.descriptor_size is not None:
            return spec.descriptor_size
        return int(self.create(name, params).descriptorSize())

    def norm(self, name: str, params: Mapping[str, Any] | None = None) -> tuple[int, str]:
        """The cv2.NORM_* constant (and its name) for matching this configuration's descriptors."""
        norm_name = self.spec(name).norm_for(self.resolve(name, params))
        return int(getattr(cv2, norm_name)), norm_name

    def extract(
        self, name: str, image: np.ndarray, params: Mapping[str, Any] | None = None, mask: np.ndarray | None = None
    ) -> Features:
        """Detect keypoints and compute descriptors on ``image`` (grey or colour) with the extractor's backend;
        a backend that cannot run here raises ModelUnavailable saying what to install or set."""
        spec = self.spec(name)
        full = spec.resolve(params)  # once per frame: the backend, its norm and the grid all read it
        fn = self._extract_fns.get(spec.backend)
        if fn is None:
            entry = backend(spec.backend)
            entry.availability(self.settings).require()
            fn = self._extract_fns[spec.backend] = entry.extract_function()
        return fn(spec, as_grey_u8(image), full, mask, self.settings)


def _opencv_spec(spec: ExtractorSpec) -> ExtractorSpec:
    if spec.backend != "opencv" or not spec.constructor:
        raise BadInput(f"{spec.name} runs on the {spec.backend!r} backend, not an OpenCV constructor")
    return spec


_LOCAL = threading.local()


def _detector(spec: ExtractorSpec, args: dict[str, Value]) -> Any:
    """OpenCV detectors are cheap to build but not safe to share between threads: cached per thread."""
    key = (spec.name, spec.constructor, tuple(sorted(args.items())))
    cache: OrderedDict[tuple[Any, ...], Any] | None = getattr(_LOCAL, "cache", None)
    if cache is None:
        cache = _LOCAL.cache = OrderedDict()
    detector = cache.get(key)
    if detector is None:
        detector = resolve_constructor(spec.constructor)(**args)
        cache[key] = detector
        if len(cache) > CACHE_SIZE:
            cache.popitem(last=False)
    else:
        cache.move_to_end(key)
    return detector


def extract_opencv(spec: ExtractorSpec, grey: np.ndarray, full: Mapping[str, Value], mask: np.ndarray | None,
                   settings: Settings | None = None) -> Features:
    """The ``opencv`` backend: ``detectAndCompute`` (or detect, spread over the grid, compute)."""
    detector = _detector(spec, spec.constructor_args(full))
    norm_name = spec.norm_for(full)
    norm = int(getattr(cv2, norm_name))
    grid = spec.grid(full)
    t0 = time.perf_counter()
    if grid is None:
        keypoints, descriptors = detector.detectAndCompute(grey, mask)
    else:
        nf = spec.nf_parameter()
        keep = int(full[nf]) if nf is not None else 0
        keypoints = spread_over_grid(detector.detect(grey, mask), grid[0], keep)
        keypoints, descriptors = detector.compute(grey, keypoints)
    elapsed = (time.perf_counter() - t0) * 1000
    try:
        width = int(detector.descriptorSize())
    except cv2.error:
        width = 0
    return Features.from_opencv(
        spec.name,
        keypoints,
        descriptors,
        width=width,
        norm=norm,
        norm_name=norm_name,
        descriptor_kind=spec.descriptor_kind,
        image_shape=(int(grey.shape[0]), int(grey.shape[1])),
        elapsed_ms=elapsed,
        matcher=spec.matcher,
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
