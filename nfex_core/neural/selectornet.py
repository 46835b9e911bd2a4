"""SelectorNet: α* from the frame and the numbers (§IV-B's hybrid network), served in NumPy.

    image: grey frame resized to 48×160 (H×W), scaled to [0, 1]
    c1 = ReLU(conv3×3/2(image; 1→8)),  c2 = ReLU(conv3×3/2(c1; 8→16)),  g = mean over pixels of c2
    numeric: one-hot(E) ‖ scaled frame statistics ‖ image bit ‖ m_x(α_i) for every extractor ‖ metric bits
    z = [g ‖ numeric],  h1 = ReLU(W1 z + b1),  h2 = ReLU(W2 h1 + b2),  logits = W3 h2 + b3
    P(α_i) = softmax over C(E) only: a pruned extractor gets probability 0 and can never be α*.

Trained with cross-entropy on the window's best extractor. A missing image or missing metrics enter
as zeros with their bit at 0 (the network is trained with such gaps). The convolution is im2col on a
channels-last array via NumPy stride tricks; the weights are torch's layout.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

IMAGE_HW = (48, 160)
CONVS = ("conv1", "conv2")
FCS = ("fc1", "fc2", "fc3")


def prepare_image(grey: np.ndarray, hw: tuple[int, int] = IMAGE_HW) -> np.ndarray:
    """A grey uint8 frame → H×W float32 in [0, 1] (area interpolation)."""
    import cv2

    small = cv2.resize(grey, (hw[1], hw[0]), interpolation=cv2.INTER_AREA)
    return small.astype(np.float32) / 255.0


def conv_matrix(weight: np.ndarray) -> np.ndarray:
    """torch's Cout×Cin×kh×kw kernel as a contiguous (Cin·kh·kw)×Cout matrix (a strided one is ~50× slower in BLAS)."""
    return np.ascontiguousarray(weight.reshape(weight.shape[0], -1).T, np.float32)


SINGLE_THREAD_MNK = 1 << 17  # OpenBLAS goes multi-threaded above m·n·k = 262,144


def matmul_single(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a @ b in row blocks small enough that BLAS stays on one thread: on a busy host a threaded
    product of this size stalls (measured: median 9 µs, 90th percentile 32 ms on 2 shared cores)."""
    rows = max(1, SINGLE_THREAD_MNK // max(1, b.shape[0] * b.shape[1]))
    if a.shape[0] <= rows:
        return a @ b
    out = np.empty((a.shape[0], b.shape[1]), np.result_type(a, b))
    for i in range(0, a.shape[0], rows):
        np.matmul(a[i : i + rows], b, out=out[i : i + rows])
    return out


def conv2d_hwc(
    x: np.ndarray, weight: np.ndarray, bias: np.ndarray, stride: int = 2, pad: int = 1, matrix: np.ndarray | None = None
) -> np.ndarray:
    """Cross-correlation as torch's Conv2d on an H×W×C array: im2col by strides, then one matrix product."""
    cout, cin, kh, kw = weight.shape
    xp = np.zeros((x.shape[0] + 2 * pad, x.shape[1] + 2 * pad, cin), np.float32)
    xp[pad : pad + x.shape[0], pad : pad + x.shape[1]] = x
    win = sliding_window_view(xp, (kh, kw), axis=(0, 1))[::stride, ::stride]  # Ho×Wo×C×kh×kw
    ho, wo = win.shape[:2]
    cols = win.reshape(ho * wo, cin * kh * kw)
    m = conv_matrix(weight) if matrix is None else matrix
    return (matmul_single(cols, m) + bias).reshape(ho, wo, cout)


@dataclass(frozen=True)
class SelectorNet:
    weights: Mapping[str, np.ndarray]

    def __post_init__(self) -> None:
        object.__setattr__(self, "_w", {k: np.ascontiguousarray(v, np.float32) for k, v in self.weights.items()})
        object.__setattr__(self, "_conv", {n: conv_matrix(self.weights[f"{n}.weight"]) for n in CONVS})
        object.__setattr__(self, "_fct", [np.ascontiguousarray(self.weights[f"{n}.weight"].T, np.float32) for n in FCS])
        object.__setattr__(self, "_blank", {})  # image shape → g of the all-zero image (``embed``)

    @property
    def n_numeric(self) -> int:
        return int(self.weights["fc1.weight"].shape[1] - self.weights["conv2.weight"].shape[0])

    @property
    def n_outputs(self) -> int:
        return int(self.weights["fc3.weight"].shape[0])

    def embed(self, image: np.ndarray) -> np.ndarray:
        """The CNN branch: H×W image in [0, 1] → the pooled feature vector g. A request without a frame
        sends the all-zero image: its g is computed once per network and shape (0.2 ms a request otherwise)."""
        if not image.any():
            cache = self._blank  # type: ignore[attr-defined]
            g = cache.get(image.shape)
            if g is None:
                g = cache[image.shape] = self._embed(image)
            return g
        return self._embed(image)

    def _embed(self, image: np.ndarray) -> np.ndarray:
        w = self._w  # type: ignore[attr-defined]
        h = image[:, :, None].astype(np.float32)
        for n in CONVS:
            h = np.maximum(conv2d_hwc(h, w[f"{n}.weight"], w[f"{n}.bias"], matrix=self._conv[n]), 0.0)  # type: ignore[attr-defined]
        return h.mean(axis=(0, 1))

    def logits(self, image: np.ndarray, numeric: np.ndarray, embedded: np.ndarray | None = None) -> np.ndarray:
        """The logits; ``embedded``: ``embed(image)`` when the caller already has it."""
        w, fct = self._w, self._fct  # type: ignore[attr-defined]
        z = np.concatenate([self.embed(image) if embedded is None else embedded, numeric.astype(np.float32)])
        z = np.maximum(z @ fct[0] + w["fc1.bias"], 0.0)
        z = np.maximum(z @ fct[1] + w["fc2.bias"], 0.0)
        return z @ fct[2] + w["fc3.bias"]

    def logit_bounds(self, image: np.ndarray, low: np.ndarray, high: np.ndarray,
                     embedded: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Bounds on every logit over all numeric inputs with low ≤ numeric ≤ high, the image fixed: interval
        bound propagation (Gowal et al. 2018). Through an affine layer the box with centre c and radius r
        maps to centre W c + b and radius |W| r; ReLU is monotone, so it maps the bounds themselves. Sound
        (every input in the box gives logits inside), computed in float64 so rounding stays far below the
        margin a caller demands. ``embedded``: ``embed(image)`` when the caller already has it."""
        w, fct = self._w, self._fct  # type: ignore[attr-defined]
        g = (self.embed(image) if embedded is None else embedded).astype(np.float64)
        lo = np.concatenate([g, low.astype(np.float64)])
        hi = np.concatenate([g, high.astype(np.float64)])
        for i, n in enumerate(FCS):
            weight, bias = fct[i].astype(np.float64), w[f"{n}.bias"].astype(np.float64)
            centre, radius = (lo + hi) / 2 @ weight + bias, (hi - lo) / 2 @ np.abs(weight)
            lo, hi = centre - radius, centre + radius
            if n != FCS[-1]:
                lo, hi = np.maximum(lo, 0.0), np.maximum(hi, 0.0)
        return lo, hi

    def forward(self, images: np.ndarray, numeric: np.ndarray) -> np.ndarray:
        """Batch logits: images (N, H, W), numeric (N, n) → (N, extractors)."""
        return np.stack([self.logits(im, nu) for im, nu in zip(images, numeric, strict=True)])


def masked_probabilities(logits: np.ndarray, names: Sequence[str], allowed: Sequence[str]) -> dict[str, float]:
    """Softmax over the allowed extractors only; the others are absent (probability 0)."""
    idx = [i for i, n in enumerate(names) if n in set(allowed)]
    if not idx:
        return {}
    z = logits[idx] - logits[idx].max()
    e = np.exp(z)
    p = e / e.sum()
    return {names[i]: float(pi) for i, pi in zip(idx, p, strict=True)}


def init_weights(n_numeric: int, n_outputs: int, channels: tuple[int, int] = (8, 16), hidden: tuple[int, int] = (64, 32), seed: int = 0) -> dict[str, np.ndarray]:
    """Random weights (uniform ±1/√fan_in, as torch's default) for tests and benchmarks."""
    rng = np.random.default_rng(seed)
    out: dict[str, np.ndarray] = {}

    def layer(name: str, shape: tuple[int, ...], fan_in: int) -> None:
        b = 1.0 / np.sqrt(fan_in)
        out[f"{name}.weight"] = rng.uniform(-b, b, shape).astype(np.float32)
        out[f"{name}.bias"] = rng.uniform(-b, b, shape[0]).astype(np.float32)

    layer("conv1", (channels[0], 1, 3, 3), 9)
    layer("conv2", (channels[1], channels[0], 3, 3), channels[0] * 9)
    sizes = (channels[1] + n_numeric, *hidden, n_outputs)
    for n, (a, b) in zip(FCS, zip(sizes[:-1], sizes[1:], strict=True), strict=True):
        layer(n, (b, a), a)
    return out


def numeric_input(
    context: np.ndarray,
    stats: np.ndarray,
    has_image: bool,
    metrics: Mapping[str, Mapping[str, float]],
    extractors: Sequence[str],
    metric_names: Sequence[str],
) -> np.ndarray:
    """[one-hot(E) ‖ stats ‖ image bit ‖ m(α_1)… m(α_n) ‖ bit(α_1)… bit(α_n)]; absent metrics are zeros."""
    m = np.zeros((len(extractors), len(metric_names)), np.float32)
    bits = np.zeros(len(extractors), np.float32)
    for i, x in enumerate(extractors):
        if x in metrics and metrics[x]:
            bits[i] = 1.0
            m[i] = [metrics[x].get(k, 0.0) for k in metric_names]
    return np.concatenate([context, stats, np.array([float(has_image)], np.float32), m.ravel(), bits])


def numeric_box(
    context: np.ndarray,
    stats: np.ndarray,
    metrics: Mapping[str, Mapping[str, float]],
    unknown: Mapping[str, Sequence[str]],
    extractors: Sequence[str],
    metric_names: Sequence[str],
) -> tuple[np.ndarray, np.ndarray]:
    """The numeric inputs (``numeric_input`` with an image) when the ``unknown`` extractors' metrics are not yet
    measured: each metric it names lies in [0, 1] (vision.metrics normalises every one), the rest is absent
    (0), and its bit is 1 — the extractor will have metrics once extracted. Known ``metrics`` enter exactly."""
    low = numeric_input(context, stats, True, metrics, extractors, metric_names)
    high = low.copy()
    n, k = len(extractors), len(metric_names)
    block, bits = len(low) - n * (k + 1), len(low) - n  # where m(α_1)… and bit(α_1)… start
    for i, x in enumerate(extractors):
        if x in unknown and x not in metrics:
            low[bits + i] = high[bits + i] = 1.0
            for j, name in enumerate(metric_names):
                if name in unknown[x]:
                    high[block + i * k + j] = 1.0
    return low, high
