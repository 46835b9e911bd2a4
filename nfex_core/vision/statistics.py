"""Frame statistics: the cheap, resolution-independent numbers that context estimation reads.

Every statistic is computed on a grey copy of the frame resized (INTER_AREA) so that its longer side is
``ANALYSIS_SIDE`` px, so a 752×480 EuRoC frame, a 1241×376 KITTI frame and the advisor's QVGA-sized scoring
image give comparable numbers. Keys are stable (ParamNet reads them as a vector): ``FRAME_KEYS`` always,
``FLOW_KEYS`` too, NaN-free — with no previous frame the flow keys are present with ``flow_valid = 0``.

| key | meaning |
|---|---|
| mean, std, p01 … p99 | intensity mean, standard deviation and percentiles (grey levels 0–255) |
| dark_fraction, saturated_fraction | share of pixels < 32 and ≥ 250 |
| gradient_rms | √mean(g_x² + g_y²), Sobel/8, grey levels per px (gradient energy) |
| gradient_rel | gradient_rms / (std + 1): structure per unit of contrast (gain-invariant) |
| laplacian_var | variance of the 3×3 Laplacian (the classical focus/blur measure, Pech-Pacheco et al. 2000) |
| detail | √laplacian_var / gradient_rms: characteristic spatial frequency (falls under any low-pass) |
| sharpness | gradient_rms at full analysis scale / 2 × gradient_rms one octave down (≈ 1 sharp, → 0 blurred) |
| anisotropy | (λ₁−λ₂)/(λ₁+λ₂) of the image-wide structure tensor (directional blur evidence) |
| blur_direction | 1 − min/max over 4 directions of ‖∂²_d I‖/‖∂_d I‖ (motion-blur evidence, ≈ 0 for isotropic) |
| highlight_fraction, highlight_blobs | area share and count per 100 k px of small round saturated blobs (glints) |
| flow_median, flow_p90 | LK optical-flow magnitude on a grid, as a fraction of the image width |
| flow_valid | share of grid points tracked forward-backward consistently (0 without a previous frame) |
"""
from __future__ import annotations

import cv2
import numpy as np
from nfex_slam.features import as_grey_u8

ANALYSIS_SIDE = 320
PERCENTILES = (1, 5, 25, 50, 75, 95, 99)
FRAME_KEYS = (
    "mean", "std", *(f"p{p:02d}" for p in PERCENTILES), "dark_fraction", "saturated_fraction",
    "gradient_rms", "gradient_rel", "laplacian_var", "detail", "sharpness", "anisotropy", "blur_direction",
    "highlight_fraction", "highlight_blobs",
)  # fmt: skip
FLOW_KEYS = ("flow_median", "flow_p90", "flow_valid")
SATURATED = 250
HIGHLIGHT_MAX_AREA = 0.004  # a specular highlight is a blob of at most 0.4 % of the frame
_LK_CRITERIA = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 20, 0.03)


def analysis_image(image: np.ndarray, side: int = ANALYSIS_SIDE) -> np.ndarray:
    """Grey uint8 copy with its longer side ``side`` px (never upscaled)."""
    grey = as_grey_u8(image)
    h, w = grey.shape
    s = side / max(h, w)
    if s >= 1.0:
        return grey
    return cv2.resize(grey, (max(1, round(w * s)), max(1, round(h * s))), interpolation=cv2.INTER_AREA)


def _gradient_rms(a: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    gx = cv2.Sobel(a, cv2.CV_32F, 1, 0, ksize=3, scale=0.125)
    gy = cv2.Sobel(a, cv2.CV_32F, 0, 1, ksize=3, scale=0.125)
    return float(np.sqrt(np.mean(gx * gx + gy * gy))), gx, gy


def _directional_detail(a: np.ndarray) -> float:
    """1 − min_d r_d / max_d r_d over directions d ∈ {0°, 45°, 90°, 135°}, r_d = ‖∂²_d I‖ / ‖∂_d I‖.

    r_d is the characteristic spatial frequency along d; a linear motion blur along d lowers r_d only,
    an isotropic low-pass (defocus, fog) lowers all four alike. So ≈ 0 for sharp or isotropically
    blurred frames, large for motion-blurred ones.
    """
    f = a.astype(np.float32)
    c = f[1:-1, 1:-1]
    r = []
    for (dy, dx), step in (((0, 1), 1.0), ((1, 1), np.sqrt(2.0)), ((1, 0), 1.0), ((1, -1), np.sqrt(2.0))):
        fwd = f[1 + dy : f.shape[0] - 1 + dy, 1 + dx : f.shape[1] - 1 + dx]
        bwd = f[1 - dy : f.shape[0] - 1 - dy, 1 - dx : f.shape[1] - 1 - dx]
        first = float(np.mean((fwd - bwd) ** 2)) / 4.0
        second = float(np.mean((fwd - 2 * c + bwd) ** 2))
        r.append(np.sqrt(second / first) / step if first > 1e-9 else 0.0)
    return 1.0 - min(r) / max(r) if max(r) > 0 else 0.0


def _highlights(a: np.ndarray) -> tuple[float, float]:
    """Specular-highlight evidence: small, compact, round saturated blobs (area share, count per 100 k px).

    A highlight is a saturated (≥ 250) 8-connected blob of at least 3 px and at most 0.4 % of the frame
    whose bounding box it fills to ≥ 60 % with an aspect ratio ≤ 2: glints on glass, metal or a wet
    road. Sky seen through foliage or a window saturates in large or ragged blobs and is left out.
    """
    sat = (a >= SATURATED).astype(np.uint8)
    if not sat.any():
        return 0.0, 0.0
    _, _, stats, _ = cv2.connectedComponentsWithStats(sat, connectivity=8)
    area = stats[1:, cv2.CC_STAT_AREA].astype(np.float64)
    w = stats[1:, cv2.CC_STAT_WIDTH].astype(np.float64)
    h = stats[1:, cv2.CC_STAT_HEIGHT].astype(np.float64)
    spec = (area >= 3) & (area <= HIGHLIGHT_MAX_AREA * a.size) & (area / (w * h) >= 0.6)
    spec &= np.maximum(w, h) <= 2 * np.minimum(w, h)
    return float(area[spec].sum()) / a.size, float(spec.sum()) * 1e5 / a.size


def _flow(prev: np.ndarray, cur: np.ndarray) -> tuple[float, float, float]:
    h, w = cur.shape
    gx, gy = np.meshgrid(np.linspace(0.08 * w, 0.92 * w, 8), np.linspace(0.1 * h, 0.9 * h, 6))
    pts = np.stack([gx.ravel(), gy.ravel()], 1).astype(np.float32).reshape(-1, 1, 2)
    lk = {"winSize": (11, 11), "maxLevel": 3, "criteria": _LK_CRITERIA}
    nxt, st, _ = cv2.calcOpticalFlowPyrLK(prev, cur, pts, None, **lk)  # type: ignore[call-overload]
    back, st2, _ = cv2.calcOpticalFlowPyrLK(cur, prev, nxt, None, **lk)  # type: ignore[call-overload]
    ok = (st.ravel() == 1) & (st2.ravel() == 1) & (np.linalg.norm((back - pts).reshape(-1, 2), axis=1) < 1.0)
    if not ok.any():
        return 0.0, 0.0, 0.0
    mag = np.linalg.norm((nxt - pts).reshape(-1, 2)[ok], axis=1) / w
    return float(np.median(mag)), float(np.percentile(mag, 90)), float(ok.mean())


def frame_statistics(image: np.ndarray, previous_image: np.ndarray | None = None, *, analysis: np.ndarray | None = None,
                     previous_analysis: np.ndarray | None = None) -> dict[str, float]:
    """The statistics of ``image`` (and of the motion from ``previous_image``), keyed as in the table above.
    ``analysis`` / ``previous_analysis``: the frames' ``analysis_image`` where the caller has them (a stream keeps
    the last frame's, so the motion is measured between two copies of the same size made the same way)."""
    a = analysis if analysis is not None else analysis_image(image)
    hist = np.bincount(a.ravel(), minlength=256).astype(np.float64)
    n = hist.sum()
    levels = np.arange(256, dtype=np.float64)
    mean = float(hist @ levels / n)
    std = float(np.sqrt(max(hist @ (levels - mean) ** 2 / n, 0.0)))
    cdf = np.cumsum(hist) / n
    out: dict[str, float] = {"mean": mean, "std": std}
    for p in PERCENTILES:
        out[f"p{p:02d}"] = float(np.searchsorted(cdf, p / 100.0))
    out["dark_fraction"] = float(cdf[31])
    out["saturated_fraction"] = float(1.0 - cdf[SATURATED - 1])
    g, gx, gy = _gradient_rms(a)
    out["gradient_rms"] = g
    out["gradient_rel"] = g / (std + 1.0)
    out["laplacian_var"] = lap = float(cv2.Laplacian(a, cv2.CV_32F, ksize=1).var())
    out["detail"] = float(np.sqrt(lap)) / g if g > 1e-6 else 0.0
    g_coarse, _, _ = _gradient_rms(cv2.pyrDown(a))
    out["sharpness"] = g / (2.0 * g_coarse) if g_coarse > 1e-6 else 0.0
    jxx, jyy, jxy = float(np.mean(gx * gx)), float(np.mean(gy * gy)), float(np.mean(gx * gy))
    tr = jxx + jyy
    out["anisotropy"] = float(np.sqrt((jxx - jyy) ** 2 + 4 * jxy * jxy) / tr) if tr > 1e-9 else 0.0
    out["blur_direction"] = _directional_detail(a)
    out["highlight_fraction"], out["highlight_blobs"] = _highlights(a)
    if previous_analysis is not None or previous_image is not None:
        b = previous_analysis if previous_analysis is not None else analysis_image(previous_image)  # type: ignore[arg-type]
        if b.shape != a.shape:
            b = cv2.resize(b, (a.shape[1], a.shape[0]), interpolation=cv2.INTER_AREA)
        out["flow_median"], out["flow_p90"], out["flow_valid"] = _flow(b, a)
    else:
        out["flow_median"], out["flow_p90"], out["flow_valid"] = 0.0, 0.0, 0.0
    return out
