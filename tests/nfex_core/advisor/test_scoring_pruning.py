"""Scoring only what can still win (advisor/scoring.Scorer) gives the answer of scoring every candidate.

On real frames, as single requests and as streams (each advisor chaining its own FrameState), for contexts
decided by SelectorNet, by F_metrics, with and without a budget: α*, Θ′ and the mode equal those of
``exhaustive_scoring=True``, and the candidates that were scored keep the same scores.
"""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from nfex_core.advisor.advisor import Advisor
from nfex_core.advisor.bounds import score_bounds
from nfex_core.advisor.scoring import FrameState, measured_accuracy
from nfex_core.kg import KnowledgeGraph

CONTEXTS = [{"agent": "car"}, {"agent": "car", "budget_ms": 20}, {"agent": "drone"}, {"agent": "human"},
            {"agent": "car", "light": "dark"}]


def frames(data_dir: Path) -> dict[str, list[np.ndarray]]:
    kitti = sorted((data_dir / "kitti/sequences/00/image_0").glob("*.png"))[40:44]
    euroc = sorted((data_dir / "euroc").rglob("cam0/data/*.png"))[:3]
    return {name: [cv2.imread(str(p), cv2.IMREAD_GRAYSCALE) for p in paths] for name, paths in (("kitti", kitti), ("euroc", euroc))}


@pytest.mark.parametrize("neural", ["selectornet", "both", "symbolic"])  # both: what the gate leaves on
def test_pruned_scoring_answers_as_exhaustive_scoring(shipped_kg: KnowledgeGraph, data_dir: Path, neural: str) -> None:
    pruned, exhaustive = Advisor(shipped_kg, neural=neural), Advisor(shipped_kg, neural=neural, exhaustive_scoring=True)
    skipped = 0
    for name, stream in frames(data_dir).items():
        for context in CONTEXTS:
            states: list[FrameState | None] = [None, None]
            for i, image in enumerate(stream):
                a = pruned.select(context, image, states[0])
                b = exhaustive.select(context, image, states[1])
                states = [a.state, b.state]
                where = f"{name} frame {i} {context}"
                assert (a.extractor, a.params, a.mode) == (b.extractor, b.params, b.mode), where
                assert all(c.score is not None for c in b.candidates if c.evidence.not_scored is None), where
                exact = {c.extractor: c for c in b.candidates}
                snap = exhaustive.snapshot()
                decision = snap.table.decide({e.dimension: e.value for e in b.context})
                accuracy = measured_accuracy(decision, exact)
                weight = sum(w.value for w in decision.weights.values())
                for c in b.candidates:  # the ceiling is sound: no score exceeds it
                    if c.evidence.f_metrics is not None:
                        top = score_bounds(decision, snap.vocab.metrics, c.metrics, c.extractor, accuracy.get(c.extractor, 0.0), weight)[1]
                        assert c.evidence.f_metrics + weight * (c.evidence.measured_accuracy or 0.0) <= top + 1e-9, where
                for c in a.candidates:
                    if c.score is not None and c.evidence.not_scored is None and a.mode == "metrics":
                        assert c.score == pytest.approx(exact[c.extractor].score, abs=1e-12), where
                        assert c.metrics == exact[c.extractor].metrics, where
                    if c.score is None:
                        assert c.evidence.not_scored, where  # every unscored candidate says why
                skipped += sum(1 for c in a.candidates if c.keypoints is None) - sum(1 for c in b.candidates if c.keypoints is None)
    assert skipped > 0, "no candidate was ever skipped: the bounds never decided"


def test_a_skipped_candidate_is_extracted_on_the_next_frame_when_needed(shipped_kg: KnowledgeGraph, data_dir: Path) -> None:
    """A candidate skipped on frame t is owed to frame t+1's temporal metrics: extracted there from frame t's
    scoring copy with frame t's Θ′, its features equal a direct extraction."""
    images = frames(data_dir)["kitti"][:2]
    advisor = Advisor(shipped_kg, neural="selectornet")
    first = advisor.select({"agent": "car"}, images[0])
    assert first.state is not None and first.state.owed, "SelectorNet's choice was not settled by bounds here"
    x, params = next(iter(first.state.owed.items()))
    registry = advisor.snapshot().registry
    got = first.state.previous(x, first.state.image.shape, registry)
    assert got is not None and x in first.state.features
    direct = registry.extract(x, first.state.image, params)
    np.testing.assert_array_equal(got[0].xy, direct.xy)
    assert first.state.previous(x, (1, 1), registry) is None  # another scoring size: no temporal metrics


def test_a_bound_decides_only_with_the_margin(shipped_kg: KnowledgeGraph, data_dir: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """``bounded_choice`` settles only when the leader's lower bound beats every other upper bound by LOGIT_MARGIN;
    the bounds themselves are the network's (tested in test_selectornet); here they are set to what the test needs."""
    from nfex_core.neural import serve

    image = frames(data_dir)["kitti"][0]
    advisor = Advisor(shipped_kg, neural="selectornet")
    nn = advisor.neural.step(shipped_kg.vocabulary())
    assert nn.selectornet and nn.model is not None and nn.model.selectornet is not None
    nn.prepare({"agent": "car"}, None)
    names = list(nn.model.inputs.extractors)
    known = sorted(nn.selector_extractors)
    leader, rival = known[0], known[1]

    def bounds(gap: float):  # type: ignore[no-untyped-def]
        lo, hi = np.full(len(names), -50.0), np.full(len(names), -40.0)
        lo[names.index(leader)], hi[names.index(leader)] = 1.0, 2.0
        lo[names.index(rival)], hi[names.index(rival)] = -5.0, 1.0 - gap
        return lambda *_: (lo, hi)

    unknown = {x: ("texturedness",) for x in known}
    for gap, settles in ((serve.LOGIT_MARGIN / 2, False), (0.0, False), (-0.5, False), (serve.LOGIT_MARGIN * 2, True)):
        monkeypatch.setattr(type(nn.model.selectornet), "logit_bounds", bounds(gap))
        got = nn.bounded_choice(image, {}, unknown, known)
        assert (got is not None) == settles, gap
        if got is not None:
            assert got.extractor == leader and got.allowed and 0.0 < got.p_low < 1.0
    got = nn.bounded_choice(image, {}, unknown, [rival])  # the leader is not a candidate: the network declines
    assert got is not None and not got.allowed
