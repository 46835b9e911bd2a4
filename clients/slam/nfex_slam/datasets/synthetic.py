"""A tiny synthetic sequence: procedurally textured planes seen from known camera poses.

Each plane is a texture image mapped onto the world by X(u, v) = o + s·u·e1 + s·v·e2 (u, v texture
pixels, s metres per pixel). A camera with pose T_wc = [R | c] sees it through the homography

    H = K · [Rᵀ s e1,  Rᵀ s e2,  Rᵀ (o − c)]

(texture pixel → image pixel), rendered with ``cv2.warpPerspective`` far plane first. The default
scene is a wall (z = 0, facing the camera) and a floor (y = +1, the OpenCV camera's y axis points
down), seen by a camera ~3 m in front of the wall that slides sideways, forwards and yaws a little.
Unit tests use it where they must not depend on ../shared/data.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError
from .base import Intrinsics
from .frames import ArraySequence

TEXTURE_SIZE = 1024


@dataclass(frozen=True)
class Plane:
    origin: np.ndarray  # world position of texture pixel (0, 0)
    e1: np.ndarray  # world direction of texture +u
    e2: np.ndarray  # world direction of texture +v
    size: float  # metres covered by the texture's side


PLANES = {
    "wall": Plane(np.array([-4.0, -4.0, 0.0]), np.array([1.0, 0, 0]), np.array([0, 1.0, 0]), 8.0),
    "floor": Plane(np.array([-4.0, 1.0, -2.5]), np.array([1.0, 0, 0]), np.array([0, 0, 1.0]), 8.0),
}
# far to near: nearer planes are painted over farther ones
PAINT_ORDER = ("wall", "floor")


def procedural_texture(seed: int, size: int = TEXTURE_SIZE) -> np.ndarray:
    """A grey texture rich in corners and blobs at several scales (noise octaves + random shapes)."""
    import cv2

    rng = np.random.default_rng(seed)
    tex = np.zeros((size, size), np.float32)
    for cells, weight in ((8, 0.35), (32, 0.3), (128, 0.2), (512, 0.15)):
        noise = rng.random((cells, cells)).astype(np.float32)
        tex += weight * cv2.resize(noise, (size, size), interpolation=cv2.INTER_CUBIC)
    img = np.clip(tex * 255, 0, 255).astype(np.uint8)
    for _ in range(3000):
        colour = int(rng.integers(0, 256))
        x, y = (int(v) for v in rng.integers(0, size, 2))
        r = int(rng.integers(8, 32))
        if rng.random() < 0.5:
            cv2.rectangle(img, (x, y), (x + r, y + int(rng.integers(8, 32))), colour, -1)
        else:
            cv2.circle(img, (x, y), r // 2 + 2, colour, -1)
    return img


def plane_homography(plane: Plane, pose: np.ndarray, k: np.ndarray, texture_size: int) -> np.ndarray:
    """H (3×3) taking texture pixels of ``plane`` to image pixels of a camera at ``pose`` (camera-to-world)."""
    s = plane.size / texture_size
    r_cw = pose[:3, :3].T
    cols = np.column_stack([r_cw @ (s * plane.e1), r_cw @ (s * plane.e2), r_cw @ (plane.origin - pose[:3, 3])])
    return k @ cols


def yaw(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def make_poses(n: int, step: float = 0.05, direction: tuple[float, float, float] = (1.0, 0.0, 0.3), yaw_deg: float = 0.3) -> np.ndarray:
    """Camera-to-world poses: start 3 m before the wall, move ``step`` m per frame along ``direction``
    (camera frame axes at the start) and turn ``yaw_deg`` per frame about the vertical."""
    d = np.asarray(direction, dtype=float)
    d = d / np.linalg.norm(d)
    start = np.array([-0.5 * step * (n - 1) * d[0], -0.2, -3.0])
    poses = np.tile(np.eye(4), (n, 1, 1))
    for i in range(n):
        poses[i, :3, :3] = yaw(np.radians(yaw_deg * (i - (n - 1) / 2)))
        poses[i, :3, 3] = start + i * step * d
    return poses


def render(
    pose: np.ndarray, intr: Intrinsics, textures: dict[str, np.ndarray], planes: tuple[str, ...] = PAINT_ORDER
) -> np.ndarray:
    """The grey image of the planes seen from ``pose`` (background black)."""
    import cv2

    image = np.zeros((intr.height, intr.width), np.uint8)
    for name in PAINT_ORDER:
        if name not in planes:
            continue
        tex = textures[name]
        h = plane_homography(PLANES[name], pose, intr.K, tex.shape[0])
        size = (intr.width, intr.height)
        warped = cv2.warpPerspective(tex, h, size, flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT)
        mask = cv2.warpPerspective(np.full_like(tex, 255), h, size, flags=cv2.INTER_NEAREST) > 0
        image[mask] = warped[mask]
    return image


def make_sequence(
    n_frames: int = 10,
    width: int = 320,
    height: int = 240,
    *,
    step: float = 0.05,
    direction: tuple[float, float, float] = (1.0, 0.0, 0.3),
    yaw_deg: float = 0.3,
    planes: tuple[str, ...] = ("wall", "floor"),
    seed: int = 0,
    fps: float = 10.0,
    context: dict[str, str] | None = None,
) -> ArraySequence:
    """A synthetic ``Sequence`` with exact camera-to-world ground truth and pinhole intrinsics
    (f = 0.8·width, principal point at the centre, no distortion)."""
    if n_frames < 1 or width < 16 or height < 16:
        raise ParameterError(f"need ≥ 1 frame of ≥ 16×16 pixels, got {n_frames} of {width}×{height}")
    unknown = set(planes) - set(PLANES)
    if unknown:
        raise ParameterError(f"unknown plane(s) {sorted(unknown)}; known: {', '.join(PLANES)}")
    f = 0.8 * width
    intr = Intrinsics(f, f, width / 2.0, height / 2.0, width, height)
    textures = {name: procedural_texture(seed * 10 + i) for i, name in enumerate(PLANES)}
    poses = make_poses(n_frames, step, direction, yaw_deg)
    images = [render(p, intr, textures, planes) for p in poses]
    ts = np.arange(n_frames) / fps
    return ArraySequence("synthetic", f"planes-{seed}", intr, images, ts, poses, context or {})
