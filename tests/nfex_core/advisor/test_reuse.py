"""A stream's decision reused while the context and the frame statistics do not move (advisor/reuse.py)."""
from __future__ import annotations

from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pytest

from nfex_core.advisor.advisor import Advisor
from nfex_core.advisor.pipeline import STAGES
from nfex_core.advisor.reuse import ReuseTerms, moved
from nfex_core.kg import KnowledgeGraph

FRAMES = "kitti/sequences/00/image_0"


def allow_reuse(kg: KnowledgeGraph, frames: int, change: float = 0.05) -> None:
    kg.update(f"""PREFIX nfex: <https://w3id.org/nfex#>
        PREFIX xsd: <http://www.w3.org/2001/XMLSchema#>
        DELETE {{ nfex:decisionReuseFrames nfex:value ?f . nfex:decisionReuseChange nfex:value ?c }}
        INSERT {{ nfex:decisionReuseFrames nfex:value {frames} . nfex:decisionReuseChange nfex:value "{change}"^^xsd:double }}
        WHERE {{ nfex:decisionReuseFrames nfex:value ?f . nfex:decisionReuseChange nfex:value ?c }}""", author="test")


def stream(advisor: Advisor, images: list[np.ndarray], context: dict[str, str]) -> list:  # type: ignore[type-arg]
    out, state = [], None
    for image in images:
        sel = advisor.select(context, image, state)
        out.append(sel)
        state = sel.state
    return out


def test_the_shipped_graph_scores_every_frame(kg: KnowledgeGraph, data_dir: Path) -> None:
    assert ReuseTerms.load(kg).frames == 0
    image = cv2.imread(str(sorted((data_dir / FRAMES).glob("*.png"))[40]), cv2.IMREAD_GRAYSCALE)
    assert [s.reused for s in stream(Advisor(kg), [image] * 3, {"agent": "car"})] == [0, 0, 0]


def test_a_still_frame_reuses_the_decision_at_most_n_frames(kg: KnowledgeGraph, data_dir: Path) -> None:
    allow_reuse(kg, 2)
    assert ReuseTerms.load(kg) == ReuseTerms(2, 0.05, 30, 2, 0.6)
    image = cv2.imread(str(sorted((data_dir / FRAMES).glob("*.png"))[40]), cv2.IMREAD_GRAYSCALE)
    out = stream(Advisor(kg), [image] * 5, {"agent": "drone"})
    assert [s.reused for s in out] == [0, 1, 2, 0, 1]
    first = out[0]
    for s in out[1:3]:
        assert (s.extractor, s.params, s.mode, s.candidates) == (first.extractor, first.params, first.mode, first.candidates)
        assert list(s.timings_ms) == [*STAGES, "total"]
        assert [s.timings_ms[k] for k in ("params", "budget", "verification")] == [0.0, 0.0, 0.0]  # the decision was carried
        assert s.as_dict()["reused"] == s.reused
    assert list(out[3].timings_ms) == [*STAGES, "total"] and out[3].timings_ms["params"] > 0


def test_a_frame_that_moved_or_a_new_context_is_scored(kg: KnowledgeGraph, data_dir: Path) -> None:
    allow_reuse(kg, 10)
    image = cv2.imread(str(sorted((data_dir / FRAMES).glob("*.png"))[40]), cv2.IMREAD_GRAYSCALE)
    darker = (image * 0.5).astype(np.uint8)  # brightness halves: a statistic moves by far more than 5 %
    advisor = Advisor(kg)
    first = advisor.select({"agent": "drone"}, image)
    assert advisor.select({"agent": "drone"}, darker, first.state).reused == 0
    assert advisor.select({"agent": "drone", "scene": "indoor"}, image, first.state).reused == 0
    assert advisor.select({"agent": "drone"}, image, first.state).reused == 1


def test_moved_is_the_largest_relative_change() -> None:
    before, after = {"a": 1.0, "b": 10.0, "c": 0.0}, {"a": 1.1, "b": 10.0, "c": 0.0}
    assert moved(before, after, ("a", "b", "c")) == pytest.approx(0.1 / 1.1)
    assert moved({"f": 0.001}, {"f": 0.002}, ("f",)) == pytest.approx(0.001)  # a fraction near 0: absolute
    assert moved(before, before, ("a", "b", "c")) == 0.0
    assert moved(before, after, ()) == 0.0


def session_frames(kg: KnowledgeGraph, n: int) -> None:
    kg.update(f"""PREFIX nfex: <https://w3id.org/nfex#>
        DELETE {{ nfex:sessionDecisionFrames nfex:value ?f }} INSERT {{ nfex:sessionDecisionFrames nfex:value {n} }}
        WHERE {{ nfex:sessionDecisionFrames nfex:value ?f }}""", author="test")


def test_a_session_reuses_its_decision_while_the_evidence_holds(kg: KnowledgeGraph, data_dir: Path) -> None:
    """Consecutive KITTI frames in a session: the decision of the first frame serves nfex:sessionDecisionFrames
    frames, each reused frame extracting α* alone (counted by the registry), then the session re-decides."""
    assert ReuseTerms.load(kg).session == 30  # shipped: rules/pruning/thresholds.ttl
    session_frames(kg, 4)
    images = [cv2.imread(str(p), cv2.IMREAD_GRAYSCALE) for p in sorted((data_dir / FRAMES).glob("*.png"))[40:49]]
    advisor = Advisor(kg)
    registry = advisor.snapshot().registry
    out, state, work = [], None, []
    for image in images:
        before = registry.work.totals()[0]
        sel = advisor.select({"agent": "car", "light": "bright", "texture": "high", "motion": "slow"}, image, state, session=True)
        work.append(registry.work.totals()[0] - before)
        if sel.reused:  # before the next frame extracts what it owes from this one
            assert sel.state is not None and set(sel.state.features) == {sel.extractor}
        out.append(sel)
        state = sel.state
    assert [s.reused for s in out] == [0, 1, 2, 3, 0, 1, 2, 3, 0]
    for s, n in zip(out, work, strict=True):
        assert s.scoring is not None and s.scoring.extractions == n
        if s.reused:  # the steady state: one configuration per frame, α*, and the decision of the last scored frame
            assert n == 1 and s.scoring.outcome == "unscored" and "verification verdict" in s.scoring.reason
    assert out[1].extractor == out[0].extractor and out[1].params == out[0].params
    # a plain stream (not a session) keeps scoring every frame: the shipped nfex:decisionReuseFrames is 0
    assert advisor.select({"agent": "car"}, images[1], out[0].state).reused == 0


def test_a_session_re_decides_when_the_verdict_or_the_context_moves(kg: KnowledgeGraph, data_dir: Path) -> None:
    images = [cv2.imread(str(p), cv2.IMREAD_GRAYSCALE) for p in sorted((data_dir / FRAMES).glob("*.png"))[40:43]]
    advisor = Advisor(kg)
    ctx = {"agent": "drone", "light": "bright", "texture": "high", "motion": "slow"}
    first = advisor.select(ctx, images[0], session=True)
    assert advisor.select(ctx, images[1], first.state, session=True).reused == 1
    assert advisor.select(ctx, images[1], first.state, session=True, verdict_held=False).reused == 0
    assert advisor.select({**ctx, "light": "dark"}, images[1], first.state, session=True).reused == 0


def test_a_session_re_decides_once_a_changed_estimate_holds(kg: KnowledgeGraph, data_dir: Path) -> None:
    """Light is estimated: a frame that reads as dark once keeps the decision (nfex:sessionConditionFrames = 2),
    the second dark frame in a row re-decides."""
    assert ReuseTerms.load(kg).hold == 2
    image = cv2.imread(str(sorted((data_dir / FRAMES).glob("*.png"))[40]), cv2.IMREAD_GRAYSCALE)
    dark = (image * 0.15).astype(np.uint8)
    advisor = Advisor(kg)
    ctx = {"agent": "drone", "texture": "high", "motion": "slow"}
    first = advisor.select(ctx, image, session=True)
    light = {e.dimension: e for e in first.context}["light"]
    once = advisor.select(ctx, dark, first.state, session=True)
    assert {e.dimension: e for e in once.context}["light"].value != light.value, "the darker frame reads the same"
    assert once.reused == 1 and once.scoring is not None and "differed for 1 frame" in once.scoring.reason
    assert advisor.select(ctx, dark, once.state, session=True).reused == 0
    back = advisor.select(ctx, image, once.state, session=True)  # the flicker ends: the decision stands
    assert back.reused == 2


def dead_band(kg: KnowledgeGraph, confidence: float) -> None:
    kg.update(f"""PREFIX nfex: <https://w3id.org/nfex#>
        PREFIX xsd: <http://www.w3.org/2001/XMLSchema#>
        DELETE {{ nfex:sessionConditionConfidence nfex:value ?c }}
        INSERT {{ nfex:sessionConditionConfidence nfex:value "{confidence}"^^xsd:double }}
        WHERE {{ nfex:sessionConditionConfidence nfex:value ?c }}""", author="test")


def session_decisions(advisor: Advisor, images: list[np.ndarray], context: dict[str, str]) -> list[int]:
    """The frames of a session stream that were decided (not reused)."""
    out, state = [], None
    for i, image in enumerate(images):
        sel = advisor.select(context, image, state, session=True)
        state = sel.state
        if sel.reused == 0:
            out.append(i)
    return out


def test_an_estimate_inside_the_dead_band_keeps_a_session_decision(kg: KnowledgeGraph, data_dir: Path) -> None:
    """90 consecutive KITTI 00 frames of a car session: the texture and reflectance estimates flip at their thresholds
    with confidences near 0.5; inside the dead band (nfex:sessionConditionConfidence, shipped 0.6) they keep the
    decision, so the session re-decides only on a firm change that holds and every nfex:sessionDecisionFrames."""
    assert ReuseTerms.load(kg).firm == 0.6  # shipped: rules/pruning/thresholds.ttl
    images = [cv2.imread(str(p), cv2.IMREAD_GRAYSCALE) for p in sorted((data_dir / FRAMES).glob("*.png"))[:90]]
    banded = session_decisions(Advisor(kg, neural="symbolic"), images, {"agent": "car"})
    dead_band(kg, 0.0)
    assert ReuseTerms.load(kg).firm == 0.0
    every = session_decisions(Advisor(kg, neural="symbolic"), images, {"agent": "car"})
    # frame 16: an estimate beyond its band for two frames; 46 and 76: the decision served 30 frames
    assert banded == [0, 16, 46, 76, 78]
    assert every == [0, 2, 8, 10, 12, 21, 27, 57, 60, 82, 86, 88]  # texture high ⇄ medium at confidence ≈ 0.5


def verified_sessions(kg: KnowledgeGraph, data_dir: Path) -> tuple[Advisor, Any, list[np.ndarray]]:
    """The shipped verification program applied, a session decision due every 4 frames, a symbolic advisor, its
    registry (whose work count the tests read) and five consecutive KITTI 00 frames."""
    from nfex_core.rules.dsl import programs

    text = (Path(__file__).resolve().parents[3] / "rules" / "verification" / "verification.nfex").read_text()
    _, g = programs.compile_text(text, kg.vocabulary(), name="verification")
    programs.apply(kg, g, "verification", author="test")
    session_frames(kg, 4)
    images = [cv2.imread(str(p), cv2.IMREAD_GRAYSCALE) for p in sorted((data_dir / FRAMES).glob("*.png"))[40:45]]
    advisor = Advisor(kg, neural="symbolic")
    return advisor, advisor.snapshot().registry, images


def test_a_verified_session_due_again_keeps_its_proposals_order_while_the_pairs_confirm_it(
        shipped_kg: KnowledgeGraph, data_dir: Path) -> None:
    """Under the verification program, a session's decision due again only because it served
    nfex:sessionDecisionFrames frames (its verdicts held, its estimate unchanged) scores α* alone; where α* is the
    same, the later proposals keep the order the decision scored them in, and the answer says so. A verdict that
    did not hold scores the first proposals in exact order again, extracting more (counted)."""
    advisor, registry, images = verified_sessions(shipped_kg, data_dir)

    def run(held_at_last: bool) -> tuple[list, int]:  # type: ignore[type-arg]
        out, state, n = [], None, 0
        for k, image in enumerate(images):
            before = registry.work.totals()[0]
            sel = advisor.select({"agent": "car"}, image, state, session=True,
                                 verdict_held=held_at_last or k < len(images) - 1)
            n = registry.work.totals()[0] - before
            out.append(sel)
            state = sel.state
        return out, n

    out, work = run(True)
    assert [s.reused for s in out] == [0, 1, 2, 3, 0]
    first, due = out[0], out[4]
    assert due.verification.active and due.verification.max_tries >= 2
    assert due.extractor == first.extractor
    assert [p.extractor for p in due.proposals] == [p.extractor for p in first.proposals]
    assert due.scoring is not None and "the order the decision of 4 frame(s) ago scored them" in due.scoring.reason
    again, work_again = run(False)
    assert again[4].reused == 0 and again[4].scoring is not None and "scored them" not in again[4].scoring.reason
    assert work < work_again


def test_a_decision_due_again_whose_alpha_changed_scores_every_proposal_and_counts_all_it_took(
        shipped_kg: KnowledgeGraph, data_dir: Path) -> None:
    """Where the single answer of a decision due again names another α* than the decision's, the frame is scored for
    every proposal in exact order, and ``scoring.extractions`` counts both passes (the registry's own count)."""
    from dataclasses import replace

    advisor, registry, images = verified_sessions(shipped_kg, data_dir)
    state = None
    for image in images[:4]:
        state = advisor.select({"agent": "car"}, image, state, session=True).state
    assert state is not None and state.decided is not None and state.decided.reused == 3
    other = next(c.extractor for c in state.decided.selection.candidates if c.extractor != state.decided.selection.extractor)
    state = replace(state, decided=replace(state.decided, selection=replace(state.decided.selection, extractor=other)))
    before = registry.work.totals()
    sel = advisor.select({"agent": "car"}, images[4], state, session=True)
    after = registry.work.totals()
    assert sel.reused == 0 and sel.scoring is not None and "came out other than" in sel.scoring.reason
    assert (sel.scoring.extractions, sel.scoring.pixels) == (after[0] - before[0], after[1] - before[1])
