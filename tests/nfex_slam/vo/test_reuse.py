"""Runs over the same frames share extractions and matches (``vo.reuse``), and come out as they would alone."""
from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from nfex_slam.datasets.base import Sequence
from nfex_slam.features import Features
from nfex_slam.vo import Choice, Reusing, VOParams, VOResult, fixed, run_vo

from nfex_core.vision.registry import ExtractorRegistry


class Counting:
    """The real registry, counting the extractions it runs."""

    def __init__(self, inner: ExtractorRegistry) -> None:
        self.inner, self.calls = inner, 0

    def extract(self, name: str, image: np.ndarray, params: Mapping[str, Any] | None = None) -> Features:
        self.calls += 1
        return self.inner.extract(name, image, params)

    def resolve(self, name: str, params: Mapping[str, Any] | None = None) -> dict[str, Any]:
        return self.inner.resolve(name, params)


def _same(a: VOResult, b: VOResult) -> None:
    assert np.array_equal(a.poses, b.poses)
    for fa, fb in zip(a.frames, b.frames, strict=True):
        assert (fa.matches, fa.inliers, fa.lost, fa.reason, fa.errors) == (fb.matches, fb.inliers, fb.lost, fb.reason, fb.errors)


def test_paired_runs_extract_and_match_each_frame_once_and_keep_their_results(
        kitti01: Sequence, registry: ExtractorRegistry) -> None:
    counting = Counting(registry)
    shared = Reusing(counting)
    alone = [run_vo(kitti01, fixed("ORB_GRID"), registry=registry, params=VOParams(seed=s), stop=8) for s in (0, 1)]
    reused = [run_vo(kitti01, fixed("ORB_GRID"), registry=shared, params=VOParams(seed=s), stop=8) for s in (0, 1, 0)]
    assert counting.calls == shared.extractions == 8  # one per frame, for three runs
    assert shared.matchings == 7  # one per frame pair
    for a, b in zip([*alone, alone[0]], reused, strict=True):
        _same(a, b)
    # a reused extraction reports the time it took when it ran
    assert [f.extraction_ms for f in reused[0].frames] == [f.extraction_ms for f in reused[1].frames]


def test_a_switch_of_configuration_reuses_the_other_configurations_extractions(
        kitti01: Sequence, registry: ExtractorRegistry) -> None:
    counting = Counting(registry)
    shared = Reusing(counting)
    run_vo(kitti01, fixed("ORB_GRID"), registry=shared, stop=6)
    run_vo(kitti01, fixed("ORB"), registry=shared, stop=6)
    assert counting.calls == 12

    def alternate(frame: Any, _history: Any) -> Choice:
        return Choice("ORB" if frame.index % 2 else "ORB_GRID")

    res = run_vo(kitti01, alternate, registry=shared, stop=6)
    assert counting.calls == 12 and not res.lost  # every frame, and every re-extraction of frame k−1, was kept


def test_past_its_bound_it_forgets_the_oldest_and_still_answers_alike(
        kitti01: Sequence, registry: ExtractorRegistry) -> None:
    counting = Counting(registry)
    small = Reusing(counting, max_bytes=3 * registry.extract("ORB_GRID", kitti01[0].image).nbytes)  # about three frames' features
    a = run_vo(kitti01, fixed("ORB_GRID"), registry=small, params=VOParams(seed=0), stop=8)
    b = run_vo(kitti01, fixed("ORB_GRID"), registry=small, params=VOParams(seed=0), stop=8)
    assert counting.calls > 8  # the second run extracted again what the bound dropped
    _same(a, b)
    assert len(small._features) <= 4 and all(  # noqa: SLF001 - the bound is what this test is about
        k[0] in small._features and k[1] in small._features for k in small._matches)  # noqa: SLF001
