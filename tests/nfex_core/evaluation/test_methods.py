"""Dynamic parameters come from the graph's measurements on *other* sequences; nFEX runs per frame."""
from __future__ import annotations

import json
from pathlib import Path

import pytest

from nfex_core.datasets import open_sequence
from nfex_core.evaluation import AdvisorChooser, best_params, chooser_for
from nfex_core.kg import KnowledgeGraph
from nfex_core.sweeps.records import RunInfo, measurement_graph
from nfex_core.vo import Choice


def _row(kg: KnowledgeGraph, seq: str, nfeatures: int, ate: float, cell: str) -> dict[str, object]:
    params = kg.vocabulary().extractor("ORB").resolve({"nfeatures": nfeatures})
    return {
        "dataset": "kitti", "sequence": seq, "corruption": "dark", "severity": 0.7, "seed": 0, "window_start": 0,
        "window_end": 10, "frames": 10, "ctx.agent": "drone", "ctx.light": "dark", "extractor": "ORB",
        "params": json.dumps(params, sort_keys=True, separators=(",", ":")), "ate_rmse": ate, "rpe_rmse": 0.1,
        "tracking_lost": 0, "failed": 0, "mean_matches": 1.0, "mean_inliers": 1.0, "mean_keypoints": 1.0,
        "extraction_ms": 1.0, "matching_ms": 1.0, "width": 1241, "height": 376, "cell": cell,
    }


def test_best_params_excludes_the_evaluated_sequence(kg: KnowledgeGraph) -> None:
    rows = [_row(kg, "00", 1000, 0.2, "a"), _row(kg, "00", 2000, 0.5, "b"), _row(kg, "01", 3000, 0.1, "c")]
    kg.add(measurement_graph(rows, kg.vocabulary(), RunInfo(command="test")), author="test")
    ctx = {"agent": "drone"}  # the seeded KITTI sweep measured agent = car, never drone
    on_01, note = best_params(kg, "ORB", ctx, "kitti 01")
    assert on_01["nfeatures"] == 1000 and "0.200" in note
    assert best_params(kg, "ORB", ctx, "kitti 00")[0]["nfeatures"] == 3000
    assert best_params(kg, "SIFT", ctx, "kitti 01")[0] == {}  # nothing measured for drones: defaults
    assert best_params(kg, "ORB", {}, "kitti 01")[0] == {}
    chooser, _ = chooser_for("orb-dyn", kg, ctx, "kitti 01")
    choice = chooser(None, [])  # type: ignore[arg-type]
    assert choice == Choice("ORB", on_01)


@pytest.mark.slow
def test_advisor_chooser_selects_every_frame(kg: KnowledgeGraph, data_dir: Path) -> None:
    seq = open_sequence(data_dir / "kitti", "kitti", "01")
    chooser, note = chooser_for("nfex", kg, dict(seq.context), "kitti 01")
    assert isinstance(chooser, AdvisorChooser) and "advisor" in note
    choices = [chooser(seq[i], []) for i in range(3)]
    names = kg.vocabulary().extractors
    assert all(c.extractor in names for c in choices)
    assert [s["frame"] for s in chooser.selections] == [0, 1, 2]
    assert chooser._state is not None  # the stream state is carried to the next frame
