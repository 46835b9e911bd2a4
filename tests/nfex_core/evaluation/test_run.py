from __future__ import annotations

from pathlib import Path

import pytest

from nfex_core.datasets import open_sequence
from nfex_core.evaluation import evaluate, markdown
from nfex_core.evaluation.plots import draw
from nfex_core.kg import KnowledgeGraph


@pytest.mark.slow
def test_evaluate_runs_methods_corruptions_and_runs(kg: KnowledgeGraph, data_dir: Path, tmp_path: Path) -> None:
    seq = open_sequence(data_dir / "kitti", "kitti", "01")
    ev = evaluate(seq, kg, methods=["orb-default", "sift-default"], runs=2, corruptions=["none", "dark"], frames=6)
    assert len(ev.records) == 8 and ev.frames == 6
    assert {(r.method, r.corruption) for r in ev.records} == {
        (m, c) for m in ("orb-default", "sift-default") for c in ("none", "dark")}
    ok = [r for r in ev.records if not r.failed]
    assert ok and all(r.ate_rmse is not None and r.ate_rmse >= 0 and r.ms_per_frame > 0 for r in ok)
    assert "SIFT (default)" in markdown(ev)
    names = {p.name for p in draw(ev, tmp_path)}
    assert {"trajectories.png", "ate.png", "accuracy_vs_cost.png"} <= names
    assert all((tmp_path / n).stat().st_size > 1000 for n in names)
