from __future__ import annotations

import csv
import io

from nfex_core.evaluation import Evaluation, RunRecord, as_json, csv_text, markdown, selections_csv


def _rec(method: str, ate: float | None, run: int, corruption: str = "none", budget: float | None = None) -> RunRecord:
    return RunRecord(method, corruption, run, ate, ate is None, 0 if ate else 9, 10, 5.0, 1.0, 0.1, budget_ms=budget)


def test_table_shows_mean_over_runs_fail_and_cost() -> None:
    ev = Evaluation("kitti", "01", 10, [
        _rec("orb-default", 1.0, 0), _rec("orb-default", 2.0, 1), _rec("sift-default", None, 0),
        _rec("sift-default", None, 1), _rec("nfex", 0.5, 0), _rec("nfex", None, 1), _rec("nfex", 0.7, 0, budget=20.0),
    ])
    md = markdown(ev)
    lines = {line.split("|")[1].strip(): line for line in md.splitlines() if line.startswith("| ") and "---" not in line}
    assert "1.500" in lines["ORB (default)"] and "6.0" in lines["ORB (default)"]
    assert "| fail |" in lines["SIFT (default)"]
    assert "0.500 (1/2 fail)" in lines["nFEX"]
    assert "0.700" in lines["nFEX @ 20 ms"]
    js = as_json(ev)["methods"]
    assert js["orb-default"]["ate_rmse_mean"] == 1.5 and js["orb-default"]["runs"] == 2
    assert js["sift-default"]["ate_rmse_mean"] is None and js["sift-default"]["failed_runs"] == 2
    assert js["nfex@20ms"]["budget_ms"] == 20.0 and js["nfex"]["failed_runs"] == 1
    assert csv_text(ev).count("\n") == 8


def test_selections_csv_has_a_row_per_run_frame_and_candidate() -> None:
    nfex = _rec("nfex", 0.5, 1, budget=20.0)
    nfex.selections = [
        {"frame": f, "extractor": "ORB_GRID", "mode": "metrics", "candidates": [
            {"extractor": "ORB_GRID", "score": 9.0, "f_metrics": 4.0, "measured_accuracy": 1.0, "ate_m": 0.1},
            {"extractor": "ORB", "score": 8.0, "f_metrics": 4.5, "measured_accuracy": 0.5, "ate_m": None}]}
        for f in (0, 1)
    ]
    rows = list(csv.DictReader(io.StringIO(selections_csv(Evaluation("kitti", "01", 2, [_rec("orb-default", 1.0, 0), nfex])))))
    assert len(rows) == 4 and {r["method"] for r in rows} == {"nfex"}
    orb = [r for r in rows if r["candidate"] == "ORB"]
    assert [r["frame"] for r in orb] == ["0", "1"] and all(r["chosen"] == "ORB_GRID" and r["budget_ms"] == "20.0" for r in orb)
    assert orb[0]["f_metrics"] == "4.5" and orb[0]["ate_m"] == "" and orb[0]["run"] == "1"
