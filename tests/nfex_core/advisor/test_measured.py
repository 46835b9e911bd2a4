"""Θ′ from the graph's own measurements (advisor/measured.py, RuleTable.measured) and the measured accuracy
in the score: which measurements count, the budget choosing among measured configurations, the rule
cited and disabled as data."""
from __future__ import annotations

from pathlib import Path
from typing import Any

import cv2
import pytest
import rdflib

from nfex_core.advisor import Advisor
from nfex_core.kg import KnowledgeGraph
from nfex_core.kg.namespaces import NFEX

from ..evidence.test_cost import add_rows, row

RULE = str(NFEX.rule_measured_configuration)
SLOW = {"agent": "car", "motion": "slow", "scene": "outdoor"}


def _rows(kg: KnowledgeGraph, nf: int, ate: float, ms: float, n: int = 3, failed: int = 0, **ctx: str) -> list[dict[str, Any]]:
    out = []
    for i in range(n):
        r = row(kg, "ORB", {"nfeatures": nf}, ms, f"orb{nf}_{i}_{'_'.join(ctx.values())}", ate=ate)
        r.update({f"ctx.{k}": v for k, v in ctx.items()}, window_start=i * 100, window_end=i * 100 + 10)
        if i < failed:
            r.update(failed=1, ate_rmse=None)
        out.append(r)
    return out


@pytest.fixture
def measured(bare_kg: KnowledgeGraph) -> KnowledgeGraph:
    """ORB measured under car/outdoor/slow: 2000 features best (0.05 m, 8 ms), 1000 next (0.10 m, 5 ms);
    3000 better still but over only two windows; 4000 best but one of its windows failed; 500 best of
    all but measured in the dark only."""
    kg = bare_kg
    rows = (_rows(kg, 2000, 0.05, 8.0) + _rows(kg, 1000, 0.10, 5.0) + _rows(kg, 3000, 0.01, 9.0, n=2)
            + _rows(kg, 4000, 0.01, 10.0, failed=1) + _rows(kg, 500, 0.02, 3.0, light="dark"))
    add_rows(kg, rows)
    return kg


def _nf(kg: KnowledgeGraph, ranked: tuple[Any, ...]) -> list[int]:
    return [int(c.params["nfeatures"]) for c in ranked]


def test_which_measurements_count(measured: KnowledgeGraph) -> None:
    table = Advisor(measured).snapshot().table
    dims = table.dimensions
    ctx = dict.fromkeys(dims)
    # light unknown: the dark windows count; too few windows and failed windows do not
    assert _nf(measured, table.measured({**ctx, **SLOW})["ORB"]) == [500, 2000, 1000]
    # a bright frame: the dark windows contradict it
    assert _nf(measured, table.measured({**ctx, **SLOW, "light": "bright"})["ORB"]) == [2000, 1000]
    # sharing no known value: nothing counts
    assert table.measured({**ctx, "agent": "drone"}) == {}
    best = table.measured({**ctx, **SLOW, "light": "bright"})["ORB"][0]
    assert best.ate == pytest.approx(0.05) and best.windows == 3


def test_theta_is_the_best_measured_configuration_and_cites_it(measured: KnowledgeGraph) -> None:
    sel = Advisor(measured, neural="symbolic").select({**SLOW, "light": "bright"})
    orb = next(c for c in sel.candidates if c.extractor == "ORB")
    assert orb.params["nfeatures"] == 2000
    [adj] = [a for a in orb.adjustments if a.parameter == "nfeatures"]
    assert adj.before == 500 and adj.after == 2000 and adj.citations[0].rule == RULE
    assert "median ATE 0.050 m over 3 windows" in adj.citations[0].reason
    assert orb.evidence.configuration.windows == 3
    # an extractor without measurements here keeps g(Θ, E)
    sift = next(c for c in sel.candidates if c.extractor == "SIFT")
    assert sift.evidence.configuration is None


def test_under_a_budget_the_best_configuration_that_fits(measured: KnowledgeGraph) -> None:
    advisor = Advisor(measured, neural="symbolic")
    sel = advisor.select({**SLOW, "light": "bright"}, budget_ms=6)
    orb = next(c for c in sel.candidates if c.extractor == "ORB")
    assert orb.params["nfeatures"] == 1000 and orb.evidence.expected_ms == pytest.approx(5.0)
    reason = orb.evidence.configuration_because.reason
    assert "fits the budget 6 ms" in reason and "0.050 m" in reason
    assert not any(c.kind == "budget" for a in orb.adjustments for c in a.citations)  # chosen, not fitted
    big = next(c for c in advisor.select({**SLOW, "light": "bright"}, budget_ms=100).candidates if c.extractor == "ORB")
    assert big.params["nfeatures"] == 2000


def test_disabling_the_rule_restores_g(measured: KnowledgeGraph) -> None:
    g = rdflib.Graph()
    g.add((NFEX.rule_measured_configuration, NFEX.enabled, rdflib.Literal(False)))
    measured.add(g, author="test")
    sel = Advisor(measured, neural="symbolic").select({**SLOW, "light": "bright"})
    orb = next(c for c in sel.candidates if c.extractor == "ORB")
    assert orb.evidence.configuration is None
    assert not any(c.rule == RULE for a in orb.adjustments for c in a.citations)


def test_the_frame_score_adds_the_measured_accuracy(measured: KnowledgeGraph, data_dir: Path) -> None:
    image = cv2.imread(str(data_dir / "kitti" / "sequences" / "01" / "image_0" / "000010.png"), cv2.IMREAD_GRAYSCALE)
    add_rows(measured, [row(measured, "SIFT", {}, 80.0, f"sift{i}", ate=0.025) for i in range(3)])
    sel = Advisor(measured, neural="symbolic", exhaustive_scoring=True).select({**SLOW, "light": "bright"}, image)
    h = sum(w.value for w in sel.weights.values())
    by = {c.extractor: c for c in sel.candidates}
    ates = {x: by[x].evidence.measured.ate for x in ("ORB", "SIFT")}
    for x, c in by.items():
        a = min(ates.values()) / ates[x] if x in ates else 0.0
        assert c.evidence.measured_accuracy == pytest.approx(a, abs=1e-6)
        assert c.score == pytest.approx(c.evidence.f_metrics + h * a, abs=1e-5)
    assert by["SIFT"].evidence.measured_accuracy == pytest.approx(1.0)
