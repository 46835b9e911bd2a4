"""The paper's two-step fitness (§IV-A).

Step 1, parameters: Θ′ = g(Θ, E) with θ′_k = w_k·θ_k and w_k = Π_j f_kj(e_j), the product of the
factors that the rules in force for context E give parameter k. nFEX applies it to the parameters the
graph marks tunable, multiplies count parameters that scale with resolution by the frame's pixel count
relative to 640×480 (ORB-SLAM's author: ~1000 features at 640×480, ~6000 at 1080p), and finally
clamps each θ′_k into its range and rounds it to its datatype (ParameterSpec.clamp).

Step 2, extractor: F_metrics(α_i | Θ′_i, E) = Σ_x h_x(E)·m_x(α_i), α* = argmax_i F_metrics. Metrics
where lower is better (m3, motion) enter as 1 − m_x so that every term rewards better features; a
``prefer`` bonus adds to F. Temporal metrics are absent on a single frame and then simply not summed —
equally for every candidate.
"""
from __future__ import annotations

from collections.abc import Mapping

from ..kg.vocab import ExtractorSpec, MetricSpec, Value
from .types import Adjustment, Citation, Factor

REFERENCE_PIXELS = 640 * 480
RESOLUTION_CITATION = Citation(
    rule="https://w3id.org/nfex#resolutionScaling",
    label="feature budget scales with resolution",
    reason="count parameters are scaled by pixels / (640×480): ORB-SLAM uses ~1000 features at 640×480 and ~6000 at 1080p",
    kind="adjust",
)


def adjust_params(
    spec: ExtractorSpec,
    factors: Mapping[str, Factor],
    *,
    base: Mapping[str, Value] | None = None,
    pixels: int | None = None,
) -> tuple[dict[str, Value], list[Adjustment]]:
    """Θ′ = g(Θ, E): ``base`` (default: the graph's defaults) times the rules' factors, clamped.

    Returns the full parameter set, ready for the OpenCV constructor, and what was changed and why.
    """
    theta: dict[str, Value] = dict(base) if base is not None else spec.defaults()
    adjustments: list[Adjustment] = []
    for name, p in spec.parameters.items():
        if not p.tunable or p.datatype == "boolean":
            continue
        w, cites = 1.0, tuple[Citation, ...]()
        if name in factors:
            w, cites = factors[name].value, factors[name].citations
        if pixels and p.scales_with_resolution:
            w *= pixels / REFERENCE_PIXELS
            cites = (*cites, RESOLUTION_CITATION)
        if w == 1.0 and not cites:
            continue
        before = theta[name]
        after = p.clamp(float(before) * w)
        theta[name] = after
        if after != before or cites:
            adjustments.append(Adjustment(name, before, after, w, cites))
    return theta, adjustments


def oriented(metric: MetricSpec, value: float) -> float:
    """A metric turned so that higher is better."""
    return value if metric.higher_is_better else 1.0 - value


def f_metrics(
    metrics: Mapping[str, float],
    weights: Mapping[str, Factor],
    specs: Mapping[str, MetricSpec],
    bonus: float = 0.0,
) -> float:
    """F_metrics = Σ_x h_x(E)·m_x (+ a preference bonus), over the metrics measured on this frame."""
    total = bonus
    for name, value in metrics.items():
        if name in specs:
            total += weights.get(name, Factor(1.0)).value * oriented(specs[name], value)
    return total
