"""Umeyama alignment of an estimated trajectory to a reference, as evo's ``--align`` / ``--correct_scale``.

Umeyama (PAMI 1991): for points x_i (estimate) and y_i (reference), with means μx, μy, variance
σx² = 1/n Σ‖x_i − μx‖² and covariance Σxy = 1/n Σ (y_i − μy)(x_i − μx)ᵀ = U D Vᵀ,

    S = diag(1, 1, det(U)·det(V) < 0 ? −1 : 1),  R = U S Vᵀ,  c = tr(D S) / σx²,  t = μy − c R μx,

minimises Σ‖y_i − (c R x_i + t)‖². SE(3) fixes c = 1. The aligned pose of an estimate pose (R_p, t_p)
is (R R_p, c R t_p + t): evo scales the translations, then left-multiplies by the SE(3) (R, t).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import BadInput
from .io import Trajectory

ALIGN_METHODS = ("se3", "sim3", "none")


@dataclass(frozen=True)
class Alignment:
    """The similarity that maps the estimate onto the reference: y ≈ scale · rotation · x + translation."""

    rotation: np.ndarray
    translation: np.ndarray
    scale: float

    @property
    def matrix(self) -> np.ndarray:
        """The 4×4 Sim(3) matrix [[c R, t], [0, 1]]."""
        m = np.eye(4)
        m[:3, :3] = self.scale * self.rotation
        m[:3, 3] = self.translation
        return m

    def apply(self, traj: Trajectory) -> Trajectory:
        poses = traj.poses.copy()
        poses[:, :3, 3] *= self.scale
        se3 = np.eye(4)
        se3[:3, :3] = self.rotation
        se3[:3, 3] = self.translation
        return Trajectory(traj.timestamps.copy(), se3 @ poses)


IDENTITY = Alignment(np.eye(3), np.zeros(3), 1.0)


def umeyama(x: np.ndarray, y: np.ndarray, with_scale: bool = False) -> Alignment:
    """The least-squares similarity (or rigid motion) taking points ``x`` (N, m) onto ``y`` (N, m)."""
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    if x.shape != y.shape or x.ndim != 2:
        raise BadInput(f"Umeyama alignment needs two (N, m) point sets of one shape, got {x.shape} and {y.shape}")
    n, m = x.shape
    if n < 2:
        raise BadInput(f"Umeyama alignment needs at least 2 points, got {n}")
    mean_x = x.mean(axis=0)
    mean_y = y.mean(axis=0)
    xc = x - mean_x
    yc = y - mean_y
    sigma_x = float(np.sum(xc * xc)) / n
    cov = yc.T @ xc / n
    u, d, vt = np.linalg.svd(cov)
    if np.count_nonzero(d > np.finfo(d.dtype).eps) < m - 1:
        raise BadInput("degenerate covariance rank: the positions are (nearly) collinear or identical, Umeyama alignment is not possible")
    s = np.eye(m)
    if np.linalg.det(u) * np.linalg.det(vt) < 0.0:
        s[m - 1, m - 1] = -1.0
    r = u @ s @ vt
    c = float(np.trace(np.diag(d) @ s)) / sigma_x if with_scale else 1.0
    t = mean_y - c * (r @ mean_x)
    return Alignment(r, t, c)


def align(est: Trajectory, ref: Trajectory, method: str = "se3") -> tuple[Trajectory, Alignment]:
    """Align ``est`` to ``ref`` (already associated, same length) with ``se3``, ``sim3`` or ``none``."""
    method = method.lower()
    if method not in ALIGN_METHODS:
        raise BadInput(f"unknown alignment {method!r}; known: {', '.join(ALIGN_METHODS)}")
    if len(est) != len(ref):
        raise BadInput(f"alignment needs associated trajectories of one length, got {len(est)} and {len(ref)}")
    if method == "none":
        return est, IDENTITY
    a = umeyama(est.positions, ref.positions, with_scale=method == "sim3")
    return a.apply(est), a
