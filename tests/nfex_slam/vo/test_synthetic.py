"""The VO on the synthetic textured-plane sequence (exact ground truth, no ../shared/data needed)."""
from __future__ import annotations

import numpy as np
import pytest
from nfex_slam.datasets import make_sequence
from nfex_slam.vo import VOParams, fixed, run_vo

from nfex_core.vision.registry import ExtractorRegistry


@pytest.mark.parametrize("extractor", ["ORB", "SIFT", "AKAZE", "BRISK"])
def test_every_extractor_recovers_the_synthetic_motion(registry: ExtractorRegistry, extractor: str) -> None:
    seq = make_sequence(8, 320, 240, step=0.3)  # ~15 px parallax a frame: enough for the five-point solver
    # ORB's few, clustered keypoints on these procedural planes start the local map on a pair whose direction is
    # off, and the map's run heads far from the true direction: ORB is held to the two-view VO's figures here
    res = run_vo(seq, fixed(extractor), registry=registry, params=VOParams(scale="triangulated") if extractor == "ORB" else None)
    assert res.lost_count == 0 and not res.failed
    gt = np.linalg.inv(seq.poses[0]) @ seq.poses  # ground truth in the first camera's frame, like the estimate
    # direction of travel (the path is a straight line, so Sim(3) ATE is degenerate: compare directions)
    d_est = res.poses[-1, :3, 3] / np.linalg.norm(res.poses[-1, :3, 3])
    d_gt = gt[-1, :3, 3] / np.linalg.norm(gt[-1, :3, 3])
    assert float(d_est @ d_gt) > 0.97
    # orientation after 7 steps (2.1° of true yaw): within 4° — except ORB, whose matches on this
    # procedural texture drift ~2.5° a step (measured; a known weakness, see docs/experiments.md)
    dR = res.poses[-1, :3, :3].T @ gt[-1, :3, :3]
    error = np.degrees(np.arccos(np.clip((np.trace(dR) - 1) / 2, -1, 1)))
    assert error < (30.0 if extractor == "ORB" else 4.0)


def test_triangulated_scale_is_consistent(registry: ExtractorRegistry) -> None:
    """Equal true steps give (nearly) equal estimated steps (SIFT; ORB's few repeated points on these
    planes make its relative scale jump — see docs/experiments.md)."""
    seq = make_sequence(8, 320, 240, step=0.3)
    res = run_vo(seq, fixed("SIFT"), registry=registry)
    steps = np.linalg.norm(np.diff(res.poses[:, :3, 3], axis=0), axis=1)
    assert steps.std() / steps.mean() < 0.1


def test_a_straight_path_makes_ate_undefined_not_an_error(registry: ExtractorRegistry) -> None:
    from nfex_slam.vo import window_errors

    seq = make_sequence(6, 320, 240)
    res = run_vo(seq, fixed("ORB"), registry=registry)
    assert window_errors(seq, res) == (None, None)  # collinear positions: Umeyama is degenerate
