"""ParamNet: F(Θ′ | E), the paper's parameter network (§IV-B), served in NumPy.

    x  = [one-hot(E) ‖ (s − μ)/σ]                    context over the graph's values + scaled frame statistics
    h1 = ReLU(W1 x + b1),  h2 = ReLU(W2 h1 + b2)
    u  = W3 h2 + b3                                  one output per tunable parameter, in [0, 1] of its range
    θ′_k = clamp_k(from_unit_k(clip(u_k, 0, 1)))     rounded to the datatype, clamped to the graph's range

Three linear layers and two ReLUs, trained with the MSE of the paper. The weights are the torch
layout (``W`` is out×in) so that export is a copy; inference is three small matrix products
(micro-seconds, no torch import).
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ..kg.vocab import ExtractorSpec, Value
from ..rules.fitness import REFERENCE_PIXELS
from .encoding import InputVocabulary

LAYERS = ("fc1", "fc2", "fc3")


@dataclass(frozen=True)
class ParamNet:
    weights: Mapping[str, np.ndarray]  # fc{1,2,3}.weight (out×in), fc{1,2,3}.bias

    def __post_init__(self) -> None:
        # transposed, contiguous float32 copies: x @ Wᵀ is the hot path
        object.__setattr__(self, "_wt", [np.ascontiguousarray(self.weights[f"{n}.weight"].T, np.float32) for n in LAYERS])
        object.__setattr__(self, "_b", [np.asarray(self.weights[f"{n}.bias"], np.float32) for n in LAYERS])

    @property
    def n_inputs(self) -> int:
        return int(self.weights["fc1.weight"].shape[1])

    @property
    def n_outputs(self) -> int:
        return int(self.weights["fc3.weight"].shape[0])

    def forward(self, x: np.ndarray) -> np.ndarray:
        """u = W3·ReLU(W2·ReLU(W1·x + b1) + b2) + b3, for one input (n,) or a batch (N, n)."""
        wt, b = self._wt, self._b  # type: ignore[attr-defined]
        h = np.maximum(x @ wt[0] + b[0], 0.0)
        h = np.maximum(h @ wt[1] + b[1], 0.0)
        return h @ wt[2] + b[2]


def decode(
    inputs: InputVocabulary,
    u: np.ndarray,
    spec: ExtractorSpec,
    pixels: int | None = None,
    grid: Mapping[int, tuple[np.ndarray, np.ndarray]] | None = None,
) -> dict[str, tuple[Value, float]]:
    """ParamNet's outputs for one extractor → {parameter: (θ′ clamped to the graph, raw value)}.

    With ``grid`` (output index → (normalised, actual) values the sweep measured), each output is
    snapped to the nearest measured value (nearest in normalised units), so the network never proposes a value nobody measured
    (SIFT's nfeatures = 0 means "no limit": 0 and 1000 must not average to 20). Count parameters are
    learned at 640×480 and scaled by pixels / (640×480) when the frame's size is known.
    """
    out: dict[str, tuple[Value, float]] = {}
    for i, p in inputs.params_of(spec.name):
        if p.name not in spec.parameters:
            continue
        if grid is not None and i in grid:
            units, values = grid[i]
            raw = float(values[np.abs(units - float(u[i])).argmin()])
        else:
            raw = p.from_unit(float(u[i]))
        if p.resolution and pixels:
            raw *= pixels / REFERENCE_PIXELS
        out[p.name] = (spec.parameters[p.name].clamp(raw), raw)
    return out


def init_weights(sizes: tuple[int, int, int, int], seed: int = 0) -> dict[str, np.ndarray]:
    """Random weights (torch's default uniform ±1/√fan_in) for tests and benchmarks."""
    rng = np.random.default_rng(seed)
    out: dict[str, np.ndarray] = {}
    for name, (fan_in, fan_out) in zip(LAYERS, zip(sizes[:-1], sizes[1:], strict=True), strict=True):
        bound = 1.0 / np.sqrt(fan_in)
        out[f"{name}.weight"] = rng.uniform(-bound, bound, (fan_out, fan_in)).astype(np.float32)
        out[f"{name}.bias"] = rng.uniform(-bound, bound, fan_out).astype(np.float32)
    return out
