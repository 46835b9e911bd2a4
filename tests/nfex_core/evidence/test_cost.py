"""The cost model: fitted from Measurements, its tiers (measured, model, fallback, unknown), SPARQL agreement."""
from __future__ import annotations

import json
from collections.abc import Mapping
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nfex_core.evidence.cost import CostModel, ExtractorCost, expected_cost_query, fit_cost_model
from nfex_core.kg import KnowledgeGraph
from nfex_core.rules.engine import compile_table
from nfex_core.sweeps.grid import canonical
from nfex_core.sweeps.records import RunInfo, configuration_iri, measurement_graph

# a known law to recover: ms = MP·(6 + 2·nlevels) + 4·nfeatures/1000
A, B, C = 6.0, 4.0, 2.0


def law(params: Mapping[str, Any], w: int, h: int) -> float:
    return w * h / 1e6 * (A + C * params["nlevels"]) + B * params["nfeatures"] / 1000


def row(kg: KnowledgeGraph, x: str, params: Mapping[str, Any], ms: float, cell: str, w: int = 1241, h: int = 376,
        ate: float = 0.5) -> dict[str, Any]:
    full = kg.vocabulary().extractor(x).resolve(params)
    return {
        "dataset": "kitti", "sequence": "00", "corruption": "none", "severity": 0, "seed": 0, "window_start": 0,
        "window_end": 10, "frames": 10, "ctx.agent": "car", "ctx.scene": "outdoor", "ctx.motion": "slow",
        "extractor": x, "params": canonical(full), "ate_rmse": ate, "rpe_rmse": 0.1, "tracking_lost": 0, "failed": 0,
        "mean_matches": 200.0, "mean_inliers": 150.0, "mean_keypoints": 500.0, "extraction_ms": ms,
        "matching_ms": 2.0, "width": w, "height": h, "cell": cell,
    }


def add_rows(kg: KnowledgeGraph, rows: list[dict[str, Any]]) -> None:
    kg.add(measurement_graph(rows, kg.vocabulary(), RunInfo(command="test")), author="test")


@pytest.fixture
def measured(bare_kg: KnowledgeGraph) -> KnowledgeGraph:
    kg = bare_kg
    rows = []
    for i, (nf, nl) in enumerate((nf, nl) for nf in (500, 1000, 2000) for nl in (4, 8)):
        for j, (w, h) in enumerate(((1241, 376), (640, 480))):
            p = {"nfeatures": nf, "nlevels": nl}
            rows.append(row(kg, "ORB", p, law(p, w, h), f"orb{i}_{j}", w, h))
    rows += [row(kg, "SIFT", {}, 300.0, "sift0"), row(kg, "SIFT", {}, 340.0, "sift1", ate=0.1)]
    add_rows(kg, rows)
    return kg


def test_fit_recovers_the_law_and_reports_its_error(measured: KnowledgeGraph) -> None:
    model = fit_cost_model(measured, measured.vocabulary().extractors)
    orb = model.extractors["ORB"]
    assert (orb.per_mp, orb.per_kfeature, orb.per_mp_level) == pytest.approx((A, B, C), rel=1e-6)
    assert orb.rmse_ms == pytest.approx(0, abs=1e-9) and orb.fallback_rmse_ms > 0.5
    # SIFT: one configuration at one size: no parameter term, the mean rate is the model
    sift = model.extractors["SIFT"]
    assert not sift.has_terms and sift.mean_per_mp == pytest.approx(320.0 / (1241 * 376 / 1e6))
    assert model.typical_size == (1241, 376)


def test_tiers_measured_model_fallback_unknown(measured: KnowledgeGraph) -> None:
    vocab = measured.vocabulary()
    model = compile_table(measured).cost  # fitted in the compile step, per graph version
    orb, sift = vocab.extractor("ORB"), vocab.extractor("SIFT")
    hit = model.expected(orb, {"nfeatures": 1000, "nlevels": 8}, 1241, 376)
    assert hit.source == "measured" and hit.ms == pytest.approx(law({"nfeatures": 1000, "nlevels": 8}, 1241, 376))
    new = {"nfeatures": 1500, "nlevels": 6}
    est = model.expected(orb, new, 1920, 1080)
    assert est.source == "model" and est.ms == pytest.approx(law(new, 1920, 1080))
    fb = model.expected(sift, {"nfeatures": 1000}, 640, 480)  # never measured: extractor mean × pixels
    assert fb.source == "fallback" and fb.ms == pytest.approx(320.0 * 640 * 480 / (1241 * 376))
    scaled = model.expected(sift, {}, 640, 480)  # measured at another size, no parameter terms
    assert scaled.source == "scaled" and scaled.ms == pytest.approx(fb.ms)
    assert "never measured" in fb.describe()
    assert model.expected(vocab.extractor("BRISK"), {}, 640, 480).source == "unknown"


def test_the_graph_answers_expected_cost_by_sparql_like_the_model(measured: KnowledgeGraph) -> None:
    vocab = measured.vocabulary()
    model = fit_cost_model(measured, vocab.extractors)
    orb = vocab.extractor("ORB")
    params = orb.resolve({"nfeatures": 2000, "nlevels": 4})
    cfg = configuration_iri("ORB", canonical(params))
    [r] = measured.select(expected_cost_query(str(cfg), "ORB", 640, 480)).rows
    assert str(r["source"]) == "measured" and int(r["measurements"].toPython()) == 1
    assert float(r["expectedMs"].toPython()) == pytest.approx(model.expected(orb, params, 640, 480).ms)
    assert float(r["expectedMs"].toPython()) == pytest.approx(law(params, 640, 480))
    sift = vocab.extractor("SIFT")
    other = sift.resolve({"nfeatures": 700})
    cfg2 = configuration_iri("SIFT", canonical(other))
    [r2] = measured.select(expected_cost_query(str(cfg2), "SIFT", 1280, 720)).rows
    assert str(r2["source"]) == "fallback"
    assert float(r2["expectedMs"].toPython()) == pytest.approx(model.expected(sift, other, 1280, 720).ms)
    assert measured.select(expected_cost_query(str(cfg2), "BRISK", 640, 480)).rows == []


def test_a_term_the_data_does_not_support_is_dropped(bare_kg: KnowledgeGraph) -> None:
    kg = bare_kg
    # cost falls with nfeatures here (noise): a negative coefficient must not survive
    rows = [row(kg, "ORB", {"nfeatures": nf}, ms, f"c{nf}") for nf, ms in ((500, 12.0), (1000, 11.0), (2000, 10.5))]
    add_rows(kg, rows)
    orb = fit_cost_model(kg, kg.vocabulary().extractors).extractors["ORB"]
    assert orb.per_kfeature == 0 and orb.per_mp > 0 and not orb.has_terms


@settings(max_examples=50, deadline=None)
@given(
    st.floats(0.1, 100), st.floats(0, 20), st.floats(0, 5),
    st.integers(100, 4000), st.integers(100, 4000), st.integers(1, 5000), st.integers(1, 16),
)
def test_predicted_cost_scales_monotonically(a: float, b: float, c: float, w: int, h: int, nf: int, nl: int) -> None:
    m = ExtractorCost("ORB", a, b, c, a, "nfeatures", "nlevels")
    base = m.predict({"nfeatures": nf, "nlevels": nl}, w * h)
    assert base >= 0
    assert m.predict({"nfeatures": nf + 1, "nlevels": nl}, w * h) >= base
    assert m.predict({"nfeatures": nf, "nlevels": nl + 1}, w * h) >= base
    assert m.predict({"nfeatures": nf, "nlevels": nl}, 2 * w * h) >= base


def test_an_extractor_never_measured_has_no_model(bare_kg: KnowledgeGraph) -> None:
    kg = bare_kg
    model = fit_cost_model(kg, {"BRISK": kg.vocabulary().extractor("BRISK")})
    assert model.extractors == {} and model.typical_size is None
    assert json.loads(json.dumps(model.as_dict()))["measured_configurations"] == 0
    assert isinstance(CostModel().as_dict(), dict)


def test_an_input_scale_parameter_counts_the_pixels_processed(bare_kg: KnowledgeGraph) -> None:
    """XFeat resizes the frame by input_scale s (nfex:scalesInput): its cost grows with s²·W·H, so one
    fit over several scales predicts the others, and the fallback rate counts processed pixels too."""
    kg = bare_kg
    rows = []
    for i, (s, k) in enumerate((s, k) for s in (0.5, 1.0) for k in (1024, 4096)):
        p = {"input_scale": s, "top_k": k}
        rows.append(row(kg, "XFEAT", p, 300.0 * s * s * 1241 * 376 / 1e6 + 2.0 * k / 1000, f"xf{i}"))
    add_rows(kg, rows)
    spec = kg.vocabulary().extractor("XFEAT")
    model = fit_cost_model(kg, kg.vocabulary().extractors)
    xf = model.extractors["XFEAT"]
    assert xf.scale == "input_scale" and (xf.per_mp, xf.per_kfeature) == pytest.approx((300.0, 2.0), rel=1e-6)
    e = model.expected(spec, {"input_scale": 0.75, "top_k": 2048}, 1241, 376)
    assert e.source == "model" and e.ms == pytest.approx(300.0 * 0.5625 * 1241 * 376 / 1e6 + 2.0 * 2.048)
    assert model.expected(spec, {"input_scale": 0.5}, 640, 480).ms < model.expected(spec, {}, 640, 480).ms / 3
