from __future__ import annotations

import csv
import io

import pytest

from nfex_core.evaluation import Evaluation, RunRecord, as_json, csv_text, markdown, selections_csv
from nfex_core.evaluation.report import display


def _rec(method: str, ate: float | None, run: int, condition: str = "none", budget: float | None = None,
         expected: float = 5.0) -> RunRecord:
    return RunRecord(method, condition, run, ate, 0.1 if ate else None, ate is None, 0 if ate else 9, 0, 10, 5.0, 7.5,
                     1.0, expected, 0.1, budget_ms=budget)


def _ev(records: list[RunRecord]) -> Evaluation:
    return Evaluation("kitti", "01", 10, records, conditions=["none"], runs=3,
                      static=["orb-default", "sift-default"])


def test_the_table_compares_with_the_best_static_method_within_the_budget() -> None:
    recs = [_rec("orb-default", a, r, expected=4.0) for r, a in enumerate((2.0, 2.4, 1.8))]
    recs += [_rec("sift-default", a, r, expected=60.0) for r, a in enumerate((0.5, 0.6, 0.4))]
    recs += [_rec("nfex", a, r) for r, a in enumerate((0.45, 0.55, None))]
    recs += [_rec("nfex", a, r, budget=20.0) for r, a in enumerate((1.0, 1.1, 0.9))]
    ev = _ev(recs)
    assert ev.best_static("none") == "sift-default" and ev.best_static("none", 20.0) == "orb-default"
    md = markdown(ev)
    lines = {line.split("|")[1].strip(): line for line in md.splitlines() if line.startswith("| ") and "---" not in line}
    assert "(reference)" in lines["SIFT (default)"] and "0.500" in lines["SIFT (default)"]
    assert "(1/3 fail)" in lines["nFEX"] and "on par" in lines["nFEX"]
    assert "-51.6 %" in lines["nFEX @ 20 ms"]  # mean 1.0 against ORB default's 2.067, the best static that fits 20 ms
    assert "Best static within 20 ms: ORB (default)" in md
    js = as_json(ev)["methods"]
    assert js["orb-default"]["ate_rmse_mean"] == pytest.approx(2.0666667)
    assert js["nfex@20ms"]["budget_ms"] == 20.0
    assert js["nfex@20ms"]["by_condition"]["none"]["vs_best_static"]["reference"] == "orb-default"
    assert js["sift-default"]["by_condition"]["none"]["ate"]["n"] == 3
    assert js["nfex"]["by_condition"]["none"]["failed_runs"] == 1
    assert csv_text(ev).count("\n") == 1 + len(recs)


def test_display_names() -> None:
    assert display("orb_grid-dyn") == "ORB_GRID (dynamic)" and display("nfex@20ms") == "nFEX @ 20 ms"
    assert display("tuned-static") == "tuned static" and display("oracle-pair") == "oracle pair"


def test_selections_csv_has_a_row_per_run_frame_and_candidate() -> None:
    nfex = _rec("nfex", 0.5, 1, budget=20.0)
    nfex.selections = [
        {"frame": f, "extractor": "ORB_GRID", "mode": "metrics", "candidates": [
            {"extractor": "ORB_GRID", "score": 9.0, "f_metrics": 4.0, "measured_accuracy": 1.0, "ate_m": 0.1},
            {"extractor": "ORB", "score": 8.0, "f_metrics": 4.5, "measured_accuracy": 0.5, "ate_m": None}]}
        for f in (0, 1)
    ]
    rows = list(csv.DictReader(io.StringIO(selections_csv(_ev([_rec("orb-default", 1.0, 0), nfex])))))
    assert len(rows) == 4 and {r["method"] for r in rows} == {"nfex"}
    orb = [r for r in rows if r["candidate"] == "ORB"]
    assert [r["frame"] for r in orb] == ["0", "1"] and all(r["chosen"] == "ORB_GRID" and r["budget_ms"] == "20.0" for r in orb)
    assert orb[0]["f_metrics"] == "4.5" and orb[0]["ate_m"] == "" and orb[0]["run"] == "1"
