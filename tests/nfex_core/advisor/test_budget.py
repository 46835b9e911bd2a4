"""A per-frame budget flips the choice, citing the budget rule; Θ′ fitted to it; defaults, compute classes, fallback."""
from __future__ import annotations

from pathlib import Path

import cv2
import pytest

from nfex_core.advisor import Advisor
from nfex_core.errors import BadInput, UnknownName
from nfex_core.kg import KnowledgeGraph
from nfex_core.rules.dsl import programs

from ..evidence.test_cost import add_rows, law, row

N = "https://w3id.org/nfex#"
CTX = {"agent": "car", "motion": "slow", "scene": "outdoor"}


@pytest.fixture
def measured(bare_kg: KnowledgeGraph) -> KnowledgeGraph:
    kg = bare_kg
    """SIFT accurate and slow; ORB fast, 7.5× SIFT's ATE (so the relative-ATE rule prunes it without a
    budget), its cost following ``law`` (features, levels)."""
    rows = [row(kg, "SIFT", {}, 300.0, f"sift{i}", ate=0.02) for i in range(3)]
    for i, (nf, nl) in enumerate((nf, nl) for nf in (500, 1000, 2000) for nl in (4, 8)):
        p = {"nfeatures": nf, "nlevels": nl}
        rows.append(row(kg, "ORB", p, law(p, 1241, 376), f"orb{i}", ate=0.15))
    add_rows(kg, rows)
    return kg


def _budget_citation(sel, x: str):  # type: ignore[no-untyped-def]
    [p] = [p for p in sel.pruned if p.extractor == x]
    return next(c for c in p.because if c.kind == "budget")


def test_a_budget_flips_the_context_only_choice_and_cites_the_rule(measured: KnowledgeGraph) -> None:
    advisor = Advisor(measured)
    free = advisor.select(CTX)
    assert free.extractor == "SIFT" and free.budget is None
    tight = advisor.select(CTX, budget_ms=20)
    assert tight.extractor != "SIFT"
    cite = _budget_citation(tight, "SIFT")
    assert cite.rule == N + "rule_budget" and cite.label == "Expected extraction cost over the budget"
    assert "300.0 ms" in cite.reason and "20 ms" in cite.reason and "1241×376" in cite.reason
    assert tight.budget is not None and tight.budget["source"] == "given"
    assert tight.budget["size_source"].startswith("assumed")  # no frame: the size most measurements had
    for c in tight.candidates:
        assert c.evidence.expected_ms is None or c.evidence.expected_ms <= 20
    assert advisor.select(CTX, budget_ms=1000).extractor == "SIFT"  # a larger budget flips it back
    assert advisor.select({**CTX, "budget_ms": "20"}).extractor == tight.extractor  # the budget as a context key


def test_theta_is_fitted_into_the_budget_before_pruning(measured: KnowledgeGraph) -> None:
    sel = Advisor(measured).select(CTX, budget_ms=12)
    orb = next(c for c in sel.candidates if c.extractor == "ORB")
    fitted = [a for a in orb.adjustments if any(c.kind == "budget" for c in a.citations)]
    assert [a.parameter for a in fitted] == ["nfeatures"]
    assert fitted[0].after < fitted[0].before
    assert fitted[0].citations[0].rule == N + "rule_budget_fit"
    assert orb.params["nfeatures"] == fitted[0].after
    assert orb.evidence.cost.source == "model" and orb.evidence.expected_ms <= 12
    assert law(orb.params, 1241, 376) <= 12  # the fitted Θ′ meets the budget under the true law
    assert "SIFT" in {p.extractor for p in sel.pruned}


def test_what_the_relative_accuracy_rule_pruned_is_re_judged_among_affordable_extractors(measured: KnowledgeGraph) -> None:
    advisor = Advisor(measured)
    free = advisor.select(CTX)
    [orb] = [p for p in free.pruned if p.extractor == "ORB"]
    assert {c.rule for c in orb.because} == {N + "rule_measured_relative_ate"}  # 0.15 m > 4 × SIFT's 0.02 m
    tight = advisor.select(CTX, budget_ms=20)
    assert "ORB" in {c.extractor for c in tight.candidates} and "ORB" not in {p.extractor for p in tight.pruned}
    assert any(w.startswith("ORB: re-admitted") for w in tight.warnings)


def test_agent_default_budget_and_compute_class(measured: KnowledgeGraph) -> None:
    advisor = Advisor(measured)
    drone = advisor.select({"agent": "drone"})
    assert drone.budget is not None and drone.budget["ms"] == 20 and drone.budget["source"] == "agent default (drone)"
    assert _budget_citation(drone, "SIFT").rule == N + "rule_budget"
    assert advisor.select({"agent": "car"}).budget is None  # a car has no default budget
    ref = advisor.select(CTX, budget_ms=40)
    slow = advisor.select(CTX, budget_ms=40, compute="embedded")
    assert slow.budget is not None and slow.budget["factor"] == 4.0
    orb_ref = next(c for c in ref.candidates if c.extractor == "ORB")
    orb_slow = next(c for c in slow.candidates if c.extractor == "ORB")
    assert not any(c.kind == "budget" for a in orb_ref.adjustments for c in a.citations)  # fits as it is
    assert orb_slow.evidence.expected_ms == pytest.approx(4 * law(orb_slow.params, 1241, 376), rel=1e-3)
    assert orb_slow.evidence.expected_ms <= 40 < 4 * law(orb_ref.params, 1241, 376)
    assert (orb_slow.params["nlevels"], orb_slow.params["nfeatures"]) < (orb_ref.params["nlevels"], orb_ref.params["nfeatures"])
    with pytest.raises(UnknownName, match="reference"):
        advisor.select(CTX, budget_ms=20, compute="mainframe")
    with pytest.raises(BadInput):
        advisor.select(CTX, budget_ms=-1)


def test_nothing_within_budget_falls_back_to_the_cheapest_with_a_warning(measured: KnowledgeGraph) -> None:
    sel = Advisor(measured).select(CTX, budget_ms=0.5)
    assert sel.warnings and "running the cheapest" in sel.warnings[-1]
    assert sel.extractor in {"ORB", "ORB_GRID"}  # the measured extractors with the lowest floor
    chosen = sel.candidates[0]
    assert chosen.evidence.expected_ms > 0.5 and any(c.kind == "budget" for a in chosen.adjustments for c in a.citations)
    assert "SIFT" in {p.extractor for p in sel.pruned}
    assert sel.extractor not in {p.extractor for p in sel.pruned}


def test_a_budget_flips_the_choice_on_a_real_frame(measured: KnowledgeGraph, data_dir: Path) -> None:
    image = cv2.imread(str(data_dir / "kitti" / "sequences" / "01" / "image_0" / "000010.png"), cv2.IMREAD_GRAYSCALE)
    assert image is not None
    _, g = programs.compile_text('program accurate\nprefer SIFT by 5 because "test: SIFT was most accurate here"',
                                 measured.vocabulary(), name="accurate")
    programs.apply(measured, g, "accurate", author="test")
    advisor = Advisor(measured, neural="symbolic")  # the preference decides, not the shipped model
    free = advisor.select(CTX, image)
    assert free.mode == "metrics" and free.extractor == "SIFT"
    tight = advisor.select(CTX, image, budget_ms=20)
    assert tight.extractor != "SIFT" and tight.budget is not None and tight.budget["size_source"] == "frame"
    assert (tight.budget["width"], tight.budget["height"]) == (image.shape[1], image.shape[0])
    assert _budget_citation(tight, "SIFT").rule == N + "rule_budget"
    assert tight.as_dict()["budget"]["ms"] == 20
