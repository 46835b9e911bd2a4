"""``evaluate`` end to end on a synthetic sequence: paired runs, a schedule, oracles, the held-out scope."""
from __future__ import annotations

import json
from pathlib import Path

import pytest
from nfex_slam.datasets.synthetic import make_sequence

from cli.plots import draw
from nfex_core.evaluation import SCHEDULE, as_json, evaluate, frames_csv, markdown
from nfex_core.kg import KnowledgeGraph

from .conftest import add_rows, measured_row


@pytest.fixture
def seq():  # type: ignore[no-untyped-def]
    return make_sequence(8, width=192, height=128, context={"agent": "car", "scene": "outdoor"})


def test_evaluate_pairs_runs_and_reports_segments_transitions_and_oracles(bare_kg: KnowledgeGraph, seq, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    # measured on this very sequence: the evaluation must hold it out from every method
    add_rows(bare_kg, [measured_row(bare_kg, "ORB", {"nfeatures": 1500}, 0.01, f"x{i}", dataset=seq.dataset,
                                    sequence=seq.name) for i in range(3)])
    ev = evaluate(seq, bare_kg, methods=["orb-default", "orb-dyn", "sift-default", "nfex"], runs=2,
                  schedule="none:0-3,dark:4-7", corruptions=["none"], oracle=True)
    assert ev.conditions == ["none", SCHEDULE] and ev.runs == 2 and "sequence_synthetic_planes_0" in ev.scope
    assert ev.checks.startswith("agent car")
    keys = {r.key for r in ev.records}
    assert keys == {"orb-default", "orb-dyn", "sift-default", "nfex", "oracle-segment", "oracle-pair", "motion-prior"}
    assert len(ev.records) == 2 * 2 * 7
    for r in ev.records:  # every run has its front-end figures; lost and coasted pairs are apart
        assert set(r.auc) == {5.0, 10.0, 20.0} and all(0.0 <= v <= 1.0 for v in r.auc.values())
        assert r.auc[5.0] <= r.auc[10.0] <= r.auc[20.0] and r.lost + r.coasted <= r.frames - 1
        assert r.coasted >= r.rejected + r.fell_back
    prior = [r for r in ev.records if r.method == "motion-prior"]
    assert all(r.coasted >= r.frames - 2 and r.lost == 0 for r in prior)  # all coasting after the first step
    assert "orb-default" in ev.control
    sched = [r for r in ev.records if r.condition == SCHEDULE]
    assert all([s["segment"] for s in r.segments] == ["none:0-3", "dark:4-7"] for r in sched)
    assert all(len(r.transitions) == 1 and r.transitions[0]["transition"] == "none→dark" for r in sched)
    nfex = [r for r in ev.records if r.method == "nfex"]
    assert all(s["params"].get("nfeatures") != 1500 for r in nfex for s in r.selections if s["extractor"] == "ORB")
    dyn = [r for r in ev.records if r.method == "orb-dyn"]
    assert all(f.params["nfeatures"] != 1500 for r in dyn for f in r.result.frames)  # type: ignore[union-attr]
    best = ev.best_static("none")
    assert best in ("orb-default", "orb-dyn", "sift-default")
    md = markdown(ev)
    assert "Wilcoxon" in md and "Per segment" in md and "Transition pairs" in md and "Headroom" in md
    js = as_json(ev)
    assert js["best_static"]["none"] == best and json.dumps(js)
    assert len(js["methods"]["nfex"]["by_condition"]["none"]["ate_runs"]) == 2
    figures = js["methods"]["nfex"]["by_condition"]["none"]["figures"]
    assert set(figures) == {"auc5", "auc10", "auc20", "frontend_ate", "ate", "lost", "coasted"}
    assert len(figures["auc10"]["runs"]) == 2 and figures["auc10"]["vs_best_static"]["reference"] in ev.static
    assert js["max_coasted_fraction"] == 0.5 and "Front-end accuracy" in md
    assert frames_csv(ev).count("\n") == 1 + len(ev.records) * 8
    names = {p.name for p in draw(ev, tmp_path)}
    assert {"trajectories.png", "ate.png", "extractor_per_frame.png", "accuracy_vs_cost.png"} <= names


def test_the_same_seed_gives_the_same_run(bare_kg: KnowledgeGraph, seq) -> None:  # type: ignore[no-untyped-def]
    a = evaluate(seq, bare_kg, methods=["orb-default"], runs=2, corruptions=["dark"])
    b = evaluate(seq, bare_kg, methods=["orb-default"], runs=2, corruptions=["dark"])
    assert [r.ate_rmse for r in a.records] == [r.ate_rmse for r in b.records]


def test_checks_can_be_turned_off(bare_kg: KnowledgeGraph, seq) -> None:  # type: ignore[no-untyped-def]
    ev = evaluate(seq, bare_kg, methods=["orb-default"], runs=1, checks=False)
    assert ev.checks == "off"


def test_paired_runs_extract_each_frame_once_per_configuration(bare_kg: KnowledgeGraph, seq, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    from nfex_core.vision.registry import ExtractorRegistry

    calls: list[str] = []
    real = ExtractorRegistry.extract

    def counted(self, name, image, params=None):  # type: ignore[no-untyped-def]
        calls.append(name)
        return real(self, name, image, params)

    monkeypatch.setattr(ExtractorRegistry, "extract", counted)
    ev = evaluate(seq, bare_kg, methods=["orb-default", "sift-default"], runs=3, checks=False)
    # the clean frames are the same in every run: ORB and SIFT once per frame, whatever the runs and the control
    assert sorted(calls) == sorted(["ORB"] * len(seq) + ["SIFT"] * len(seq))
    assert {r.run for r in ev.records} == {0, 1, 2}
    # under a corruption drawn per run, each run's frames are new
    calls.clear()
    evaluate(seq, bare_kg, methods=["orb-default"], runs=2, corruptions=["dark"], checks=False)
    assert len(calls) == 2 * len(seq)


def test_a_method_the_evidence_in_scope_cannot_form_is_left_out_of_that_sequence(bare_kg: KnowledgeGraph, seq) -> None:  # type: ignore[no-untyped-def]
    # nothing measured: tuned static has no configuration to be, and the other methods still run
    ev = evaluate(seq, bare_kg, methods=["orb-default", "tuned-static"], runs=1, checks=False)
    assert set(ev.keys()) == {"orb-default", "motion-prior"}
    assert "needs measured configurations" in ev.skipped["tuned-static"]
    assert "Not run on this sequence: tuned-static (" in markdown(ev)
    assert as_json(ev)["skipped"] == ev.skipped
