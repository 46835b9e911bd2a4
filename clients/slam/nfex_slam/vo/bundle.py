"""Sliding-window bundle adjustment of the local map, on GTSAM's factor graphs (Dellaert & Kaess 2017).

Over the window's keyframe poses T_wc,i and the points X_j they see (each point seen by at least two of them):

    min  Σ_ij ρ_H( ‖π(K, T_wc,i⁻¹ · X_j) − x_ij‖ / σ_ij ),

with one ``GenericProjectionFactorCal3_S2`` per observation x_ij (undistorted pixels, pinhole K), σ_ij the
keypoint's scale (``localmap.keypoint_sigma``: 1 px at the finest), ρ_H the Huber loss with k = √5.991 (χ² with 2 degrees of freedom at 95 %, ORB-SLAM's local BA: Mur-Artal et al. 2015, §VI-D),
solved by Levenberg–Marquardt. The oldest ``fixed`` keyframes of the window are held where they are
(``NonlinearEqualityPose3``), and with ``hold_range`` the distance between two of them too (``RangeFactorPose3``,
σ = 10⁻⁶ of it): one pose and that distance, or two poses, fix the gauge — the seven degrees of freedom a monocular
reconstruction leaves free, its scale among them — at the map's, so the window refines the scale it inherits and
never re-chooses it, while one held pose lets the second oldest keyframe's direction be corrected.

``rotations`` adds, between two keyframes i, j of the window, the rotation R_j←i their frame pairs' two-view
estimates chain to (each pair's essential matrix, x_k = R x_k−1 + t): a ``BetweenFactorPose3`` whose measured
relative pose is (R_j←iᵀ, the current translation) with noise σ_R on the rotation's three tangent coordinates and
σ = 10⁶ times the pair's distance on the translation's, so that only the rotation binds,

    + Σ_ij ρ_H( ‖Log(R_j←i · R_wc,iᵀ R_wc,j)‖ / σ_R )  (k = √7.815, χ² with 3 degrees of freedom at 95 %).

Points triangulated while the camera mostly turned can fit a wrong heading as well as the right one (their depths
absorb it); the pairs' rotations, which need no depth, tie the window's heading to the images.
"""
from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np

HUBER_PX = float(np.sqrt(5.991))  # χ²(2 dof, 95 %) in pixels: ORB-SLAM's threshold for an inlying observation
HUBER_ROTATION = float(np.sqrt(7.815))  # χ²(3 dof, 95 %): a relative rotation's whitened error


def adjust(
    poses: Mapping[int, np.ndarray], fixed: Iterable[int], points: Mapping[int, np.ndarray],
    observations: Iterable[tuple[int, int, np.ndarray, float]], K: np.ndarray, *, iterations: int = 10,
    hold_range: tuple[int, int] | None = None, rotations: Mapping[tuple[int, int], np.ndarray] | None = None,
    rotation_sigma: float = 0.0,
) -> tuple[dict[int, np.ndarray], dict[int, np.ndarray]]:
    """Refined camera-to-world poses (4×4) and world points of one window; the fixed poses come back unchanged.

    ``observations`` are (keyframe id, point id, undistorted pixel, σ in px); an observation of a pose or point not
    given is skipped. ``rotations`` maps (i, j) to R_j←i (camera i to camera j), held with σ ``rotation_sigma``
    (radians); a pair of which a pose is not given is skipped.
    """
    import gtsam  # heavy (a 40 MB extension): imported where the map adjusts, not with the package
    from gtsam.symbol_shorthand import L, X

    cal = gtsam.Cal3_S2(float(K[0, 0]), float(K[1, 1]), float(K[0, 1]), float(K[0, 2]), float(K[1, 2]))
    noises: dict[float, Any] = {}
    graph = gtsam.NonlinearFactorGraph()
    values = gtsam.Values()
    for i, T in poses.items():
        values.insert(X(i), gtsam.Pose3(np.asarray(T, float)))
    for i in set(fixed) & set(poses):
        graph.add(gtsam.NonlinearEqualityPose3(X(i), gtsam.Pose3(np.asarray(poses[i], float))))
    if hold_range is not None:
        a, b = hold_range
        d = float(np.linalg.norm(np.asarray(poses[a])[:3, 3] - np.asarray(poses[b])[:3, 3]))
        graph.add(gtsam.RangeFactorPose3(X(a), X(b), d, gtsam.noiseModel.Isotropic.Sigma(1, 1e-6 * max(d, 1e-9))))
    if rotations and rotation_sigma > 0:
        robust = gtsam.noiseModel.mEstimator.Huber.Create(HUBER_ROTATION)
        for (a, b), R in rotations.items():
            if a in poses and b in poses:
                Ta, Tb = np.asarray(poses[a], float), np.asarray(poses[b], float)
                t = Ta[:3, :3].T @ (Tb[:3, 3] - Ta[:3, 3])  # b's centre in a's camera: left free
                sigmas = np.r_[np.full(3, rotation_sigma), np.full(3, 1e6 * max(float(np.linalg.norm(t)), 1e-9))]
                noise = gtsam.noiseModel.Robust.Create(robust, gtsam.noiseModel.Diagonal.Sigmas(sigmas))
                graph.add(gtsam.BetweenFactorPose3(X(a), X(b), gtsam.Pose3(gtsam.Rot3(np.asarray(R, float).T), t), noise))
    for j, Xj in points.items():
        values.insert(L(j), np.asarray(Xj, float))
    for i, j, xy, sigma in observations:
        if i in poses and j in points:
            if sigma not in noises:  # Huber on the whitened error: the threshold is √5.991 σ in pixels
                noises[sigma] = gtsam.noiseModel.Robust.Create(
                    gtsam.noiseModel.mEstimator.Huber.Create(HUBER_PX), gtsam.noiseModel.Isotropic.Sigma(2, sigma))
            graph.add(gtsam.GenericProjectionFactorCal3_S2(np.asarray(xy, float), noises[sigma], X(i), L(j), cal))
    params = gtsam.LevenbergMarquardtParams()
    params.setMaxIterations(iterations)
    try:
        result = gtsam.LevenbergMarquardtOptimizer(graph, values, params).optimize()
    except RuntimeError:  # an indeterminant system (a point seen along one ray): keep the window as it was
        return dict(poses), dict(points)
    return ({i: result.atPose3(X(i)).matrix() for i in poses}, {j: np.asarray(result.atPoint3(L(j)), float) for j in points})
