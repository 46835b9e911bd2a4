"""How much a selection extracts, counted (not timed) through the extractor registry's own counter.

For fixed real frames and contexts the number of extractions (and pixels) per select is asserted, so a change
that makes the frame path extract more fails here instead of waiting for a bench run: a context whose α* the
bounds settle (advisor/bounds.py) extracts nothing — over the sound [0, 1] per metric, or within the metric ranges
measured on KITTI 00 (advisor/ranges.py) —; a drone's two unmeasured candidates are both extracted; every candidate
is listed, with the reason it was not extracted.
"""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from nfex_core.advisor.advisor import Advisor
from nfex_core.advisor.bounds import next_extraction, score_bounds
from nfex_core.advisor.scoring import measured_accuracy
from nfex_core.kg import KnowledgeGraph
from nfex_core.rules.dsl import programs


def kitti(data_dir: Path, i: int = 40) -> np.ndarray:
    image = cv2.imread(str(sorted((data_dir / "kitti/sequences/00/image_0").glob("*.png"))[i]), cv2.IMREAD_GRAYSCALE)
    assert image is not None
    return image


def counted(advisor: Advisor, context: dict[str, object], image: np.ndarray, previous: object = None) -> tuple[object, int, int]:
    """The selection and the extractions and pixels the registry counted while it was made."""
    registry = advisor.snapshot().registry
    n0, p0 = registry.work.totals()
    sel = advisor.select(context, image, previous)  # type: ignore[arg-type]
    n1, p1 = registry.work.totals()
    assert sel.scoring is not None and (sel.scoring.extractions, sel.scoring.pixels) == (n1 - n0, p1 - p0)
    return sel, n1 - n0, p1 - p0


def test_a_context_whose_bounds_settle_extracts_nothing(shipped_kg: KnowledgeGraph, data_dir: Path) -> None:
    """Fast motion: SIFT's measured accuracy puts its least score above every other candidate's best."""
    advisor = Advisor(shipped_kg, neural="symbolic")
    sel, n, pixels = counted(advisor, {"motion": "fast"}, kitti(data_dir))
    assert (n, pixels) == (0, 0) and sel.scoring.outcome == "settled"  # type: ignore[attr-defined]
    assert sel.extractor == "SIFT" and "settled by bounds" in sel.candidates[0].evidence.not_scored  # type: ignore[attr-defined]
    assert sel.as_dict()["scoring"]["outcome"] == "settled"  # type: ignore[attr-defined]
    exhaustive = Advisor(shipped_kg, neural="symbolic", exhaustive_scoring=True).select({"motion": "fast"}, kitti(data_dir))
    assert exhaustive.extractor == "SIFT" and exhaustive.scoring is not None and exhaustive.scoring.outcome == "scored"


def test_a_car_whose_preference_settles_the_choice_extracts_nothing(shipped_kg: KnowledgeGraph, data_dir: Path) -> None:
    """A car context plus a frame, where an expert's preference for SIFT puts its least score above every other
    candidate's most: no extraction at all, and the answer says why."""
    _, g = programs.compile_text('program sure\nprefer SIFT by 4 when agent is car because "test: SIFT for cars"',
                                 shipped_kg.vocabulary(), name="sure")
    programs.apply(shipped_kg, g, "sure", author="test")
    advisor = Advisor(shipped_kg, neural="symbolic")
    sel, n, _ = counted(advisor, {"agent": "car"}, kitti(data_dir))
    assert n == 0 and sel.extractor == "SIFT" and sel.scoring.outcome == "settled"  # type: ignore[attr-defined]
    assert all(c.keypoints is None and c.evidence.not_scored for c in sel.candidates)  # type: ignore[attr-defined]


def without_ranges(kg: KnowledgeGraph) -> None:
    """The graph without its measured metric ranges: the bounds are the sound [0, 1] per metric alone."""
    kg.update("PREFIX nfex: <https://w3id.org/nfex#> DELETE WHERE { ?r a nfex:MetricRange ; ?p ?o }", author="test")


@pytest.mark.parametrize("frame", [0, 40, 120])
def test_a_car_settled_by_the_measured_ranges_extracts_nothing(shipped_kg: KnowledgeGraph, data_dir: Path, frame: int) -> None:
    """A car's SIFT leads XFEAT by its measured accuracy; within the metric ranges measured on KITTI 00
    (ontology/measurements/metric-ranges.ttl) no other candidate can reach SIFT's least score: nothing is extracted,
    and the answer says the bounds rest on the measured ranges. Exhaustive scoring picks the same α*."""
    advisor = Advisor(shipped_kg, neural="symbolic")
    sel, n, pixels = counted(advisor, {"agent": "car"}, kitti(data_dir, frame))
    assert (n, pixels) == (0, 0) and sel.extractor == "SIFT" and sel.scoring.outcome == "settled"  # type: ignore[attr-defined]
    assert "ranges measured on KITTI 00" in sel.candidates[0].evidence.not_scored  # type: ignore[attr-defined]
    exhaustive = Advisor(shipped_kg, neural="symbolic", exhaustive_scoring=True).select({"agent": "car"}, kitti(data_dir, frame))
    assert exhaustive.extractor == "SIFT"


def test_a_car_extracts_what_can_change_the_answer_over_the_sound_bounds(shipped_kg: KnowledgeGraph, data_dir: Path) -> None:
    """Without the measured ranges a car's choice needs SIFT's metrics, and at most one rival's — not six extractions."""
    without_ranges(shipped_kg)
    advisor = Advisor(shipped_kg, neural="symbolic")
    sel, n, pixels = counted(advisor, {"agent": "car"}, kitti(data_dir))
    assert sel.extractor == "SIFT" and sel.scoring.outcome == "scored"  # type: ignore[attr-defined]
    assert 1 <= n <= 2 and pixels == n * sel.state.image.size  # type: ignore[attr-defined]
    assert "whatever their metrics" in sel.scoring.reason  # type: ignore[attr-defined]


def test_an_evaluation_holding_out_kitti_00_does_not_use_its_ranges(shipped_kg: KnowledgeGraph, data_dir: Path) -> None:
    """The ranges were measured on KITTI 00: an advisor whose evidence scope holds KITTI 00 out bounds over [0, 1]."""
    from nfex_core.kg.rdf.identity import sequence_iri
    from nfex_core.kg.scope import EvidenceScope

    scope = EvidenceScope(exclude_sequences=frozenset({str(sequence_iri("kitti", "00"))}))
    advisor = Advisor(shipped_kg, neural="symbolic", scope=scope)
    assert not advisor.snapshot().ranges and Advisor(shipped_kg, neural="symbolic").snapshot().ranges
    sel, n, _ = counted(advisor, {"agent": "car", "budget_ms": 20}, kitti(data_dir))
    assert n >= 1 and "whatever" in (sel.scoring.reason + str(sel.candidates[0].evidence.not_scored))  # type: ignore[attr-defined]


def test_ranges_a_frame_contradicts_fall_back_to_the_sound_bounds(shipped_kg: KnowledgeGraph, data_dir: Path) -> None:
    """A range the frame's extracted metrics fall outside of is not evidence for that frame: the request goes on
    over [0, 1] per metric and gives exhaustive scoring's α*."""
    shipped_kg.update("""PREFIX nfex: <https://w3id.org/nfex#>
        PREFIX xsd: <http://www.w3.org/2001/XMLSchema#>
        DELETE { ?r nfex:rangeLow ?lo ; nfex:rangeHigh ?hi }
        INSERT { ?r nfex:rangeLow "0.999"^^xsd:double ; nfex:rangeHigh "1.0"^^xsd:double }
        WHERE { ?r nfex:rangeExtractor nfex:ORB ; nfex:rangeMetric nfex:texturedness ; nfex:rangeLow ?lo ; nfex:rangeHigh ?hi
                FILTER NOT EXISTS { ?r nfex:relativeTo ?y } }""", author="test")
    context = {"agent": "drone"}
    sel, n, _ = counted(Advisor(shipped_kg, neural="symbolic"), context, kitti(data_dir))
    exhaustive = Advisor(shipped_kg, neural="symbolic", exhaustive_scoring=True).select(context, kitti(data_dir))
    assert n == 2 and sel.extractor == exhaustive.extractor and "whatever their metrics" in sel.scoring.reason  # type: ignore[attr-defined]


@pytest.mark.parametrize("frame", [0, 40, 120])
def test_a_budgeted_car_extracts_nothing(shipped_kg: KnowledgeGraph, data_dir: Path, frame: int) -> None:
    """Under 20 ms a car keeps ORB and ORB_GRID; ORB_GRID's measured accuracy puts its least score, within the
    measured ranges, above ORB's most: nothing is extracted (over the sound bounds ORB is, and settles ORB_GRID)."""
    advisor = Advisor(shipped_kg, neural="symbolic")
    sel, n, _ = counted(advisor, {"agent": "car", "budget_ms": 20}, kitti(data_dir, frame))
    assert n == 0 and sel.extractor == "ORB_GRID" and sel.scoring.outcome == "settled"  # type: ignore[attr-defined]
    without_ranges(shipped_kg)
    sel, n, _ = counted(Advisor(shipped_kg, neural="symbolic"), {"agent": "car", "budget_ms": 20}, kitti(data_dir, frame))
    assert n <= 1 and sel.extractor == "ORB_GRID" and sel.scoring.outcome == "settled"  # type: ignore[attr-defined]


def test_a_budgeted_drone_extracts_only_its_candidates(shipped_kg: KnowledgeGraph, data_dir: Path) -> None:
    """A drone's 20 ms budget leaves ORB and ORB_GRID, neither with measured accuracy under E: on KITTI 00 either
    wins on many KITTI 00 frames, their measured paired ranges overlap more than their scores
    differ, so both are extracted, once each, and nothing else."""
    advisor = Advisor(shipped_kg, neural="symbolic")
    sel, n, _ = counted(advisor, {"agent": "drone"}, kitti(data_dir))
    assert n == len(sel.candidates) == 2  # type: ignore[attr-defined]


def test_bounds_contain_every_score_and_the_order_settles(shipped_kg: KnowledgeGraph, data_dir: Path) -> None:
    """Every candidate's exhaustively scored score lies within its bounds, and next_extraction stops exactly when
    no other candidate can reach the leader."""
    exhaustive = Advisor(shipped_kg, neural="symbolic", exhaustive_scoring=True)
    for context in ({"agent": "car"}, {"agent": "drone"}, {"agent": "human", "light": "dark"}):
        sel = exhaustive.select(context, kitti(data_dir))
        snap = exhaustive.snapshot()
        decision = snap.table.decide({e.dimension: e.value for e in sel.context})
        accuracy = measured_accuracy(decision, [c.extractor for c in sel.candidates])
        weight = sum(w.value for w in decision.weights.values())
        for c in sel.candidates:
            low, high = score_bounds(decision, snap.vocab.metrics, c.metrics, c.extractor, accuracy.get(c.extractor, 0.0), weight)
            assert c.score is not None and low - 1e-9 <= c.score <= high + 1e-9, (context, c.extractor)
        exact = {c.extractor: (c.score, c.score) for c in sel.candidates}
        assert next_extraction(exact, [], {}) is None


def test_next_extraction_prefers_what_narrows_the_gap_per_ms() -> None:
    intervals = {"A": (6.5, 10.0), "B": (4.8, 8.3), "C": (4.6, 8.1), "D": (0.0, 3.5)}
    # the leader narrows the gap to every rival at once: worth its cost unless it is far dearer
    assert next_extraction(intervals, intervals, {"A": 4.0, "B": 4.0, "C": 1.0, "D": 0.1}) == "A"
    assert next_extraction(intervals, intervals, {"A": 400.0, "B": 4.0, "C": 1.0, "D": 0.1}) == "B"
    # D cannot reach A's least score: never extracted; settled once A's score passes every high bound
    assert next_extraction({**intervals, "A": (9.0, 9.0)}, ["B", "C", "D"], {}) is None
    assert next_extraction({"A": (6.5, 10.0), "D": (0.0, 3.5)}, ["A", "D"], {}) is None


def test_a_verified_pair_scores_its_proposals_in_exact_order(shipped_kg: KnowledgeGraph, data_dir: Path) -> None:
    """With the verification program in force the first max_tries proposals are those of scoring every candidate,
    in the same order; candidates that cannot reach them are not extracted: on these frames, within the measured
    metric ranges, exactly the proposals tried (3 for a car, the 2 candidates under 20 ms) and no more."""
    text = (Path(__file__).resolve().parents[3] / "rules" / "verification" / "verification.nfex").read_text()
    _, g = programs.compile_text(text, shipped_kg.vocabulary(), name="verification")
    programs.apply(shipped_kg, g, "verification", author="test")
    pruned = Advisor(shipped_kg, neural="symbolic")
    exhaustive = Advisor(shipped_kg, neural="symbolic", exhaustive_scoring=True)
    images = [kitti(data_dir, i) for i in (40, 41, 42)]
    counts: dict[str, list[int]] = {}
    for context in ({"agent": "car"}, {"agent": "car", "budget_ms": 20}, {"agent": "car", "scene": "outdoor"}):
        states: list[object] = [None, None]
        for image in images:
            a, n, _ = counted(pruned, context, image, states[0])
            counts.setdefault(str(context), []).append(n)
            b = exhaustive.select(context, image, states[1])  # type: ignore[arg-type]
            states = [a.state, b.state]  # type: ignore[attr-defined]
            assert a.verification.active and a.verification.max_tries >= 2  # type: ignore[attr-defined]
            assert [(p.extractor, p.params, p.score) for p in a.proposals] == \
                [(p.extractor, p.params, p.score) for p in b.proposals], context  # type: ignore[attr-defined]
            assert b.scoring is not None and n <= b.scoring.extractions
    assert counts == {"{'agent': 'car'}": [3, 3, 3], "{'agent': 'car', 'budget_ms': 20}": [2, 2, 2],
                      "{'agent': 'car', 'scene': 'outdoor'}": [3, 3, 3]}
