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
of them spread over square cells (``nfex_slam.features.spread_over_grid``), then computes descriptors for those only —
ORB-SLAM's idea, available to any extractor as data (ORB_GRID).

Parameter sets are validated against the graph (an out-of-range or unknown parameter raises
ParameterError / UnknownName naming it and its allowed range). OpenCV detector objects are cached per
thread and per parameter set: they are cheap to build but not safe to share between threads. A learned
backend loads its model once per process, on its first extraction.
"""
from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import cv2
import numpy as np
from nfex_slam.features import Features, as_grey_u8, detector, extract

from ..config import Settings
from ..errors import BadInput, UnknownName
from ..kg.vocabulary.vocab import ExtractorSpec, Value, Vocabulary
from .backends import backend
from .work import Work


class ExtractorRegistry:
    """Extractors by name, as the graph describes them; each runs on its backend (vision.backends)."""

    def __init__(self, specs: Mapping[str, ExtractorSpec], settings: Settings | None = None) -> None:
        self.specs = dict(specs)
        self.work = Work()
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
        return detector(spec.recipe(spec.resolve(params)))

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
        self.work.add(int(image.shape[0]) * int(image.shape[1]))
        return fn(spec, as_grey_u8(image), full, mask, self.settings)


def _opencv_spec(spec: ExtractorSpec) -> ExtractorSpec:
    if spec.backend != "opencv" or not spec.constructor:
        raise BadInput(f"{spec.name} runs on the {spec.backend!r} backend, not an OpenCV constructor")
    return spec


def extract_opencv(spec: ExtractorSpec, grey: np.ndarray, full: Mapping[str, Value], mask: np.ndarray | None,
                   settings: Settings | None = None) -> Features:
    """The ``opencv`` backend: the configuration's recipe run by the SLAM front end (nfex_slam.features.extract),
    so a client that runs a Selection's ``opencv`` finds exactly these features."""
    return extract(spec.name, _opencv_spec(spec).recipe(full), grey, mask)
