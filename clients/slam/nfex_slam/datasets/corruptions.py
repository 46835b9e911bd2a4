"""Condition corruptions: deterministic, seeded transforms that turn a real sequence into one with a
known condition at a known severity s ∈ [0, 1], labelling every frame's context (issue 5, part 2).

| name          | model (I in [0, 1])                                                             | label               |
|---------------|---------------------------------------------------------------------------------|---------------------|
| dark          | photons = full_well · g · I^γ, g = 1 − 0.9√s, γ = 1 + 1.2s, full_well = 50 + 950(1 − s); Poisson(photons)/full_well + N(0, (0.01s)²) | light = dark        |
| overexposed   | min(1, (1 + 3s) · I^(1/(1 + s))) + N(0, (0.005s)²)                                  | light = bright      |
| motion_blur   | per tile of a 2×3 grid, a line kernel of length s·(30 px + ‖f‖) along the tile's image motion f, tiles blended bilinearly | motion = fast |
| low_texture   | defocus (Gaussian σ = 0.5 + 4s px), contrast × (1 − 0.8s) about the mean         | texture = low       |
| glare         | 1 + round(4s) specular blobs, radius (0.03 + 0.1s)·min(W, H), saturated cores    | reflectance = reflective |

The image motion f of a tile of frame i is the median sparse optical flow (pyramidal Lucas–Kanade
on Shi–Tomasi corners) in that tile from frame i to i+1 (i−1 → i for the last frame); where too few
corners track, it is the motion of the tile centre predicted by the ground-truth poses and
intrinsics for a scene ``FALLBACK_DEPTH_M`` metres away. Glare blobs sit at sequence-fixed positions that drift
slowly with the frame index. A frame's noise comes from ``default_rng((seed, frame.index, k))``, so
it is the same whatever order frames are read in and however the sequence was sliced (before or
after corrupting; only motion blur on the last frame of a sequence sliced *before* corrupting
differs, as its flow is then taken from the frame before). s = 0 is the identity and adds no label.
``CorruptedSequence.at(i, s)`` gives a frame at a severity of its own (a ramped schedule segment,
``datasets.schedule``): the same image as a whole sequence corrupted at s.
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..errors import ParameterError, UnknownName
from .base import Frame, Sequence

LABELS: dict[str, dict[str, str]] = {
    "dark": {"light": "dark"},
    "overexposed": {"light": "bright"},
    "motion_blur": {"motion": "fast"},
    "low_texture": {"texture": "low"},
    "glare": {"reflectance": "reflective"},
}
NAMES = tuple(LABELS)
FALLBACK_DEPTH_M = 10.0
BLUR_GRID = (2, 3)  # rows, cols of tiles with their own blur direction (forward motion is radial)


def _to_u8(x: np.ndarray) -> np.ndarray:
    return np.clip(np.rint(x * 255.0), 0, 255).astype(np.uint8)


def dark(image: np.ndarray, s: float, rng: np.random.Generator) -> np.ndarray:
    i = image.astype(np.float64) / 255.0
    gain, gamma = 1.0 - 0.9 * np.sqrt(s), 1.0 + 1.2 * s
    full_well = 50.0 + 950.0 * (1.0 - s)
    photons = rng.poisson(full_well * gain * i**gamma)
    out = photons / full_well + rng.normal(0.0, 0.01 * s, size=i.shape)
    return _to_u8(out)


def overexposed(image: np.ndarray, s: float, rng: np.random.Generator) -> np.ndarray:
    i = image.astype(np.float64) / 255.0
    out = np.minimum(1.0, (1.0 + 3.0 * s) * i ** (1.0 / (1.0 + s))) + rng.normal(0.0, 0.005 * s, size=i.shape)
    return _to_u8(out)


def low_texture(image: np.ndarray, s: float, rng: np.random.Generator) -> np.ndarray:
    import cv2

    blurred = cv2.GaussianBlur(image.astype(np.float64), (0, 0), 0.5 + 4.0 * s)
    mean = float(blurred.mean())
    return _to_u8((mean + (blurred - mean) * (1.0 - 0.8 * s)) / 255.0)


def line_kernel(length: float, angle: float) -> np.ndarray:
    """A normalised line kernel of ``length`` pixels at ``angle`` radians from the image x axis
    (points sampled densely along the segment and splatted bilinearly, so short kernels keep their direction)."""
    n = max(1, int(np.ceil(length)) | 1)  # odd side
    c = (n - 1) / 2.0
    t = np.linspace(-1.0, 1.0, 64 * n)
    x = c + t * np.cos(angle) * (length - 1) / 2.0
    y = c + t * np.sin(angle) * (length - 1) / 2.0
    x0, y0 = np.floor(x).astype(int), np.floor(y).astype(int)
    fx, fy = x - x0, y - y0
    k = np.zeros((n + 1, n + 1))
    np.add.at(k, (y0, x0), (1 - fx) * (1 - fy))
    np.add.at(k, (y0, x0 + 1), fx * (1 - fy))
    np.add.at(k, (y0 + 1, x0), (1 - fx) * fy)
    np.add.at(k, (y0 + 1, x0 + 1), fx * fy)
    k = k[:n, :n]
    return k / k.sum()


def motion_blur(image: np.ndarray, s: float, field: np.ndarray) -> np.ndarray:
    """Blur each tile of a (rows, cols) grid along its flow vector ``field[r, c]`` (pixels per frame),
    blending the tiles' results with bilinear weights between tile centres."""
    import cv2

    field = np.asarray(field, dtype=float)
    if field.ndim == 1:  # one vector for the whole image
        field = field.reshape(1, 1, 2)
    h, w = image.shape
    img = image.astype(np.float64)
    out = np.zeros_like(img)
    rows, cols = field.shape[:2]
    for r in range(rows):
        for c in range(cols):
            f = field[r, c]
            length = s * (30.0 + float(np.linalg.norm(f)))
            angle = float(np.arctan2(f[1], f[0])) if np.linalg.norm(f) > 1e-6 else 0.0
            blurred = img if length < 1.0 else cv2.filter2D(img, -1, line_kernel(length, angle), borderType=cv2.BORDER_REFLECT)
            if rows * cols == 1:
                return _to_u8(blurred / 255.0)
            one_hot = np.zeros((rows, cols))
            one_hot[r, c] = 1.0
            # bilinear interpolation of a one-hot grid: weights that sum to 1 over the tiles
            weight = cv2.resize(one_hot, (w, h), interpolation=cv2.INTER_LINEAR)
            out += weight * blurred
    return _to_u8(out / 255.0)


def glare(image: np.ndarray, s: float, blobs: np.ndarray) -> np.ndarray:
    """``blobs``: (B, 3) rows of centre x, centre y (pixels) and radius (pixels)."""
    h, w = image.shape
    yy, xx = np.mgrid[0:h, 0:w]
    light = np.zeros((h, w))
    for cx, cy, r in blobs:
        light = np.maximum(light, 1.6 * np.exp(-((xx - cx) ** 2 + (yy - cy) ** 2) / (2.0 * (r / 2.0) ** 2)))
    i = image.astype(np.float64) / 255.0
    return _to_u8(i + (1.0 - i) * np.minimum(1.0, light))


def image_motion(prev: np.ndarray, nxt: np.ndarray, grid: tuple[int, int] = (1, 1)) -> np.ndarray | None:
    """Median optical flow (pixels) from ``prev`` to ``nxt`` per tile of a (rows, cols) ``grid``,
    shape (rows, cols, 2); a tile with fewer than 5 tracks takes the global median. None with fewer
    than 8 tracks in all."""
    import cv2

    pts = cv2.goodFeaturesToTrack(prev, maxCorners=400, qualityLevel=0.01, minDistance=8)
    if pts is None or len(pts) < 8:
        return None
    moved, status, _ = cv2.calcOpticalFlowPyrLK(prev, nxt, pts, pts.copy(), winSize=(21, 21), maxLevel=3)
    ok = status.reshape(-1) == 1
    if ok.sum() < 8:
        return None
    start = pts.reshape(-1, 2)[ok]
    flow = (moved - pts).reshape(-1, 2)[ok]
    rows, cols = grid
    h, w = prev.shape[:2]
    tile_r = np.minimum((start[:, 1] * rows / h).astype(int), rows - 1)
    tile_c = np.minimum((start[:, 0] * cols / w).astype(int), cols - 1)
    field = np.tile(np.median(flow, axis=0), (rows, cols, 1))
    for r in range(rows):
        for c in range(cols):
            sel = (tile_r == r) & (tile_c == c)
            if sel.sum() >= 5:
                field[r, c] = np.median(flow[sel], axis=0)
    return field


def pose_motion(seq: Sequence, i: int, j: int, grid: tuple[int, int] = (1, 1)) -> np.ndarray:
    """Image motion (rows, cols, 2) from frame i to j of the tile centres' scene points, placed
    ``FALLBACK_DEPTH_M`` metres along their rays, as the ground-truth poses and intrinsics predict."""
    rows, cols = grid
    field = np.zeros((rows, cols, 2))
    poses = seq.poses
    if poses is None or np.isnan(poses[[i, j]]).any():
        return field
    intr = seq.intrinsics
    k_inv = np.linalg.inv(intr.K)
    t_ji = np.linalg.inv(poses[j]) @ poses[i]
    for r in range(rows):
        for c in range(cols):
            u = np.array([(c + 0.5) * intr.width / cols, (r + 0.5) * intr.height / rows, 1.0])
            ray = k_inv @ u
            x_j = t_ji @ np.append(ray / np.linalg.norm(ray) * FALLBACK_DEPTH_M, 1.0)
            if x_j[2] > 1e-6:
                field[r, c] = (intr.K @ (x_j[:3] / x_j[2]))[:2] - u[:2]
    return field


class CorruptedSequence(Sequence):
    """``base`` with corruption ``corruption`` at ``severity`` applied lazily, frame by frame."""

    def __init__(
        self, base: Sequence, corruption: str, severity: float, seed: int = 0, positions: list[int] | None = None
    ) -> None:
        self.base = base
        # a slice keeps the whole base, so motion blur still sees each frame's true neighbours
        self._pos = list(range(len(base))) if positions is None else list(positions)
        self.corruption = corruption
        self.severity = float(severity)
        self.seed = int(seed)
        self.dataset = base.dataset
        self.name = base.name
        self.intrinsics = base.intrinsics
        self.labels = dict(LABELS[corruption]) if severity > 0 else {}
        self.context = dict(base.context) | self.labels
        self._blobs: dict[float, np.ndarray] = {}  # per severity: glare's count and radius depend on it

    def __len__(self) -> int:
        return len(self._pos)

    def __getitem__(self, i):
        if isinstance(i, slice):
            return CorruptedSequence(self.base, self.corruption, self.severity, self.seed, self._pos[i])
        return self.at(int(i), self.severity)

    def at(self, i: int, severity: float) -> Frame:
        """Frame ``i`` under this corruption at ``severity`` (labelled where it is above 0)."""
        idx = self._pos[i]
        frame = self.base[idx]
        image = self._apply(idx, frame, float(severity))  # idx: position here (neighbours); frame.index: identity (seeds)
        labels = dict(LABELS[self.corruption]) if severity > 0 else {}
        return Frame(frame.index, frame.timestamp, image, frame.pose, dict(frame.context) | labels)

    @property
    def timestamps(self) -> np.ndarray:
        return self.base.timestamps[self._pos]

    @property
    def poses(self) -> np.ndarray | None:
        poses = self.base.poses
        return None if poses is None else poses[self._pos]

    def rng(self, frame_index: int) -> np.random.Generator:
        return np.random.default_rng((self.seed, frame_index, NAMES.index(self.corruption)))

    def flow_field(self, i: int, grid: tuple[int, int] | None = None) -> np.ndarray:
        """Image motion (rows, cols, 2), pixels per frame, at position ``i`` of the base sequence."""
        grid = grid or BLUR_GRID
        n = len(self.base)
        if n < 2:
            return np.zeros((*grid, 2))
        a, b = (i, i + 1) if i + 1 < n else (i - 1, i)
        f = image_motion(self.base[a].image, self.base[b].image, grid)
        return f if f is not None else pose_motion(self.base, a, b, grid)

    def flow(self, i: int) -> np.ndarray:
        """The median image motion (2,) at position ``i`` of the base sequence."""
        return self.flow_field(i, (1, 1))[0, 0]

    def blobs(self, frame_index: int, severity: float | None = None) -> np.ndarray:
        """Glare blobs of a frame: sequence-fixed centres drifting ~1 px per frame, fixed radii (per severity)."""
        w, h = self.intrinsics.width, self.intrinsics.height
        s = self.severity if severity is None else float(severity)
        b = self._blobs.get(s)
        if b is None:
            rng = np.random.default_rng((self.seed, 7919))
            count = 1 + int(round(4 * s))
            centres = rng.uniform([0.1 * w, 0.1 * h], [0.9 * w, 0.9 * h], size=(count, 2))
            drift = rng.normal(0.0, 1.0, size=(count, 2))
            radius = np.full((count, 1), (0.03 + 0.1 * s) * min(w, h))
            b = self._blobs[s] = np.hstack([centres, drift, radius])
        i = frame_index
        return np.column_stack([b[:, 0] + i * b[:, 2], b[:, 1] + i * b[:, 3], b[:, 4]])

    def _apply(self, i: int, frame: Frame, s: float) -> np.ndarray:
        if s == 0:
            return frame.image
        if self.corruption == "motion_blur":
            return motion_blur(frame.image, s, self.flow_field(i))
        if self.corruption == "glare":
            return glare(frame.image, s, self.blobs(frame.index, s))
        return _PIXEL[self.corruption](frame.image, s, self.rng(frame.index))


_PIXEL: dict[str, Callable[[np.ndarray, float, np.random.Generator], np.ndarray]] = {
    "dark": dark,
    "overexposed": overexposed,
    "low_texture": low_texture,
}


def corrupt(seq: Sequence, name: str, severity: float, seed: int = 0) -> Sequence:
    """``seq`` under corruption ``name`` (dark | overexposed | motion_blur | low_texture | glare) at
    ``severity`` ∈ [0, 1]; ``"none"`` returns ``seq`` itself. Frames carry the corruption's labels."""
    if name == "none":
        return seq
    if name not in LABELS:
        raise UnknownName("corruption", name, (*NAMES, "none"))
    if not 0.0 <= float(severity) <= 1.0:
        raise ParameterError(f"corruption severity must lie in [0, 1], got {severity}")
    return CorruptedSequence(seq, name, float(severity), seed)
