"""Absolute and relative trajectory error, computed as evo's ``evo_ape`` / ``evo_rpe`` (translation part).

ATE (APE, translation part): after association and alignment, e_i = ‖t_est,i − t_ref,i‖.
RPE (translation part, Sturm et al. 2012 notation): for index pairs (i, j) chosen on the estimate,
E_ij = (Q_i⁻¹ Q_j)⁻¹ (P_i⁻¹ P_j) with Q the reference and P the estimate, e_ij = ‖trans(E_ij)‖.
Statistics as evo: rmse = √(mean e²), mean, median, std (population), min, max, sse = Σ e².
Association (evo ``sync.associate_trajectories``): starting from the trajectory with fewer poses, each
of its stamps is matched to the nearest stamp of the other within ``t_max_diff`` seconds.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import BadInput
from .align import Alignment
from .align import align as align_trajectory
from .io import Trajectory


@dataclass(frozen=True)
class ErrorStats:
    """Statistics of a per-pose (ATE) or per-pair (RPE) translation error, in metres."""

    rmse: float
    mean: float
    median: float
    std: float
    min: float
    max: float
    sse: float
    pairs: int
    scale: float = 1.0  # the alignment's scale (1 unless sim3)
    errors: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False, compare=False)

    @classmethod
    def of(cls, errors: np.ndarray, scale: float = 1.0) -> ErrorStats:
        e = np.asarray(errors, dtype=float)
        if e.size == 0:
            raise BadInput("no errors to summarise (no associated poses or pairs)")
        sq = e * e
        return cls(
            rmse=math.sqrt(float(np.mean(sq))),
            mean=float(np.mean(e)),
            median=float(np.median(e)),
            std=float(np.std(e)),
            min=float(np.min(e)),
            max=float(np.max(e)),
            sse=float(np.sum(sq)),
            pairs=int(e.size),
            scale=float(scale),
            errors=e,
        )

    def to_dict(self) -> dict[str, Any]:
        return {k: getattr(self, k) for k in ("rmse", "mean", "median", "std", "min", "max", "sse", "pairs", "scale")}


def matching_indices(stamps_1: np.ndarray, stamps_2: np.ndarray, max_diff: float = 0.01) -> tuple[np.ndarray, np.ndarray]:
    """For each stamp of ``stamps_1`` the index of the nearest stamp of ``stamps_2`` within ``max_diff``
    (ties go to the earlier stamp); stamps without a partner are dropped."""
    s1 = np.asarray(stamps_1, dtype=float)
    s2 = np.asarray(stamps_2, dtype=float)
    if s2.size == 0 or s1.size == 0:
        return np.zeros(0, dtype=int), np.zeros(0, dtype=int)
    if np.all(np.diff(s2) >= 0):
        upper = np.minimum(np.searchsorted(s2, s1, side="right"), s2.size - 1)
        lower = upper - 1
        diff_ub = s2[upper] - s1
        diff_lb = np.where(lower >= 0, s1 - s2[np.maximum(lower, 0)], np.inf)
        take_ub = (diff_ub <= max_diff) & (diff_ub < diff_lb)
        take_lb = ~take_ub & (diff_lb <= max_diff) & (diff_lb <= diff_ub)
        in_range = (s1 >= s2[0] - max_diff) & (s1 <= s2[-1] + max_diff)
        keep = in_range & (take_ub | take_lb)
        best = np.where(take_ub, upper, lower)
        return np.nonzero(keep)[0], best[keep].astype(int)
    # unsorted stamps: nearest by brute force
    diffs = np.abs(s2[None, :] - s1[:, None])
    best = np.argmin(diffs, axis=1)
    keep = diffs[np.arange(s1.size), best] <= max_diff
    return np.nonzero(keep)[0], best[keep].astype(int)


def associate(ref: Trajectory, est: Trajectory, t_max_diff: float = 0.01) -> tuple[Trajectory, Trajectory]:
    """Pose pairs of ``ref`` and ``est`` at (nearly) equal timestamps, as evo's nearest-time association."""
    if t_max_diff < 0:
        raise BadInput(f"t_max_diff must be ≥ 0, got {t_max_diff}")
    est_longer = len(est) > len(ref)
    short, long_ = (ref, est) if est_longer else (est, ref)
    i_short, i_long = matching_indices(short.timestamps, long_.timestamps, t_max_diff)
    if i_short.size == 0:
        raise BadInput(f"no matching timestamps between the reference and the estimate within {t_max_diff} s")
    short_sub, long_sub = short.subset(i_short), long_.subset(i_long)
    return (short_sub, long_sub) if est_longer else (long_sub, short_sub)


def associate_and_align(
    ref: Trajectory, est: Trajectory, align: str = "se3", t_max_diff: float = 0.01
) -> tuple[Trajectory, Trajectory, Alignment]:
    """The associated reference, the associated estimate aligned onto it, and the alignment: what
    ``ate`` measures, for plotting trajectories against ground truth."""
    r, e = associate(ref, est, t_max_diff)
    e_aligned, alignment = align_trajectory(e, r, align)
    return r, e_aligned, alignment


def ate(
    ref: Trajectory,
    est: Trajectory,
    align: str = "se3",
    t_max_diff: float = 0.01,
) -> ErrorStats:
    """Absolute trajectory error (translation part) after association and ``align`` (se3 | sim3 | none);
    ``evo_ape … -a`` is se3, ``-as`` is sim3."""
    r, e_aligned, alignment = associate_and_align(ref, est, align, t_max_diff)
    errors = np.linalg.norm(e_aligned.positions - r.positions, axis=1)
    return ErrorStats.of(errors, alignment.scale)


def se3_inverse(poses: np.ndarray) -> np.ndarray:
    """[Rᵀ | −Rᵀ t] of (…, 4, 4) poses: the rigid inverse, as evo takes it (files round their
    rotations, so Rᵀ and the matrix inverse differ at 1e-7, and evo's figures use Rᵀ)."""
    out = np.zeros_like(poses)
    rt = np.swapaxes(poses[..., :3, :3], -1, -2)
    out[..., :3, :3] = rt
    out[..., :3, 3] = -np.einsum("...ij,...j->...i", rt, poses[..., :3, 3])
    out[..., 3, 3] = 1.0
    return out


def pairs_by_index(n: int, delta: int, all_pairs: bool = False) -> list[tuple[int, int]]:
    """(i, i+Δ) for every i (all pairs) or for i = 0, Δ, 2Δ, … (consecutive pairs)."""
    if all_pairs:
        return [(i, i + delta) for i in range(n) if i + delta < n]
    ids = list(range(0, n, delta))
    return list(zip(ids, ids[1:], strict=False))


def pairs_by_path(
    positions: np.ndarray, delta: float, tol: float = 0.0, all_pairs: bool = False, from_first_pose: bool = True
) -> list[tuple[int, int]]:
    """Index pairs ``delta`` metres of travelled path apart (evo ``filter_pairs_by_path``).

    Consecutive: start at pose 0, accumulate the path and close a pair whenever it reaches ``delta``.
    ``from_first_pose=False`` is the 2018 evo that produced the published KITTI figures: the first
    pair starts at the first pose whose path reaches ``delta``, not at pose 0.
    All pairs: from every i, the later pose whose path distance is nearest ``delta``, if within ``tol``.
    """
    steps = np.linalg.norm(np.diff(positions, axis=0), axis=1)
    if all_pairs:
        dist = np.concatenate(([0.0], np.cumsum(steps)))
        out = []
        for i in range(dist.size - 1):
            ahead = dist[i + 1 :] - dist[i]
            k = int(np.argmin(np.abs(ahead - delta)))
            if abs(ahead[k] - delta) <= tol:
                out.append((i, i + 1 + k))
        return out
    ids = [0] if from_first_pose else []
    travelled = 0.0
    for i, step in enumerate(steps, start=1):
        travelled += float(step)
        if travelled >= delta:
            ids.append(i)
            travelled = 0.0
    return list(zip(ids, ids[1:], strict=False))


def rpe(
    ref: Trajectory,
    est: Trajectory,
    delta: float = 1,
    delta_unit: str = "f",
    all_pairs: bool = False,
    align: str = "none",
    t_max_diff: float = 0.01,
    rel_delta_tol: float = 0.1,
    pairs_from_reference: bool = False,
    from_first_pose: bool = True,
) -> ErrorStats:
    """Relative pose error (translation part) as ``evo_rpe``: ``delta`` in frames (``f``) or metres
    (``m``) of path, consecutive or all pairs, pairs chosen on the estimate unless
    ``pairs_from_reference``; the metre tolerance for all pairs is ``rel_delta_tol · delta``.
    ``from_first_pose=False`` reproduces evo's 2018 consecutive metre pairs (see ``pairs_by_path``)."""
    if delta <= 0:
        raise BadInput(f"delta must be positive, got {delta}")
    r, e, alignment = associate_and_align(ref, est, align, t_max_diff)
    base = r if pairs_from_reference else e
    if delta_unit == "f":
        if float(delta) != int(delta):
            raise BadInput(f"delta must be an integer number of frames, got {delta}")
        pairs = pairs_by_index(len(base), int(delta), all_pairs)
    elif delta_unit == "m":
        pairs = pairs_by_path(base.positions, float(delta), float(delta) * rel_delta_tol, all_pairs, from_first_pose)
    else:
        raise BadInput(f"unknown delta unit {delta_unit!r}; known: f, m")
    if not pairs:
        raise BadInput(f"delta = {delta} ({delta_unit}) produced no pose pairs; try a smaller delta")
    i, j = np.array(pairs, dtype=int).T
    q_rel = se3_inverse(r.poses[i]) @ r.poses[j]
    p_rel = se3_inverse(e.poses[i]) @ e.poses[j]
    err = se3_inverse(q_rel) @ p_rel
    return ErrorStats.of(np.linalg.norm(err[:, :3, 3], axis=1), alignment.scale)
