"""Pair outcomes: coasting is not loss, the failure rule reads its coasting bound from the graph, and the
motion-prior control repeats the first tracked step."""
from __future__ import annotations

import numpy as np
import pytest
from nfex_slam.vo import FrameRecord, VOResult

from nfex_core.evaluation.outcomes import (
    COASTED,
    LOST,
    TRACKED,
    Outcomes,
    frontend,
    max_coasted_fraction,
    motion_prior,
    outcome,
)
from nfex_core.kg import KnowledgeGraph


def _frame(i: int, lost: bool = False, reason: str = "") -> FrameRecord:
    return FrameRecord(i, 0.1 * i, "ORB", {}, 500, 200, 100, 5.0, 2.0, lost, reason)


def _truth(n: int) -> np.ndarray:
    poses = np.tile(np.eye(4), (n, 1, 1))
    yaw = 0.05
    step = np.eye(4)
    step[:3, :3] = [[np.cos(yaw), 0, np.sin(yaw)], [0, 1, 0], [-np.sin(yaw), 0, np.cos(yaw)]]
    step[:3, 3] = [0.0, 0.0, 1.0]
    for k in range(1, n):
        poses[k] = poses[k - 1] @ step
    return poses


def _result(frames: list[FrameRecord], poses: np.ndarray) -> VOResult:
    return VOResult(poses, np.array([f.timestamp for f in frames]), frames)


def test_a_pair_is_tracked_coasted_or_lost_by_its_reason() -> None:
    assert outcome(_frame(1)) == TRACKED
    assert outcome(_frame(1, True, "check: rotation 40.0° exceeds 10.0° per frame")) == COASTED
    assert outcome(_frame(1, True, "verify: every candidate disagreed with the prior")) == COASTED
    assert outcome(_frame(1, True, "too few inliers (4 < 10)")) == LOST


def test_coasting_within_its_bound_does_not_fail_a_run_that_the_vo_counts_as_lost() -> None:
    """Four of ten pairs rejected by the checks: the VO's own rule (lost > 30 %) fails the run; the
    evaluation counts them coasted and keeps it, and fails it only past the graph's bound."""
    frames = [_frame(0)] + [_frame(i, i in (2, 4, 6, 8), "check: heading" if i in (2, 4, 6, 8) else "") for i in range(1, 11)]
    res = _result(frames, _truth(11))
    o = Outcomes.of(res)
    assert (o.pairs, o.lost, o.coasted) == (10, 0, 4) and res.failed
    assert not o.fails(0.3, 0.5) and o.fails(0.3, 0.3)
    lost = Outcomes.of(_result([_frame(0)] + [_frame(i, i < 5, "no essential matrix") for i in range(1, 11)], _truth(11)))
    assert lost.lost == 4 and lost.fails(0.3, 0.5)


def test_the_coasting_bound_is_graph_data(bare_kg: KnowledgeGraph) -> None:
    assert max_coasted_fraction(bare_kg) == 0.5
    bare_kg.update("""PREFIX nfex: <https://w3id.org/nfex#> PREFIX xsd: <http://www.w3.org/2001/XMLSchema#>
                      DELETE { nfex:maxCoastedFraction nfex:value ?v } INSERT { nfex:maxCoastedFraction nfex:value "0.2"^^xsd:double }
                      WHERE { nfex:maxCoastedFraction nfex:value ?v }""", author="test")
    assert max_coasted_fraction(bare_kg) == pytest.approx(0.2)


def test_untracked_pairs_score_180_degrees_in_the_front_end_figures() -> None:
    truth = _truth(11)
    tracked = frontend(truth, _result([_frame(i) for i in range(11)], truth))
    assert tracked is not None and tracked.auc[5.0] == pytest.approx(1.0, abs=1e-6) and tracked.ate == pytest.approx(0, abs=1e-9)
    frames = [_frame(i, i in (3, 7), "check: x" if i == 3 else "too few matches") for i in range(11)]
    half = frontend(truth, _result(frames, truth))
    assert half is not None and half.auc[20.0] == pytest.approx(0.8, abs=1e-6)
    assert list(np.flatnonzero(half.error_deg == 180.0)) == [2, 6]
    assert frontend(None, _result(frames, truth)) is None


def test_the_motion_prior_repeats_the_first_tracked_step_and_coasts_on_it() -> None:
    truth = _truth(8)
    frames = [_frame(0), _frame(1, True, "too few matches")] + [_frame(i) for i in range(2, 8)]
    prior = motion_prior(_result(frames, truth))
    step = np.linalg.inv(truth[1]) @ truth[2]
    assert np.allclose(prior.poses[3], np.linalg.matrix_power(step, 3))
    kinds = [outcome(f) for f in prior.frames[1:]]
    assert kinds == [COASTED, TRACKED] + [COASTED] * 5
    assert prior.frames[2] is frames[2] and prior.frames[4].extraction_ms == 0.0
    assert frontend(truth, prior).auc[5.0] == pytest.approx(1 / 7, abs=1e-6)  # on a circle, only the measured pair counts
