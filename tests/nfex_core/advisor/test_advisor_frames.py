"""The advisor on real frames: F_metrics over every candidate, estimated context, a two-frame stream."""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
from nfex_slam.datasets.synthetic import make_sequence

from nfex_core.advisor.advisor import Advisor
from nfex_core.kg import KnowledgeGraph

KITTI = "kitti/sequences/00/image_0"


def test_select_on_a_kitti_frame_and_a_stream_of_two(kg: KnowledgeGraph, data_dir: Path) -> None:
    files = sorted((data_dir / KITTI).glob("*.png"))
    f0, f1 = (cv2.imread(str(files[i]), cv2.IMREAD_GRAYSCALE) for i in (40, 41))
    advisor = Advisor(kg, neural="symbolic")  # F_metrics over every candidate
    vocab = kg.vocabulary()
    single = {m for m, s in vocab.metrics.items() if not s.temporal}

    first = advisor.select({"agent": "car"}, frame=f0)
    assert first.mode == "metrics"
    assert first.candidates and all(c.score is not None for c in first.candidates)
    assert {c.extractor for c in first.candidates} | {p.extractor for p in first.pruned} == set(vocab.extractors)
    for c in first.candidates:
        assert set(c.metrics) == single and all(0.0 <= v <= 1.0 for v in c.metrics.values())
        assert c.keypoints and c.keypoints > 0
    assert first.extractor == max(first.candidates, key=lambda c: c.score or 0.0).extractor
    context = {e.dimension: e for e in first.context}
    assert (context["agent"].value, context["agent"].source) == ("car", "given")
    assert context["scene"].source == "unknown"
    estimated = {d for d, e in context.items() if e.source == "estimated"}
    assert {"light", "texture", "reflectance", "motion"} <= estimated
    assert context["light"].value == "bright" and context["texture"].value in ("medium", "high")
    assert all(0.0 <= (context[d].confidence or 0.0) <= 1.0 and context[d].evidence for d in estimated)

    second = advisor.select({"agent": "car"}, frame=f1, previous=first.state)
    assert second.mode == "metrics"
    assert {c.extractor for c in second.candidates} == {c.extractor for c in first.candidates}
    for c in second.candidates:
        assert set(c.metrics) == set(vocab.metrics)
        assert c.metrics["repeatability"] > 0.2 and c.metrics["stability"] > 0.1 and c.metrics["motion"] < 0.5
    motion = next(e for e in second.context if e.dimension == "motion")
    assert "flow" in (motion.evidence or "")


def test_the_frame_path_on_synthetic_frames(kg: KnowledgeGraph) -> None:
    """The frame path without the data folder: a two-frame stream of the generator's textured planes."""
    seq = make_sequence(2, 640, 480)
    advisor = Advisor(kg, neural="symbolic")
    vocab = kg.vocabulary()
    first = advisor.select({"agent": "drone"}, frame=seq[0].image)
    assert first.mode == "metrics" and first.candidates
    assert all(c.score is not None and c.keypoints for c in first.candidates)
    assert first.extractor == max(first.candidates, key=lambda c: c.score or 0.0).extractor
    second = advisor.select({"agent": "drone"}, frame=seq[1].image, previous=first.state)
    for c in second.candidates:
        assert set(c.metrics) == set(vocab.metrics) and all(0.0 <= v <= 1.0 for v in c.metrics.values())
        assert c.metrics["repeatability"] > 0.2  # a small camera step: most features are found again


def test_frame_statistics_are_computed_once_per_request(kg: KnowledgeGraph, data_dir: Path, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    import nfex_core.vision.context as context
    import nfex_core.vision.statistics as statistics

    files = sorted((data_dir / KITTI).glob("*.png"))
    frame = cv2.imread(str(files[40]), cv2.IMREAD_GRAYSCALE)
    calls: list[tuple[int, ...]] = []
    real = statistics.frame_statistics

    def counting(image, previous_image=None, **analysis):  # type: ignore[no-untyped-def]
        calls.append(image.shape)
        return real(image, previous_image, **analysis)

    monkeypatch.setattr(statistics, "frame_statistics", counting)
    monkeypatch.setattr(context, "frame_statistics", counting)
    Advisor(kg, neural="paramnet").select({"agent": "car"}, frame=frame)
    assert calls == [frame.shape]  # context estimation and ParamNet share one computation on the frame


def test_when_selectornet_decides_the_extractors_it_never_saw_are_not_extracted(kg: KnowledgeGraph, data_dir: Path) -> None:
    image = cv2.imread(str(sorted((data_dir / KITTI).glob("*.png"))[40]), cv2.IMREAD_GRAYSCALE)
    advisor = Advisor(kg, neural="selectornet", exhaustive_scoring=True)  # every candidate SelectorNet knows scored
    known = advisor.neural.step(kg.vocabulary()).selector_extractors
    sel = advisor.select({"agent": "car"}, frame=image)
    assert sel.mode == "selectornet" and sel.extractor in known
    assert abs(sum(c.score or 0.0 for c in sel.candidates) - 1.0) < 1e-6
    for c in sel.candidates:
        if c.extractor in known:
            assert c.metrics and c.keypoints
        else:  # probability 0 whatever its F_metrics: listed, not extracted
            assert c.score == 0.0 and not c.metrics and c.keypoints is None and c.evidence.not_scored
    assert set(known) - {c.extractor for c in sel.candidates} <= {p.extractor for p in sel.pruned}
    assert set(sel.state.features) == {c.extractor for c in sel.candidates if c.keypoints}  # type: ignore[union-attr]


def test_when_bounds_settle_selectornet_nothing_that_cannot_win_is_extracted(kg: KnowledgeGraph, data_dir: Path) -> None:
    """Scoring what can still win: α* carries its least probability over the unmeasured metrics; SelectorNet's
    other candidates have no score and say why; the ones it never saw have probability 0, as above."""
    image = cv2.imread(str(sorted((data_dir / KITTI).glob("*.png"))[40]), cv2.IMREAD_GRAYSCALE)
    advisor = Advisor(kg, neural="selectornet")
    known = advisor.neural.step(kg.vocabulary()).selector_extractors
    sel = advisor.select({"agent": "car"}, frame=image)
    exact = Advisor(kg, neural="selectornet", exhaustive_scoring=True).select({"agent": "car"}, frame=image)
    assert (sel.extractor, sel.params, sel.mode) == (exact.extractor, exact.params, "selectornet")
    best = sel.candidates[0]
    assert best.extractor == sel.extractor and best.score is not None
    assert 0.0 < best.score <= next(c.score for c in exact.candidates if c.extractor == sel.extractor) + 1e-9
    for c in sel.candidates[1:]:
        if c.extractor in known:
            assert c.score is None and "cannot overtake" in (c.evidence.not_scored or "")
        else:
            assert c.score == 0.0 and c.keypoints is None
    extracted = {c.extractor for c in sel.candidates if c.keypoints}
    assert extracted < {c.extractor for c in exact.candidates if c.keypoints}  # something was not extracted


def test_a_stream_measures_motion_between_the_statistics_copies(kg: KnowledgeGraph, data_dir: Path) -> None:
    """The next frame's flow statistics read the copy the last frame's statistics were computed on (kept in the
    FrameState), not the smaller scoring copy enlarged: the same numbers as computing both copies afresh."""
    from nfex_core.vision.statistics import FLOW_KEYS, analysis_image, frame_statistics

    files = sorted((data_dir / KITTI).glob("*.png"))
    a, b = (cv2.imread(str(f), cv2.IMREAD_GRAYSCALE) for f in files[40:42])
    advisor = Advisor(kg, neural="symbolic")
    first = advisor.select({"agent": "car"}, a)
    assert first.state is not None and first.state.analysis is not None
    np.testing.assert_array_equal(first.state.analysis, analysis_image(a))
    assert first.state.image.size < first.state.analysis.size  # the scoring copy is the smaller one
    expected = frame_statistics(b, a)
    got = advisor.select({"agent": "car"}, b, first.state)
    # the advisor's flow equals the one between the two frames' own analysis copies (what the estimators read)
    from nfex_core.advisor.conditions import read_conditions

    cond = read_conditions(advisor.snapshot().vocab, {"agent": "car"}, b, first.state)
    assert cond.stats is not None and {k: cond.stats[k] for k in FLOW_KEYS} == {k: expected[k] for k in FLOW_KEYS}
    assert got.context == cond.entries
