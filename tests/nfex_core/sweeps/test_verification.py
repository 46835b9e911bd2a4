"""Learning the verification program from pair tables (nfex_core/sweeps/verification.py), on synthetic pairs
whose answer is known: two extractors see the same pairs; where both are right they agree, where one is wrong it
is wrong by a random large turn."""
from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

from nfex_core.rules.dsl.check import check
from nfex_core.rules.dsl.parser import parse
from nfex_core.sweeps.table import pairs_path, write_pairs
from nfex_core.sweeps.verification import learn


def _yaw_vec(deg: float) -> tuple[float, float, float]:
    return (0.0, math.radians(deg), 0.0)


def _direction(deg: float) -> tuple[float, float, float]:
    a = math.radians(deg)
    return (math.sin(a), 0.0, math.cos(a))


def _tables(tmp_path: Path) -> Path:
    rng = np.random.default_rng(0)
    table = tmp_path / "synthetic.csv"
    with table.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=["cell", "ctx.agent"])
        w.writeheader()
        w.writerows([{"cell": "orb", "ctx.agent": "car"}, {"cell": "sift", "ctx.agent": "car"}])
    rows = []
    for frame in range(1, 400):
        truth_yaw = 0.2 * math.sin(frame / 30)  # a gently turning car, heading straight ahead
        for cell, x, p_wrong in (("orb", "ORB", 0.3), ("sift", "SIFT", 0.1)):
            wrong = rng.random() < p_wrong
            yaw = truth_yaw + (rng.uniform(10, 40) if wrong else rng.normal(0, 0.05))
            heading = rng.uniform(20, 80) if wrong else rng.normal(0, 0.5)
            rows.append({
                "cell": cell, "dataset": "synthetic", "sequence": "s", "corruption": "none", "severity": 0, "seed": 0,
                "window_start": 0, "frame": frame, "before": "none", "after": "none", "transition": "", "extractor": x,
                "lost": 0, "rejected": 0, "parallax_px": 5.0,
                "rotation_error_deg": abs(yaw - truth_yaw), "direction_error_deg": abs(heading),
                **dict(zip(("rx", "ry", "rz"), _yaw_vec(yaw), strict=True)),
                **dict(zip(("dx", "dy", "dz"), _direction(heading), strict=True)),
                **dict(zip(("true_rx", "true_ry", "true_rz"), _yaw_vec(truth_yaw), strict=True)),
                **dict(zip(("true_dx", "true_dy", "true_dz"), _direction(0.0), strict=True)),
            })
    write_pairs(pairs_path(table), rows)
    return table


def test_learned_thresholds_separate_right_from_wrong_estimates(tmp_path: Path) -> None:
    from nfex_core.config import Settings
    from nfex_core.kg.shipped import ontology_vocabulary

    vocab = ontology_vocabulary(Settings.from_env())
    table = _tables(tmp_path)
    text, report = learn([pairs_path(table)], [table], min_pairs=100)
    program = check(parse(text), vocab)  # the written program is valid nFEX, checked against the graph's names
    accepts = [s for s in program.statements if s.kind == "accept"]
    assert accepts and all(s.when[0].values == ("car",) for s in accepts)
    bounds = {t.signal: t.bound for s in accepts for t in s.tests}
    # wrong estimates turn ≥ 10° away from the prior, head ≥ 20° off it and disagree by ≥ 10°: no rule admits them
    assert bounds.get("rotation_change", 0) < 10 or bounds.get("heading_change", 0) < 20
    assert bounds.get("agreement", 0) < 10
    # the fitted policy beats taking every estimate and always coasting, on the pairs it was fitted to
    for r in report:
        assert float(r["cost"]) < min(float(r["accept_all"]), float(r["fall_back_all"]))  # type: ignore[arg-type]
    assert "escalate at most 2" in text and "learned from" in text


def test_without_pair_tables_there_is_nothing_to_learn(tmp_path: Path) -> None:
    table = tmp_path / "empty.csv"
    table.write_text("cell,ctx.agent\n")
    text, report = learn([pairs_path(table)], [table])
    assert report == [] and "escalate at most" in text
