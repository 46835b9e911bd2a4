"""Sweep rows become SHACL-valid Measurements that SPARQL (and the pruning rules) can read."""
from __future__ import annotations

import json

from nfex_core.kg import KnowledgeGraph
from nfex_core.sweeps.records import RunInfo, configuration_iri, measurement_graph


def _row(kg: KnowledgeGraph, x: str, ate: float | None, cell: str, light: str = "dark") -> dict[str, object]:
    params = json.dumps(kg.vocabulary().extractor(x).resolve({}), sort_keys=True, separators=(",", ":"))
    return {
        "dataset": "kitti", "sequence": "00", "corruption": "dark", "severity": 0.7, "seed": 0, "window_start": 0,
        "window_end": 10, "frames": 10, "ctx.agent": "drone", "ctx.light": light, "ctx.scene": "outdoor",
        "extractor": x, "params": params, "ate_rmse": ate, "rpe_rmse": 0.1 if ate else None, "tracking_lost": 1,
        "failed": int(ate is None), "mean_matches": 200.0, "mean_inliers": 150.0, "mean_keypoints": 500.0,
        "extraction_ms": 5.0, "matching_ms": 2.0, "width": 1241, "height": 376, "m.density": 0.4, "cell": cell,
    }


def test_measurements_commit_and_answer_lowest_ate_under_dark(kg: KnowledgeGraph) -> None:
    run = RunInfo(command="nfex sweep test")
    rows = [_row(kg, "ORB", 1.2, "a"), _row(kg, "SIFT", 0.2, "b"), _row(kg, "ORB", None, "c")]
    before = kg.version
    kg.add(measurement_graph(rows, kg.vocabulary(), run), author="test")
    assert kg.version == before + 1
    answer = kg.select(
        """SELECT ?cfg (AVG(?ate) AS ?mean) WHERE {
             ?m a nfex:Measurement ; sosa:usedProcedure ?cfg ; nfex:ateRmse ?ate ;
                nfex:underCondition nfex:light_dark, nfex:agent_drone .
           } GROUP BY ?cfg ORDER BY ?mean LIMIT 1"""
    ).rows
    assert answer and str(answer[0]["cfg"]) == str(configuration_iri("SIFT", str(rows[1]["params"])))
    # the failed window has no ATE but counts as failed; cost and frame size are recorded for issue 8
    mine = f"prov:wasGeneratedBy <{run.iri}>"
    failed = kg.select(f"SELECT ?m WHERE {{ ?m nfex:trackingFailed true ; {mine} }}").rows
    assert len(failed) == 1
    cost = kg.select(f"SELECT ?ms ?w ?cpu WHERE {{ ?m {mine} ; nfex:extractionMs ?ms ; nfex:frameWidth ?w ; "
                     "prov:wasGeneratedBy/prov:wasAssociatedWith/nfex:cpuModel ?cpu }").rows
    assert len(cost) == 3 and int(cost[0]["w"].toPython()) == 1241 and str(cost[0]["cpu"])


def test_rewriting_the_same_rows_changes_nothing(kg: KnowledgeGraph) -> None:
    run = RunInfo(command="nfex sweep test")
    g = measurement_graph([_row(kg, "ORB", 0.5, "a")], kg.vocabulary(), run)
    kg.add(g, author="test")
    v = kg.version
    kg.add(g, author="test")
    assert kg.version == v
