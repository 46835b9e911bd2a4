"""Context estimation: fill the condition dimensions E a client did not give from the frame (paper §II-B, §V-A-1).

The graph says which dimensions exist, which values they take and which are estimable
(``nfex:estimable``); this module only knows how to read four of them off a frame:

| dimension | statistic (``frame_statistics``) | rule | threshold |
|---|---|---|---|
| light | mean intensity | dark if mean < τ, else bright | τ = 42 grey levels |
| texture | detail = √var(∇²I)/‖∇I‖, gradient_rms, gradient_rel | low if detail < τ_d or gradient_rms < 2; high if gradient_rel ≥ 0.32; else medium | τ_d = 1.23 |
| motion | flow_median (previous frame), blur_direction | fast if flow_median > τ_f (of the width) or blur_direction > τ_b | τ_f = 0.025, τ_b = 0.376 |
| reflectance | highlight_blobs (small round saturated blobs per 100 k px) | reflective if > τ_r | τ_r = 35 |

Thresholds were calibrated on KITTI 00 (frames 0, 10, …, 190) and the transforms of
``vision.transforms``: each is the geometric mean of the calibration set's worst original and worst
transformed frame; they were then checked on KITTI 01, EuRoC V1_01 and the handheld sequence
(accuracy in docs/vision.md, measured by bench/bench_vision.py). The texture high/medium split has no
ground truth and is not calibrated. Confidence grows with the log-distance from the threshold:
c = 0.5 + 0.45·min(1, |ln(s/τ)| / ln 2) — a factor of two from τ gives 0.95; motion from blur alone is
scaled by 0.8, reflectance (weak evidence) is capped at 0.6.

Scene and agent are never guessed: no model for them has been trained and measured. Dimensions the
client gives are not estimated and are reported as given.
"""
from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np

from ..context import ContextEntry
from ..kg.vocabulary.vocab import Vocabulary
from .statistics import FLOW_KEYS, FRAME_KEYS, frame_statistics

__all__ = ["Context", "ContextEntry", "estimate_context", "frame_statistics", "FRAME_KEYS", "FLOW_KEYS", "THRESHOLDS"]

THRESHOLDS: dict[str, float] = {
    "light.dark_mean": 42.0,
    "texture.low_detail": 1.23,
    "texture.flat_gradient": 2.0,
    "texture.high_gradient_rel": 0.32,
    "motion.fast_flow": 0.025,
    "motion.blur_direction": 0.376,
    "motion.min_flow_valid": 0.2,
    "reflectance.blobs": 35.0,
}


@dataclass(frozen=True)
class Context:
    """The condition dimensions E of one frame, in the graph's order, with the statistics they came from."""

    estimates: tuple[ContextEntry, ...]
    statistics: Mapping[str, float]

    def entries(self) -> tuple[ContextEntry, ...]:
        return self.estimates

    def values(self) -> dict[str, str | None]:
        return {e.dimension: e.value for e in self.estimates}

    def get(self, dimension: str) -> ContextEntry | None:
        return next((e for e in self.estimates if e.dimension == dimension), None)


def confidence(statistic: float, threshold: float, cap: float = 0.95) -> float:
    """0.5 at the threshold, rising with |ln(s/τ)| to ``cap`` at a factor of two."""
    margin = abs(math.log(max(statistic, 1e-9) / threshold))
    return round(min(cap, 0.5 + 0.45 * min(1.0, margin / math.log(2.0))), 3)


Estimator = Callable[[Mapping[str, float], bool], tuple[str, float, str]]


def _light(s: Mapping[str, float], _: bool) -> tuple[str, float, str]:
    t = THRESHOLDS["light.dark_mean"]
    value = "dark" if s["mean"] < t else "bright"
    return value, confidence(s["mean"], t), f"mean intensity {s['mean']:.1f} vs {t:g}; saturated {s['saturated_fraction']:.1%}"


def _texture(s: Mapping[str, float], _: bool) -> tuple[str, float, str]:
    t, flat, high = THRESHOLDS["texture.low_detail"], THRESHOLDS["texture.flat_gradient"], THRESHOLDS["texture.high_gradient_rel"]
    evidence = f"detail {s['detail']:.2f} vs {t:g}; gradient rms {s['gradient_rms']:.1f}, rel {s['gradient_rel']:.3f}"
    if s["gradient_rms"] < flat:
        return "low", confidence(s["gradient_rms"], flat), evidence
    if s["detail"] < t:
        return "low", confidence(s["detail"], t), evidence
    if s["gradient_rel"] >= high:
        return "high", min(confidence(s["detail"], t), confidence(s["gradient_rel"], high)), evidence
    return "medium", min(confidence(s["detail"], t), confidence(s["gradient_rel"], high)), evidence


def _motion(s: Mapping[str, float], has_previous: bool) -> tuple[str, float, str]:
    tf, tb = THRESHOLDS["motion.fast_flow"], THRESHOLDS["motion.blur_direction"]
    blur = s["blur_direction"]
    blur_text = f"directional blur {blur:.3f} vs {tb:g}"
    if has_previous and s["flow_valid"] >= THRESHOLDS["motion.min_flow_valid"]:
        flow = s["flow_median"]
        text = f"median flow {flow:.2%} of width vs {tf:.1%}; {blur_text}"
        if flow > tf or blur > tb:
            return "fast", max(confidence(flow, tf) if flow > tf else 0.0, confidence(blur, tb) if blur > tb else 0.0), text
        return "slow", min(confidence(flow + 1e-4, tf), confidence(blur, tb)), text
    if has_previous:  # the previous frame was given but could not be tracked: large motion or a cut
        return "fast", 0.6, f"optical flow lost ({s['flow_valid']:.0%} of points tracked); {blur_text}"
    value = "fast" if blur > tb else "slow"
    return value, round(0.8 * confidence(blur, tb), 3), f"no previous frame; {blur_text}"


def _reflectance(s: Mapping[str, float], _: bool) -> tuple[str, float, str]:
    t = THRESHOLDS["reflectance.blobs"]
    value = "reflective" if s["highlight_blobs"] > t else "matte"
    c = confidence(s["highlight_blobs"] + 1.0, t, cap=0.6)
    return value, c, f"{s['highlight_blobs']:.0f} specular blobs per 100k px vs {t:g}"


ESTIMATORS: dict[str, Estimator] = {"light": _light, "texture": _texture, "motion": _motion, "reflectance": _reflectance}


def estimate_context(
    vocab: Vocabulary,
    given: Mapping[str, str | None],
    image: np.ndarray,
    previous_image: np.ndarray | None = None,
    *,
    stats: Mapping[str, float] | None = None,
) -> Context:
    """The context of ``image``: ``given`` dimensions as given, estimable ones estimated, the rest unknown.

    A dimension is estimated only when the graph marks it estimable, an estimator for it exists and the
    estimated value is one the graph knows for that dimension. ``stats``: ``frame_statistics(image,
    previous_image)`` when the caller already has them (the advisor computes them once per request).
    """
    if stats is None:
        stats = frame_statistics(image, previous_image)
    out: list[ContextEntry] = []
    for name, dim in vocab.dimensions.items():
        value = given.get(name)
        if value is not None:
            out.append(ContextEntry(name, str(value), "given", 1.0))
            continue
        estimator = ESTIMATORS.get(name)
        if not dim.estimable or estimator is None:
            out.append(ContextEntry(name, None, "unknown"))
            continue
        label, conf, evidence = estimator(stats, previous_image is not None)
        if label not in dim.values:
            out.append(ContextEntry(name, None, "unknown", evidence=f"estimated {label!r}, not a value of {name} in the graph"))
            continue
        out.append(ContextEntry(name, label, "estimated", conf, evidence))
    return Context(tuple(out), stats)
