"""XFeat sparse keypoints and descriptors in NumPy around the network (Potje et al., CVPR 2024, §3.2–3.3).

The steps of the authors' ``XFeat.detectAndCompute``, written for one grey frame:

1. resize the frame to sides that are multiples of 32: ⌊side·s/32⌋·32 with s = ``input_scale``
   (bilinear at s = 1 as the authors do, area averaging below); the image is in [0, 1];
2. run the network (``model.network``): dense descriptors F, keypoint logits K, reliability R;
3. keypoint heatmap: softmax over K's 65 channels, the 64 cell channels unfolded to full resolution;
4. non-maximum suppression: a pixel is a keypoint when it is the maximum of its 5×5 window and its
   heatmap value exceeds ``detection_threshold``;
5. score = heatmap (nearest) · R (bilinear) at the keypoint, sampled as ``grid_sample`` does with
   ``align_corners=False`` on a grid normalised by (W−1, H−1) — the authors' convention, kept so the
   scores match; the ``top_k`` highest scores are kept, scores ≤ 0 dropped;
6. descriptor = F/‖F‖ sampled bicubically (a = −0.75, zero padding) at the keypoint, L2-normalised
   again: 64 floats of unit length, matched with the L2 norm;
7. positions scaled back to the frame by (W/W′, H/H′).

A constant frame has no structure for the network to see (instance normalisation maps it to zeros),
so it yields no features, like OpenCV's detectors. A frame whose side is under 32 px cannot pass the
network's five stride-2 stages: FrameTooSmall names the frame and the limit. An ``input_scale`` that
would take a side below 32 px is raised to the smallest one that gives 32.
"""
from __future__ import annotations

import time
from collections.abc import Mapping

import cv2
import numpy as np
from nfex_slam.features import Features

from ...config import Settings
from ...errors import ParameterError
from ...kg.vocabulary.vocab import ExtractorSpec, Value
from .model import DESCRIPTOR_SIZE, STRIDE, XFeatNetwork, network
from .network import CELL

NMS_WINDOW = 5
BICUBIC_A = -0.75  # PyTorch's bicubic grid_sample (Keys' cubic convolution)


class FrameTooSmall(ParameterError):
    """A frame too small for a learned network; ``parameter`` is "frame"."""


def network_size(height: int, width: int, scale: float) -> tuple[int, int]:
    """(H′, W′): each side times ``scale`` rounded down to a multiple of 32, at least 32."""
    if min(height, width) < STRIDE:
        raise FrameTooSmall(
            f"the frame is {width}×{height} px; XFeat needs at least {STRIDE} px on each side "
            f"(its network halves the resolution five times)", parameter="frame")
    return (max(STRIDE, int(height * scale) // STRIDE * STRIDE), max(STRIDE, int(width * scale) // STRIDE * STRIDE))


def _grid_coords(pos: np.ndarray, height: int, width: int, th: int, tw: int) -> tuple[np.ndarray, np.ndarray]:
    """Pixel coordinates in a (th, tw) map of positions ``pos`` (x, y) on a (height, width) image, as
    ``grid_sample(align_corners=False)`` reads a grid normalised by (width − 1, height − 1)."""
    gx = 2.0 * pos[:, 0] / (width - 1) - 1.0
    gy = 2.0 * pos[:, 1] / (height - 1) - 1.0
    return ((gx + 1.0) * tw - 1.0) / 2.0, ((gy + 1.0) * th - 1.0) / 2.0


def _taps(shape: tuple[int, int], yi: np.ndarray, xi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Flat indices of the taps (clipped into the map) and 1.0 where the tap lies inside, 0.0 outside:
    grid_sample's zero padding as a weight."""
    h, w = shape
    inside = ((yi >= 0) & (yi < h) & (xi >= 0) & (xi < w)).astype(np.float32)
    return np.clip(yi, 0, h - 1) * w + np.clip(xi, 0, w - 1), inside


def _nearest(img: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    idx, inside = _taps(img.shape, np.rint(v).astype(np.int64), np.rint(u).astype(np.int64))
    return img.ravel()[idx] * inside


def _bilinear(img: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    x0, y0 = np.floor(u).astype(np.int64), np.floor(v).astype(np.int64)
    tx, ty = u - x0, v - y0
    flat = img.ravel()
    out = np.zeros(len(u))
    for dy, wy in ((0, 1 - ty), (1, ty)):
        for dx, wx in ((0, 1 - tx), (1, tx)):
            idx, inside = _taps(img.shape, y0 + dy, x0 + dx)
            out += wy * wx * inside * flat[idx]
    return out


def _cubic_weights(t: np.ndarray) -> list[np.ndarray]:
    """Keys' cubic convolution weights of the taps at −1, 0, 1, 2 for a fraction t ∈ [0, 1)."""
    a = BICUBIC_A

    def near(d: np.ndarray) -> np.ndarray:  # |d| ≤ 1
        return ((a + 2) * d - (a + 3)) * d * d + 1

    def far(d: np.ndarray) -> np.ndarray:  # 1 < |d| < 2
        return ((a * d - 5 * a) * d + 8 * a) * d - 4 * a

    return [far(t + 1), near(t), near(1 - t), far(2 - t)]


def _bicubic_unit(feats: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The channel-normalised map F/‖F‖ (C, H, W) sampled bicubically at (u, v): (N, C). Only the 16
    taps of each point are normalised, not the whole map."""
    c, h, w = feats.shape
    rows = np.ascontiguousarray(feats.reshape(c, h * w).T)  # (H·W, C): one gather per tap
    x0, y0 = np.floor(u).astype(np.int64), np.floor(v).astype(np.int64)
    wx, wy = _cubic_weights(u - x0), _cubic_weights(v - y0)
    out = np.zeros((len(u), c), np.float32)
    for j, wyj in enumerate(wy):
        for i, wxi in enumerate(wx):
            idx, inside = _taps((h, w), y0 + j - 1, x0 + i - 1)
            tap = rows[idx]
            weight = (wyj * wxi).astype(np.float32) * inside / np.maximum(np.sqrt(np.einsum("nc,nc->n", tap, tap)), 1e-12)
            out += weight[:, None] * tap
    return out


def _unit_rows(x: np.ndarray) -> np.ndarray:
    return x / np.maximum(np.linalg.norm(x, axis=1, keepdims=True), 1e-12)


def sparse_features(
    feats: np.ndarray, logits: np.ndarray, reliability: np.ndarray, top_k: int, threshold: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Steps 3–6 on the network's outputs: (keypoints (N, 2) on the network's input, scores, descriptors)."""
    h8, w8 = reliability.shape
    height, width = h8 * CELL, w8 * CELL
    z = np.exp(logits - logits.max(axis=0, keepdims=True))
    cells = z[: CELL * CELL] / z.sum(axis=0, keepdims=True)
    heat = np.ascontiguousarray(cells.reshape(CELL, CELL, h8, w8).transpose(2, 0, 3, 1).reshape(height, width))
    local_max = cv2.dilate(heat, np.ones((NMS_WINDOW, NMS_WINDOW), np.uint8))
    ys, xs = np.nonzero((heat == local_max) & (heat > threshold))
    pos = np.stack([xs, ys], axis=1).astype(np.float64)
    u, v = _grid_coords(pos, height, width, height, width)
    uc, vc = _grid_coords(pos, height, width, h8, w8)
    scores = _nearest(heat, u, v) * _bilinear(reliability, uc, vc)
    scores[(xs == 0) & (ys == 0)] = -1.0
    keep = np.argsort(-scores, kind="stable")[:top_k]
    keep = keep[scores[keep] > 0]
    descriptors = _unit_rows(_bicubic_unit(feats, uc[keep], vc[keep]))
    return pos[keep], scores[keep].astype(np.float32), descriptors.astype(np.float32)


def extract(spec: ExtractorSpec, grey: np.ndarray, full: Mapping[str, Value], mask: np.ndarray | None = None,
            settings: Settings | None = None) -> Features:
    """XFeat on a grey uint8 frame with the validated parameters ``full`` (top_k, detection_threshold,
    input_scale); ``mask`` (non-zero where features may lie) filters the keypoints as OpenCV's does.
    The backend entry point (vision.backends): the process's network, loaded on first use."""
    network_size(grey.shape[0], grey.shape[1], float(full["input_scale"]))  # a frame too small fails before any loading
    return detect(network(settings), spec, grey, full, mask)


def detect(net: XFeatNetwork, spec: ExtractorSpec, grey: np.ndarray, full: Mapping[str, Value],
           mask: np.ndarray | None = None) -> Features:
    """``extract`` with a given network (the benchmark compares runtimes with it); timed from here."""
    h, w = grey.shape
    th, tw = network_size(h, w, float(full["input_scale"]))
    t0 = time.perf_counter()
    if int(grey.max()) == int(grey.min()):
        xy: np.ndarray = np.zeros((0, 2))
        scores, desc = np.zeros(0, np.float32), np.zeros((0, DESCRIPTOR_SIZE), np.float32)
    else:
        image: np.ndarray = grey.astype(np.float32) / 255.0
        if (th, tw) != (h, w):
            interp = cv2.INTER_LINEAR if float(full["input_scale"]) >= 1.0 else cv2.INTER_AREA
            image = cv2.resize(image, (tw, th), interpolation=interp)
        xy, scores, desc = sparse_features(*net.run(image), int(full["top_k"]), float(full["detection_threshold"]))
        xy = np.multiply(xy, np.array([w / tw, h / th]), dtype=np.float64)
        if mask is not None and len(xy):
            inside = mask[np.clip(xy[:, 1].astype(int), 0, h - 1), np.clip(xy[:, 0].astype(int), 0, w - 1)] > 0
            xy, scores, desc = xy[inside], scores[inside], desc[inside]
    elapsed = (time.perf_counter() - t0) * 1000
    n = len(xy)
    norm_name = spec.norm_for(full)
    return Features(
        extractor=spec.name,
        xy=xy.astype(np.float32).reshape(n, 2),
        size=np.full(n, CELL * w / tw, np.float32),  # the detection cell, in frame pixels
        angle=np.full(n, -1.0, np.float32),
        response=scores,
        octave=np.zeros(n, np.int32),
        descriptors=np.ascontiguousarray(desc, np.float32).reshape(n, DESCRIPTOR_SIZE),
        norm=int(getattr(cv2, norm_name)),
        norm_name=norm_name,
        descriptor_kind="real",
        image_shape=(h, w),
        elapsed_ms=elapsed,
        matcher=spec.matcher,
    )
