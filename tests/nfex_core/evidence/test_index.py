"""Incremental reading of observations (evidence/index.py) equals a full read, whatever the change.

Random sequences of changes on the shipped graph — feedback reports (new Measurements, configurations, runs,
sequences), an ATE changed or removed, a Measurement deleted, a sequence relabelled (one step from its
Measurements), a configuration's setting changed (two steps from a configuration), an extractor's note (which no row
reads) — and after each batch
the carried index equals ``ObservationIndex.read``; the rule table compiled from the carried index equals a
full compile."""
from __future__ import annotations

import random

from hypothesis import given
from hypothesis import strategies as st

from nfex_core.evidence.index import ObservationIndex
from nfex_core.feedback import Feedback, ReportWriter
from nfex_core.kg import KnowledgeGraph
from nfex_core.rules.engine import compile_table
from tests.conftest import CARRIED_EXAMPLES

PREFIXES = ("PREFIX nfex: <https://w3id.org/nfex#> PREFIX rdfs: <http://www.w3.org/2000/01/rdf-schema#> "
            "PREFIX xsd: <http://www.w3.org/2001/XMLSchema#> ")
OPS = ("report", "report", "ate", "drop-ate", "delete", "relabel", "setting", "hub")


def _pick(kg: KnowledgeGraph, query: str, rng: random.Random) -> dict[str, object] | None:
    rows = kg.select(query).rows
    return rng.choice(rows) if rows else None


def _apply(kg: KnowledgeGraph, op: str, rng: random.Random, writer: ReportWriter) -> None:
    if op == "report":
        extractor = rng.choice(["ORB", "SIFT", "ORB_GRID"])
        params = {"ORB": {"nfeatures": rng.choice([500, 1000, 1500])}, "SIFT": {"nfeatures": rng.choice([0, 800])},
                  "ORB_GRID": {}}[extractor]
        writer.write(Feedback(extractor, params, {"agent": rng.choice(["car", "drone"]), "light": rng.choice(["dark", "bright"])},
                              sequence=rng.choice(["s1", "s2"]), dataset="pytest", reporter=rng.choice(["r1", "r2"]),
                              frames=10, ate_rmse=rng.uniform(0.01, 2.0), extraction_ms=rng.uniform(2, 60),
                              width=1241, height=376, tracking_lost=0))
        return
    if op in ("ate", "drop-ate"):
        row = _pick(kg, "SELECT ?m ?a WHERE { ?m a nfex:Measurement ; nfex:ateRmse ?a }", rng)
        if row is None:
            return
        insert = f"INSERT {{ <{row['m']}> nfex:ateRmse \"{rng.uniform(0.01, 3.0)!r}\"^^xsd:double }}" if op == "ate" else ""
        kg.update(PREFIXES + f"DELETE {{ <{row['m']}> nfex:ateRmse ?a }} {insert} WHERE {{ <{row['m']}> nfex:ateRmse ?a }}", author="pytest")
    elif op == "delete":
        row = _pick(kg, "SELECT ?m WHERE { ?m a nfex:Measurement }", rng)
        if row is not None:
            kg.update(PREFIXES + f"DELETE WHERE {{ <{row['m']}> ?p ?o }}", author="pytest")
    elif op == "relabel":
        row = _pick(kg, "SELECT DISTINCT ?s WHERE { ?m a nfex:Measurement ; nfex:sequence ?s . ?s rdfs:label ?l }", rng)
        if row is not None:
            kg.update(PREFIXES + f"DELETE {{ <{row['s']}> rdfs:label ?l }} INSERT {{ <{row['s']}> rdfs:label \"relabelled {rng.random()}\" }} "
                      f"WHERE {{ <{row['s']}> rdfs:label ?l }}", author="pytest")
    elif op == "hub":  # an editor's note on an extractor every measured configuration of it points at
        kg.update(PREFIXES + f"INSERT DATA {{ nfex:{rng.choice(['ORB', 'SIFT'])} rdfs:seeAlso <urn:nfex:test:{rng.random()}> }}", author="pytest")
    elif op == "setting":  # a measured configuration's setting takes the value of another setting of its parameter
        row = _pick(kg, """SELECT ?s ?v2 WHERE { ?m a nfex:Measurement ; sosa:usedProcedure ?cfg . ?cfg nfex:hasSetting ?s .
                             ?s nfex:parameter ?p ; nfex:value ?v . ?s2 nfex:parameter ?p ; nfex:value ?v2 FILTER (?v2 != ?v) } LIMIT 200""", rng)
        if row is not None:
            value = row["v2"].n3()  # type: ignore[attr-defined]
            kg.update(PREFIXES + f"DELETE {{ <{row['s']}> nfex:value ?v }} INSERT {{ <{row['s']}> nfex:value {value} }} "
                      f"WHERE {{ <{row['s']}> nfex:value ?v }}", author="pytest")


def _same(a: ObservationIndex, b: ObservationIndex) -> None:
    assert a.observations.keys() == b.observations.keys()
    assert a.all() == b.all()
    assert dict(a.settings) == dict(b.settings)


@CARRIED_EXAMPLES
@given(ops=st.lists(st.sampled_from(OPS), min_size=1, max_size=3), seed=st.integers(0, 2**32 - 1))
def test_the_carried_index_equals_a_full_read_after_random_changes(shipped_kg: KnowledgeGraph, ops: list[str], seed: int) -> None:
    rng = random.Random(seed)
    before = shipped_kg.cached("test-index", lambda: ObservationIndex.read(shipped_kg))
    writer = ReportWriter(shipped_kg, max_items=1)
    try:
        for op in ops:
            _apply(shipped_kg, op, rng, writer)
    finally:
        writer.close()
    carried = before.advance(shipped_kg)
    assert carried.version == shipped_kg.version
    if shipped_kg.version != before.version:
        assert carried.reread >= 0  # carried forward, not a full read (a relabelled sequence re-reads all its Measurements)
    _same(carried, ObservationIndex.read(shipped_kg))


def test_a_report_rereads_only_its_own_measurement_and_the_compiled_table_equals_a_full_compile(shipped_kg: KnowledgeGraph) -> None:
    first = compile_table(shipped_kg)
    writer = ReportWriter(shipped_kg, max_items=1)
    try:
        writer.write(Feedback("SIFT", {}, {"agent": "car", "light": "dark"}, sequence="s9", dataset="pytest", reporter="r1",
                              frames=10, ate_rmse=0.05, extraction_ms=40.0, width=1241, height=376, tracking_lost=0))
    finally:
        writer.close()
    carried = compile_table(shipped_kg, first)
    full = compile_table(shipped_kg)
    assert carried.carry is not None and full.carry is not None  # what each compile hands the next
    kept, fresh = carried.carry.index, full.carry.index
    assert 1 <= kept.reread <= 5  # the Measurement and the new nodes it brought (run, sequence, …)
    assert kept.reread > -1 and fresh.reread == -1
    _same(kept, fresh)
    assert carried.decisions == full.decisions
    assert carried.configurations == full.configurations and carried.observed == full.observed
    assert carried.cost == full.cost and carried.admission == full.admission
    contexts = [{"agent": "car", "light": "dark"}, {"agent": "drone"}, {}]
    for c in contexts:
        assert carried.decide(c) == full.decide(c)
        assert carried.measured(c) == full.measured(c)


def test_a_change_no_row_reads_rereads_nothing(shipped_kg: KnowledgeGraph) -> None:
    """An extractor's ``rdfs:seeAlso`` is outside the footprint of the rows' queries (kg/storage/footprint.py): nothing
    is read again, though every Measurement of that extractor is two steps from it; a sequence's label is
    inside it, and that sequence's Measurements are read again."""
    before = ObservationIndex.read(shipped_kg)
    _apply(shipped_kg, "hub", random.Random(0), None)  # type: ignore[arg-type]
    carried = before.advance(shipped_kg)
    assert carried.version == shipped_kg.version and carried.reread == 0
    _same(carried, ObservationIndex.read(shipped_kg))
    _apply(shipped_kg, "relabel", random.Random(0), None)  # type: ignore[arg-type]
    again = carried.advance(shipped_kg)
    assert again.reread > 1
    _same(again, ObservationIndex.read(shipped_kg))
