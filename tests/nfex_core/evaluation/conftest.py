"""Measurement rows for evaluation tests: a sweep's training-table rows, committed to a test store."""
from __future__ import annotations

from typing import Any

from nfex_core.kg import KnowledgeGraph
from nfex_core.kg.identity import canonical
from nfex_core.sweeps.records import RunInfo, measurement_graph


def measured_row(kg: KnowledgeGraph, x: str, params: dict[str, Any], ate: float | None, cell: str, *, dataset: str = "kitti",
                 sequence: str = "00", light: str = "", failed: bool = False, ms: float = 5.0) -> dict[str, Any]:
    full = kg.vocabulary().extractor(x).resolve(params)
    return {
        "dataset": dataset, "sequence": sequence, "corruption": "none", "severity": 0, "seed": 0, "window_start": 0,
        "window_end": 10, "frames": 10, "ctx.agent": "car", "ctx.scene": "outdoor", "ctx.light": light,
        "extractor": x, "params": canonical(full), "ate_rmse": ate, "rpe_rmse": 0.1, "tracking_lost": 10 if failed else 0,
        "failed": int(failed), "mean_matches": 200.0, "mean_inliers": 150.0, "mean_keypoints": 500.0, "extraction_ms": ms,
        "matching_ms": 2.0, "width": 1241, "height": 376, "cell": cell,
    }


def add_rows(kg: KnowledgeGraph, rows: list[dict[str, Any]]) -> None:
    kg.add(measurement_graph(rows, kg.vocabulary(), RunInfo(command="test")), author="test")
