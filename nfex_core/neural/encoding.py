"""What the networks see and say, derived from the graph's vocabulary (§IV-B).

Inputs: the context E as a one-hot per condition dimension over the graph's values plus "unknown",
and the frame statistics standard-scaled, x̃ = (x − μ)/σ (the paper's standard scaler).
Outputs of ParamNet: every tunable, non-boolean parameter θ_k of every extractor mapped into [0, 1]
of its range [lo, hi] in the graph:

    linear:  u = (θ − lo) / (hi − lo)
    log:     u = ln(θ / lo) / ln(hi / lo)                  (lo > 0 and hi / lo ≥ 100: thresholds)
    log1p:   u = ln(1 + θ − lo) / ln(1 + hi − lo)          (integers spanning ≥ 1000: nfeatures)

so that a wide range is learned in relative, not absolute, error. Count parameters that scale with
resolution are learned at the reference 640×480 (θ·640·480/pixels) and scaled back when served,
as fitness.adjust_params does. The vocabulary is stored in each model artifact; a graph whose
vocabulary differs makes the advisor fall back to the symbolic g(Θ, E).
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from ..kg.vocab import Vocabulary
from ..rules.fitness import REFERENCE_PIXELS

UNKNOWN = "unknown"


@dataclass(frozen=True)
class ParamScale:
    """One output of ParamNet: a tunable parameter and how it maps to [0, 1]."""

    extractor: str
    name: str
    datatype: str
    lo: float
    hi: float
    scale: str  # "linear" | "log" | "log1p"
    resolution: bool = False  # scales with pixels / (640×480)

    @property
    def qualified(self) -> str:
        return f"{self.extractor}.{self.name}"

    def to_unit(self, value: float) -> float:
        v = min(max(float(value), self.lo), self.hi)
        if self.hi <= self.lo:
            return 0.0
        if self.scale == "log":
            return math.log(v / self.lo) / math.log(self.hi / self.lo)
        if self.scale == "log1p":
            return math.log1p(v - self.lo) / math.log1p(self.hi - self.lo)
        return (v - self.lo) / (self.hi - self.lo)

    def from_unit(self, u: float) -> float:
        u = min(max(float(u), 0.0), 1.0)
        if self.scale == "log":
            return self.lo * math.exp(u * math.log(self.hi / self.lo))
        if self.scale == "log1p":
            return self.lo + math.expm1(u * math.log1p(self.hi - self.lo))
        return self.lo + u * (self.hi - self.lo)


def _scale_for(lo: float, hi: float, datatype: str) -> str:
    if lo > 0 and hi / lo >= 100:
        return "log"
    if datatype == "integer" and hi - lo >= 1000:
        return "log1p"
    return "linear"


@dataclass(frozen=True)
class InputVocabulary:
    """The graph's names the networks were built on, in a fixed order."""

    dimensions: tuple[tuple[str, tuple[str, ...]], ...]
    extractors: tuple[str, ...]
    params: tuple[ParamScale, ...]
    metrics: tuple[str, ...]

    @classmethod
    def from_vocabulary(cls, vocab: Vocabulary) -> InputVocabulary:
        params: list[ParamScale] = []
        for x, spec in vocab.extractors.items():
            for name, p in spec.parameters.items():
                if not p.tunable or p.datatype == "boolean" or p.min is None or p.max is None:
                    continue
                lo, hi = float(p.min), float(p.max)
                params.append(ParamScale(x, name, p.datatype, lo, hi, _scale_for(lo, hi, p.datatype), p.scales_with_resolution))
        return cls(
            dimensions=tuple((d, tuple(s.values)) for d, s in vocab.dimensions.items()),
            extractors=tuple(vocab.extractors),
            params=tuple(params),
            metrics=tuple(vocab.metrics),
        )

    @property
    def context_size(self) -> int:
        return sum(len(values) + 1 for _, values in self.dimensions)

    def context_onehot(self, values: Mapping[str, str | None]) -> np.ndarray:
        """One block per dimension: its values then "unknown" (a missing or unlisted value)."""
        out = np.zeros(self.context_size, dtype=np.float32)
        i = 0
        for dim, names in self.dimensions:
            v = values.get(dim)
            out[i + (names.index(v) if v in names else len(names))] = 1.0
            i += len(names) + 1
        return out

    def params_of(self, extractor: str) -> list[tuple[int, ParamScale]]:
        return [(i, p) for i, p in enumerate(self.params) if p.extractor == extractor]

    def reference_params(self, extractor: str, theta: Mapping[str, Any], pixels: int | None) -> dict[int, float]:
        """θ of one extractor → {output index: value}, count parameters at the reference 640×480."""
        out: dict[int, float] = {}
        for i, p in self.params_of(extractor):
            if p.name in theta:
                v = float(theta[p.name])
                out[i] = v * REFERENCE_PIXELS / pixels if p.resolution and pixels else v
        return out

    def encode_params(self, extractor: str, theta: Mapping[str, Any], pixels: int | None) -> dict[int, float]:
        """θ of one extractor → {output index: u in [0, 1]} (ParamNet's targets)."""
        return {i: self.params[i].to_unit(v) for i, v in self.reference_params(extractor, theta, pixels).items()}

    def as_dict(self) -> dict[str, Any]:
        return {
            "dimensions": [[d, list(vs)] for d, vs in self.dimensions],
            "extractors": list(self.extractors),
            "params": [asdict(p) for p in self.params],
            "metrics": list(self.metrics),
        }

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> InputVocabulary:
        return cls(
            dimensions=tuple((str(k), tuple(vs)) for k, vs in d["dimensions"]),
            extractors=tuple(d["extractors"]),
            params=tuple(ParamScale(**p) for p in d["params"]),
            metrics=tuple(d["metrics"]),
        )

    def mismatch(self, live: InputVocabulary) -> str | None:
        """Why a model built on ``self`` cannot take inputs from ``live`` (None when it can)."""
        for what, mine, theirs in (
            ("condition dimensions/values", self.dimensions, live.dimensions),
            ("extractors", self.extractors, live.extractors),
            ("tunable parameters/ranges", self.params, live.params),
            ("metrics", self.metrics, live.metrics),
        ):
            if mine != theirs:
                a, b = set(map(str, mine)), set(map(str, theirs))
                diff = sorted(b - a)[:2] + [f"-{x}" for x in sorted(a - b)[:2]]
                return f"the graph's {what} changed since training ({', '.join(diff) or 'order'})"
        return None


@dataclass(frozen=True)
class Scaler:
    """The standard scaler of the frame statistics: x̃ = (x − μ) / σ; a missing statistic enters as 0 (= μ)."""

    keys: tuple[str, ...]
    mean: np.ndarray
    std: np.ndarray

    @classmethod
    def fit(cls, keys: tuple[str, ...], rows: np.ndarray) -> Scaler:
        if len(keys) == 0 or len(rows) == 0:
            return cls(keys, np.zeros(len(keys), np.float32), np.ones(len(keys), np.float32))
        mean = np.nanmean(rows, axis=0).astype(np.float32)
        std = np.nanstd(rows, axis=0).astype(np.float32)
        return cls(keys, np.nan_to_num(mean), np.where(std > 1e-8, std, 1.0).astype(np.float32))

    def transform(self, stats: Mapping[str, float] | None) -> np.ndarray:
        if not stats:
            return np.zeros(len(self.keys), dtype=np.float32)
        x = np.array([stats.get(k, np.nan) for k in self.keys], dtype=np.float32)
        z = (x - self.mean) / self.std
        return np.nan_to_num(z, nan=0.0).astype(np.float32)

    def as_dict(self) -> dict[str, Any]:
        return {"keys": list(self.keys), "mean": self.mean.tolist(), "std": self.std.tolist()}

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> Scaler:
        return cls(tuple(d["keys"]), np.asarray(d["mean"], np.float32), np.asarray(d["std"], np.float32))
