"""A tiny real sweep (KITTI 00, 4-frame windows): rows, labels, Measurements, resume, executors."""
from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

from nfex_core.kg import KnowledgeGraph
from nfex_core.sweeps import RunInfo, SweepSpec, export_measurements, sweep, table


def _spec(data_dir: Path, **kw: object) -> SweepSpec:
    base: dict[str, object] = dict(path=str(data_dir / "kitti"), format="kitti", sequences=("00",), extractors=("ORB",),
                                   window=4, stride=100, max_windows=1, corruptions=("none", "dark"), sample=2)
    base.update(kw)
    return SweepSpec(**base)  # type: ignore[arg-type]


def _measurements(kg: KnowledgeGraph) -> int:
    return int(kg.select("SELECT (COUNT(?m) AS ?n) WHERE { ?m a nfex:Measurement }").rows[0]["n"].toPython())  # type: ignore[union-attr]


@pytest.mark.slow
def test_sweep_writes_rows_and_measurements_and_resumes(kg: KnowledgeGraph, data_dir: Path, tmp_path: Path) -> None:
    csv = tmp_path / "t.csv"
    seeded = _measurements(kg)  # the seed carries ontology/measurements/
    counts = sweep(_spec(data_dir), kg, csv, run=RunInfo(command="test"), workers=1, batch=3, progress=False)
    assert counts == {"cells": 4, "skipped": 0, "ran": 4, "committed": 4}
    rows = table.read(csv)
    assert len(rows) == 4 and _measurements(kg) == seeded + 4
    assert {r["corruption"] for r in rows} == {"none", "dark"}
    assert all(r["ctx.agent"] == "car" for r in rows)
    assert {r["ctx.light"] for r in rows if r["corruption"] == "dark"} == {"dark"}
    for r in rows:
        assert r["width"] == "1241" and r["height"] == "376" and float(r["extraction_ms"]) > 0
        assert float(r["m.texturedness"]) >= 0 and "stat.mean" in r
    for c in ("none", "dark"):
        assert sum(int(r["best_overall"]) for r in rows if r["corruption"] == c) == 1
    # resume: nothing left to do, and a row lost from the table is measured again (and not duplicated)
    again = sweep(_spec(data_dir), kg, csv, run=RunInfo(command="test"), workers=1, progress=False)
    assert again["ran"] == 0 and again["skipped"] == 4
    table.write(csv, rows[1:])
    third = sweep(_spec(data_dir), kg, csv, run=RunInfo(command="test"), workers=1, progress=False)
    assert third["ran"] == 1 and len(table.read(csv)) == 4 and _measurements(kg) == seeded + 4
    out = tmp_path / "m.ttl"
    assert export_measurements(kg, out) > 100
    assert "nfex:Measurement" in out.read_text()
    # only the cells asked for, compressed N-Triples: exactly their Measurements, and it loads back
    from rdflib import RDF

    from nfex_core.kg.changes import read_rdf_file
    from nfex_core.kg.namespaces import NFEX

    mine = tmp_path / "m.nt.gz"
    cells = [r["cell"] for r in table.read(csv)][:2]
    n = export_measurements(kg, mine, cells=cells)
    g = read_rdf_file(mine)
    assert len(g) == n and len(set(g.subjects(RDF.type, NFEX.Measurement))) == 2


@pytest.mark.slow
def test_local_process_pool(kg: KnowledgeGraph, data_dir: Path, tmp_path: Path) -> None:
    seeded = _measurements(kg)
    counts = sweep(_spec(data_dir, corruptions=("none",)), kg, tmp_path / "t.csv", run=RunInfo(command="test"),
                   workers=2, progress=False)
    assert counts["ran"] == 2 and _measurements(kg) == seeded + 2


@pytest.mark.slow
@pytest.mark.skipif(importlib.util.find_spec("ray") is None, reason="ray is not installed (pip install 'nfex[ray]')")
def test_ray_executor_on_a_local_two_cpu_instance(kg: KnowledgeGraph, data_dir: Path, tmp_path: Path) -> None:
    seeded = _measurements(kg)
    counts = sweep(_spec(data_dir, corruptions=("none",)), kg, tmp_path / "t.csv", run=RunInfo(command="test"),
                   executor="ray", workers=2, progress=False)
    assert counts["ran"] == 2 and _measurements(kg) == seeded + 2


@pytest.mark.slow
def test_a_schedule_sweep_keeps_each_pairs_outcome_and_the_transition(kg: KnowledgeGraph, data_dir: Path, tmp_path: Path) -> None:
    """A window across a change of condition: its row names the schedule and the transition, the pairs
    table has one row per frame pair (the straddling one marked), the Measurement carries both."""
    csv = tmp_path / "t.csv"
    spec = _spec(data_dir, corruptions=(), schedules=("none:0-1,dark:2-199",), sample=1)  # KITTI 00 here: 200 frames
    counts = sweep(spec, kg, csv, run=RunInfo(command="test"), workers=1, progress=False)
    assert counts["ran"] == 1
    (row,) = table.read(csv)
    assert (row["corruption"], row["schedule"], row["transition"]) == ("schedule", "none:0-1,dark:2-199", "none→dark")
    assert 0.0 <= float(row["bad_pair_fraction"]) <= 1.0
    pairs = table.read_pairs(table.pairs_path(csv))
    assert [p["frame"] for p in pairs] == ["1", "2", "3"]
    assert [p["transition"] for p in pairs] == ["", "none→dark", ""]
    for p in pairs:  # an estimate has its error against the ground truth; a lost pair says why
        assert p["rotation_error_deg"] != "" or (p["lost"] == "1" and p["reason"])
    assert kg.ask('ASK { ?m a nfex:Measurement ; nfex:transition "none→dark" ; nfex:badPairFraction ?b }')


@pytest.mark.slow
def test_a_ramped_schedule_sweeps_like_an_abrupt_one(kg: KnowledgeGraph, data_dir: Path, tmp_path: Path) -> None:
    """A segment's own severity ramp travels with the schedule's text into the row and the Measurement."""
    csv = tmp_path / "t.csv"
    text = "none:0-1,dark:2-199@0.2-0.9"
    counts = sweep(_spec(data_dir, corruptions=(), schedules=(text,), sample=1), kg, csv, run=RunInfo(command="test"),
                   workers=1, progress=False)
    assert counts["ran"] == 1
    (row,) = table.read(csv)
    assert (row["corruption"], row["schedule"], row["transition"]) == ("schedule", text, "none→dark")
    assert [p["transition"] for p in table.read_pairs(table.pairs_path(csv))] == ["", "none→dark", ""]
