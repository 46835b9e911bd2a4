"""``read_observations`` (branches scanned one predicate each, joined in Python) reads what the plain query says.

The oracle is the query the reading is defined by, one row per condition value with an OPTIONAL per
attribute, evaluated by Oxigraph and folded naively; on the shipped graph with reports added."""
from __future__ import annotations

import dataclasses

from nfex_core.evidence.observations import Observation, read_observations
from nfex_core.feedback import Feedback, ReportWriter
from nfex_core.kg import KnowledgeGraph
from nfex_core.kg.rdf.terms import py
from tests.conftest import SparqlServer

PLAIN = """SELECT ?m ?xname ?cfg ?dim ?val ?ate ?ms ?w ?h ?failed ?lost ?frames ?seq ?seqLabel ?run ?reporter ?accepted WHERE {
    ?m a nfex:Measurement ; sosa:usedProcedure ?cfg .
    ?cfg nfex:ofExtractor/nfex:token ?xname .
    OPTIONAL { ?m nfex:underCondition ?c . ?c nfex:token ?val ; nfex:inDimension/nfex:token ?dim . }
    OPTIONAL { ?m nfex:ateRmse ?ate } OPTIONAL { ?m nfex:extractionMs ?ms }
    OPTIONAL { ?m nfex:frameWidth ?w ; nfex:frameHeight ?h }
    OPTIONAL { ?m nfex:trackingFailed ?failed } OPTIONAL { ?m nfex:trackingLost ?lost } OPTIONAL { ?m nfex:frameCount ?frames }
    OPTIONAL { ?m nfex:sequence ?seq OPTIONAL { ?seq rdfs:label ?seqLabel } }
    OPTIONAL { ?m prov:wasGeneratedBy ?run } OPTIONAL { ?m prov:wasAttributedTo ?reporter }
    OPTIONAL { ?m nfex:acceptedBy ?accepted }
}"""


def _plain(kg: KnowledgeGraph) -> dict[str, Observation]:
    out: dict[str, Observation] = {}
    conditions: dict[str, set[tuple[str, str]]] = {}
    for r in kg.select(PLAIN).rows:
        m = str(r["m"])
        conditions.setdefault(m, set())
        if "dim" in r:
            conditions[m].add((str(r["dim"]), str(r["val"])))
        out.setdefault(m, Observation(
            iri=m, extractor=str(r["xname"]), configuration=str(r["cfg"]), conditions=frozenset(),
            ate=float(py(r["ate"])) if "ate" in r else None, extraction_ms=float(py(r["ms"])) if "ms" in r else None,
            width=int(py(r["w"])) if "w" in r else None, height=int(py(r["h"])) if "h" in r else None,
            failed=bool(py(r["failed"])) if "failed" in r else False, lost=int(py(r["lost"])) if "lost" in r else None,
            frames=int(py(r["frames"])) if "frames" in r else None, sequence=str(r["seq"]) if "seq" in r else None,
            sequence_label=str(r["seqLabel"]) if "seqLabel" in r else None, run=str(r["run"]) if "run" in r else None,
            reporter=str(r["reporter"]) if "reporter" in r else None, accepted_by=str(r["accepted"]) if "accepted" in r else None))
    return {m: dataclasses.replace(o, conditions=frozenset(conditions[m])) for m, o in out.items()}


def test_the_reading_is_the_plain_querys(shipped_kg: KnowledgeGraph) -> None:
    writer = ReportWriter(shipped_kg, max_items=1)
    try:
        writer.write(Feedback("ORB", {"nfeatures": 1500}, {"agent": "car", "light": "dark"}, sequence="s1", dataset="pytest",
                              reporter="r1", frames=10, ate_rmse=0.4, extraction_ms=4.0, width=640, height=480, tracking_lost=2))
        writer.write(Feedback("SIFT", {}, {}, sequence="s2", reporter="r2", tracking_failed=True))  # no conditions, no ATE
    finally:
        writer.close()
    expected = _plain(shipped_kg)
    read = read_observations(shipped_kg)
    assert len(read) == len(expected) > 500
    assert {o.iri: o for o in read} == expected
    some = sorted(expected)[::50]
    assert {o.iri: o for o in read_observations(shipped_kg, some)} == {m: expected[m] for m in some}


def test_a_failure_flag_reads_as_xsd_boolean_does() -> None:
    from nfex_core.evidence.observations import _bool

    assert [_bool(x) for x in (None, "false", "False", "0", " FALSE ", "0.0")] == [False] * 6
    assert [_bool(x) for x in ("true", "TRUE", "1", "2", "yes")] == [True] * 5


def test_a_server_reads_what_the_plain_query_says(sparql_server: SparqlServer) -> None:
    """Through a SPARQL server the branches come back in its CSV results (``Backend.values``): the same Observations
    as the plain query's JSON results give, on `oxigraph serve` and on Virtuoso."""
    kg = sparql_server.open()
    writer = ReportWriter(kg, max_items=1)
    try:
        writer.write(Feedback("ORB", {"nfeatures": 1500}, {"agent": "car", "light": "dark"}, sequence='s1, "odd"\nname',
                              dataset="pytest", reporter="r1", frames=10, ate_rmse=0.4, extraction_ms=4.5, width=640, height=480,
                              tracking_lost=2))
        writer.write(Feedback("SIFT", {}, {}, sequence="s2", reporter="r2", tracking_failed=True))
    finally:
        writer.close()
    expected = _plain(kg)
    assert len(expected) >= 2
    assert any(o.sequence_label and '"odd"\nname' in o.sequence_label for o in expected.values())  # CSV's quoting
    assert {o.iri: o for o in read_observations(kg)} == expected
    assert {o.iri: o for o in read_observations(kg, list(expected))} == expected
