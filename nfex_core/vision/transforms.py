"""Known condition transforms of a real frame, for measuring context estimation (issue 3).

Each transform turns a real frame into one whose condition label is known by construction, so the
estimators in ``context.py`` can be scored against it: ``dark`` (gamma + gain + sensor noise),
``bright`` (gain + offset, saturating), ``low_texture`` (Gaussian low-pass), ``motion_blur`` (a
linear blur kernel, optionally with the frame displaced from its predecessor) and ``glare``
(small saturated specular highlights). All are deterministic for a given ``seed``.

These are measurement tools, not the corruption suite of the sweeps (``nfex_slam.datasets.corruptions``).
"""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np


def darken(image: np.ndarray, gamma: float = 1.8, gain: float = 0.3, noise: float = 2.0, seed: int = 0) -> np.ndarray:
    """I′ = gain · 255 · (I/255)^γ + N(0, noise²): an under-exposed frame with sensor noise."""
    rng = np.random.default_rng(seed)
    x = gain * 255.0 * (image.astype(np.float32) / 255.0) ** gamma
    x += rng.normal(0.0, noise, image.shape).astype(np.float32)
    return np.clip(x, 0, 255).astype(np.uint8)


def brighten(image: np.ndarray, gain: float = 1.6, offset: float = 40.0) -> np.ndarray:
    """I′ = gain · I + offset, saturating at 255: an over-exposed frame."""
    return np.clip(image.astype(np.float32) * gain + offset, 0, 255).astype(np.uint8)


def low_texture(image: np.ndarray, sigma: float = 5.0) -> np.ndarray:
    """A Gaussian low-pass with standard deviation ``sigma`` px: fog, defocus, a blank scene."""
    return cv2.GaussianBlur(image, (0, 0), sigma)


def motion_blur(image: np.ndarray, length: int = 21, angle_deg: float = 0.0) -> np.ndarray:
    """Convolution with a normalised line kernel of ``length`` px at ``angle_deg``: camera motion blur."""
    k = np.zeros((length, length), np.float32)
    k[length // 2, :] = 1.0
    rot = cv2.getRotationMatrix2D((length / 2 - 0.5, length / 2 - 0.5), angle_deg, 1.0)
    kernel = np.asarray(cv2.warpAffine(k, rot, (length, length)), np.float32)
    kernel /= kernel.sum()
    return cv2.filter2D(image, -1, kernel, borderType=cv2.BORDER_REFLECT)


def translate(image: np.ndarray, dx: float, dy: float) -> np.ndarray:
    """The frame displaced by (dx, dy) px (a pure image translation, borders replicated)."""
    m = np.array([[1, 0, dx], [0, 1, dy]], np.float32)
    h, w = image.shape[:2]
    return cv2.warpAffine(image, m, (w, h), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)


def glare(image: np.ndarray, spots: int = 12, radius: float = 6.0, seed: int = 0) -> np.ndarray:
    """Adds ``spots`` small saturated Gaussian highlights (specular reflections) at random places."""
    rng = np.random.default_rng(seed)
    h, w = image.shape[:2]
    out = image.astype(np.float32)
    yy, xx = np.mgrid[0:h, 0:w]
    for _ in range(spots):
        cx, cy = rng.uniform(0.1 * w, 0.9 * w), rng.uniform(0.1 * h, 0.9 * h)
        r = radius * rng.uniform(0.7, 1.5)
        x0, x1 = int(max(0, cx - 4 * r)), int(min(w, cx + 4 * r + 1))
        y0, y1 = int(max(0, cy - 4 * r)), int(min(h, cy + 4 * r + 1))
        d2 = (xx[y0:y1, x0:x1] - cx) ** 2 + (yy[y0:y1, x0:x1] - cy) ** 2
        spot = 400.0 * np.exp(-d2 / (2 * r * r))
        out[y0:y1, x0:x1] = np.maximum(out[y0:y1, x0:x1], out[y0:y1, x0:x1] + spot)
    return np.clip(out, 0, 255).astype(np.uint8)


@dataclass(frozen=True)
class Case:
    """One labelled test of an estimator: the frame (and its predecessor) and the labels it must get."""

    name: str
    dimension: str
    expected: frozenset[str]
    image: np.ndarray
    previous: np.ndarray | None = None


def labelled_cases(image: np.ndarray, seed: int = 0) -> list[Case]:
    """The known-transform cases for one real frame (assumed well exposed, textured, still, matte).

    light: original → bright, darkened → dark, brightened → bright. texture: original → medium or high,
    low-pass → low. motion with a previous frame: shifted by (2, 1) px → slow, shifted by 6 % of the
    width and blurred along the shift (21 px) → fast; from one frame: the original → slow, blurred at a
    seed-dependent angle → fast. reflectance: original → matte, glare → reflective.
    """
    grey = image if image.ndim == 2 else cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
    w = grey.shape[1]
    angle = float((seed * 37) % 180)
    fast = motion_blur(translate(grey, 0.06 * w, 0.0), 21, 0.0)
    s = frozenset
    return [
        Case("original", "light", s({"bright"}), grey),
        Case("dark", "light", s({"dark"}), darken(grey, seed=seed)),
        Case("bright", "light", s({"bright"}), brighten(grey)),
        Case("original", "texture", s({"medium", "high"}), grey),
        Case("low_texture", "texture", s({"low"}), low_texture(grey)),
        Case("shift_2px", "motion", s({"slow"}), translate(grey, 2.0, 1.0), grey),
        Case("shift_6pct_blur", "motion", s({"fast"}), fast, grey),
        Case("original_single", "motion", s({"slow"}), grey),
        Case("motion_blur_single", "motion", s({"fast"}), motion_blur(grey, 21, angle)),
        Case("original", "reflectance", s({"matte"}), grey),
        Case("glare", "reflectance", s({"reflective"}), glare(grey, seed=seed)),
    ]
