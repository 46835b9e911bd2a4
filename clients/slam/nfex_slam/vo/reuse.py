"""Extractions and matches that several runs over the same frames share (``nfex evaluate``'s paired runs).

Runs that differ only by the RANSAC seed see identical images, and so compute identical features and identical
ratio-test matches; several methods that run one configuration on a frame (a static method, an oracle replaying
it, the advisor choosing it) do too. ``Reusing`` wraps an ``Extractors`` and keeps each extraction, keyed by the
extractor, its parameters and the image's bytes (a BLAKE2b digest), and each match of two extractions it keeps,
so that only the first run computes them. What it returns is what the first computation returned: a reused
extraction keeps the ``elapsed_ms`` measured when it ran, and a reused match its ``elapsed_ms``, so the cost a run
reports is the computation's own. Once the kept features exceed ``max_bytes`` (descriptors and keypoint arrays) the
least recently used go, with their matches; matches are bounded by an eighth of it.
"""
from __future__ import annotations

import hashlib
import json
from collections import OrderedDict
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from ..features import Features
from .geometry import MatchResult, match

if TYPE_CHECKING:
    from .pipeline import Extractors

Key = tuple[str, str, tuple[int, ...], str, str]


class Reusing:
    """An ``Extractors`` that computes each (configuration, image) extraction and each match of two once."""

    def __init__(self, inner: Extractors, max_bytes: int = 2 << 30) -> None:
        self.inner, self.max_bytes = inner, max_bytes
        self._features: OrderedDict[Key, Features] = OrderedDict()
        self._keys: dict[int, Key] = {}  # id of a kept Features → its key
        self._matches: OrderedDict[tuple[Key, Key, float], MatchResult] = OrderedDict()
        self._bytes = self._match_bytes = 0
        self.extractions = 0  # computed, not reused
        self.matchings = 0

    def extract(self, name: str, image: np.ndarray, params: Mapping[str, Any] | None = None) -> Features:
        data = np.ascontiguousarray(image)
        key: Key = (name, json.dumps(dict(params or {}), sort_keys=True, default=str), tuple(data.shape), str(data.dtype),
                    hashlib.blake2b(data.data, digest_size=16).hexdigest())
        kept = self._features.get(key)
        if kept is not None:
            self._features.move_to_end(key)
            return kept
        feats = self.inner.extract(name, image, params)
        self.extractions += 1
        self._features[key] = feats
        self._keys[id(feats)] = key
        self._bytes += feats.nbytes
        while self._bytes > self.max_bytes and len(self._features) > 1:
            self._forget(*self._features.popitem(last=False))
        return feats

    def resolve(self, name: str, params: Mapping[str, Any] | None = None) -> dict[str, Any]:
        return self.inner.resolve(name, params)

    def match(self, a: Features, b: Features, ratio: float) -> MatchResult:
        """``geometry.match(a, b, ratio)``, computed once where both are extractions this object keeps."""
        ka, kb = self._keys.get(id(a)), self._keys.get(id(b))
        if ka is None or kb is None or self._features.get(ka) is not a or self._features.get(kb) is not b:
            return match(a, b, ratio)
        key = (ka, kb, ratio)
        kept = self._matches.get(key)
        if kept is not None:
            self._matches.move_to_end(key)
            return kept
        m = match(a, b, ratio)
        self.matchings += 1
        self._matches[key] = m
        self._match_bytes += m.query.nbytes + m.train.nbytes
        while self._match_bytes > self.max_bytes // 8 and len(self._matches) > 1:
            _, old = self._matches.popitem(last=False)
            self._match_bytes -= old.query.nbytes + old.train.nbytes
        return m

    def _forget(self, key: Key, feats: Features) -> None:
        self._keys.pop(id(feats), None)
        self._bytes -= feats.nbytes
        for mk in [mk for mk in self._matches if key in (mk[0], mk[1])]:
            old = self._matches.pop(mk)
            self._match_bytes -= old.query.nbytes + old.train.nbytes
