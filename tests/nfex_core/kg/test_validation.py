"""Incremental validation agrees with validating the whole candidate graph.

Random writes — new configurations, edited parameter ranges, removed triples, new condition values
and measurements — are checked both ways on a seeded graph that already holds configurations (so a
narrowed range can break them). The verdict must be the same, and every violation the incremental
path reports must be one the whole-graph run reports too.
"""
from __future__ import annotations

from collections.abc import Iterator

import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from rdflib import Literal, URIRef
from rdflib.namespace import RDF, XSD

from nfex_core.kg import ChangeSet, KnowledgeGraph, parse_rdf
from nfex_core.kg.namespaces import NFEX, RDFS, SOSA
from nfex_core.kg.validation import validate_graph

BASE = """@prefix nfex: <https://w3id.org/nfex#> .
nfex:base_orb a nfex:Configuration ; nfex:ofExtractor nfex:ORB ; nfex:hasSetting nfex:base_orb_sf, nfex:base_orb_nf .
nfex:base_orb_sf a nfex:ParameterSetting ; nfex:parameter nfex:ORB_scaleFactor ; nfex:value 1.5 .
nfex:base_orb_nf a nfex:ParameterSetting ; nfex:parameter nfex:ORB_nfeatures ; nfex:value 2000 .
nfex:base_sift a nfex:Configuration ; nfex:ofExtractor nfex:SIFT ; nfex:hasSetting nfex:base_sift_ct .
nfex:base_sift_ct a nfex:ParameterSetting ; nfex:parameter nfex:SIFT_contrastThreshold ; nfex:value 0.02 .
nfex:seq a nfex:Sequence .
"""

PARAMS = ["ORB_scaleFactor", "ORB_nfeatures", "ORB_nlevels", "ORB_WTA_K", "SIFT_contrastThreshold", "SIFT_nfeatures", "BRISK_thresh"]


@pytest.fixture(scope="module")
def graph(tmp_path_factory: pytest.TempPathFactory, seeded_template) -> Iterator[tuple[KnowledgeGraph, object, object]]:  # type: ignore[no-untyped-def]
    import shutil

    path = tmp_path_factory.mktemp("agree") / "store"
    shutil.copytree(seeded_template, path, ignore=shutil.ignore_patterns("LOCK"))
    kg = KnowledgeGraph.open(str(path))
    kg.add(parse_rdf(BASE), author="test")
    yield kg, kg.data_graph(), kg.shapes()
    kg.close()


number = st.one_of(
    st.integers(-5, 30000).map(lambda i: Literal(i)),
    st.floats(-1, 3, allow_nan=False).map(lambda f: Literal(f, datatype=XSD.double)),
)


@st.composite
def new_configuration(draw) -> ChangeSet:  # type: ignore[no-untyped-def]
    n = draw(st.integers(0, 10**6))
    cfg = NFEX[f"cfg_{n}"]
    extractor = draw(st.sampled_from(["ORB", "SIFT", "BRISK"]))
    triples = [(cfg, RDF.type, NFEX.Configuration), (cfg, NFEX.ofExtractor, NFEX[extractor])]
    for k, param in enumerate(draw(st.lists(st.sampled_from(PARAMS), max_size=3))):
        s = NFEX[f"cfg_{n}_{k}"]
        triples += [(cfg, NFEX.hasSetting, s), (s, RDF.type, NFEX.ParameterSetting), (s, NFEX.parameter, NFEX[param])]
        triples.append((s, NFEX.value, draw(number)))
    return ChangeSet.adding(triples)


@st.composite
def edit_parameter(draw, data) -> ChangeSet:  # type: ignore[no-untyped-def]
    p = NFEX[draw(st.sampled_from(PARAMS))]
    prop = draw(st.sampled_from([NFEX.minValue, NFEX.maxValue, NFEX.defaultValue]))
    old = [(p, prop, o) for o in data.objects(p, prop)]
    return ChangeSet.of(added=[(p, prop, draw(number))], removed=old)


@st.composite
def remove_triple(draw, data) -> ChangeSet:  # type: ignore[no-untyped-def]
    p = NFEX[draw(st.sampled_from(PARAMS + ["ORB", "SIFT", "light_dark"]))]
    triples = sorted(data.triples((p, None, None)), key=str)
    return ChangeSet.removing([draw(st.sampled_from(triples))])


@st.composite
def new_condition_value(draw) -> ChangeSet:  # type: ignore[no-untyped-def]
    v = NFEX[f"value_{draw(st.integers(0, 10**6))}"]
    dims = draw(st.lists(st.sampled_from(["light", "texture", "motion"]), max_size=2, unique=True))
    token = draw(st.sampled_from(["dark", "low", "dusk", "Bad Token"]))
    return ChangeSet.adding([(v, RDF.type, NFEX.ConditionValue), (v, NFEX.token, Literal(token))] + [(v, NFEX.inDimension, NFEX[d]) for d in dims])


@st.composite
def new_measurement(draw) -> ChangeSet:  # type: ignore[no-untyped-def]
    m = NFEX[f"meas_{draw(st.integers(0, 10**6))}"]
    triples = [(m, RDF.type, NFEX.Measurement), (m, SOSA.usedProcedure, NFEX[draw(st.sampled_from(["base_orb", "base_sift", "nothing"]))])]
    if draw(st.booleans()):
        triples.append((m, NFEX.sequence, NFEX.seq))
    triples.append((m, NFEX.ateRmse, Literal(draw(st.floats(-1, 5, allow_nan=False)), datatype=XSD.double)))
    for c in draw(st.lists(st.sampled_from(["light_dark", "light_bright", "agent_car"]), max_size=2, unique=True)):
        triples.append((m, NFEX.underCondition, NFEX[c]))
    return ChangeSet.adding(triples)


@st.composite
def hub_note(draw) -> ChangeSet:  # type: ignore[no-untyped-def]
    """A note on a node many others point at, along a predicate no shape reads (Shapes.footprint)."""
    node = NFEX[draw(st.sampled_from(["ORB", "SIFT", "light_dark", "ORB_nfeatures"]))]
    return ChangeSet.adding([(node, RDFS.seeAlso, NFEX[f"note_{draw(st.integers(0, 10**6))}"])])


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(data=st.data())
def test_incremental_validation_agrees_with_whole_graph(graph, data) -> None:  # type: ignore[no-untyped-def]
    kg, base, shapes = graph
    kinds = [new_configuration(), edit_parameter(base), remove_triple(base), new_condition_value(), new_measurement(), hub_note()]
    changes = data.draw(st.lists(st.one_of(*kinds), min_size=1, max_size=2))
    change = ChangeSet()
    for c in changes:
        change = change.then(c)
    change = ChangeSet(added=change.added - set(base), removed=change.removed & set(base))
    incremental = kg.check(change)
    candidate = base - change.as_graph("removed") + change.as_graph("added")
    whole = validate_graph(candidate, shapes)
    assert incremental.conforms == whole.conforms, (incremental.text, whole.text)
    seen = {(r.focus_node, r.source_shape, r.message) for r in whole.violations}
    assert {(r.focus_node, r.source_shape, r.message) for r in incremental.violations} <= seen


def test_touching_a_shape_validates_the_whole_graph(graph) -> None:  # type: ignore[no-untyped-def]
    """A new shape applies to existing data: the write is checked against all of it."""
    kg, _, _ = graph
    shape = parse_rdf(
        """@prefix nfex: <https://w3id.org/nfex#> . @prefix sh: <http://www.w3.org/ns/shacl#> .
        nfex:NoBigORB a sh:NodeShape ; sh:targetClass nfex:Configuration ;
            sh:property [ sh:path ( nfex:hasSetting nfex:value ) ; sh:maxInclusive 1000 ] ."""
    )
    from nfex_core.kg import graph_triples

    report = kg.check(ChangeSet.adding(graph_triples(shape)))
    assert not report.conforms
    # base_orb, and any seeded sweep configuration (ontology/measurements/) with nfeatures 2000
    focus = {r.focus_node for r in report.violations}
    assert str(NFEX.base_orb) in focus
    assert all(f == str(NFEX.base_orb) or f.startswith(str(NFEX) + "cfg_") for f in focus)


def test_unchanged_graph_needs_no_validation(graph) -> None:  # type: ignore[no-untyped-def]
    kg, base, _ = graph
    assert kg.check(ChangeSet.adding([next(iter(base))])).conforms
    assert URIRef(NFEX.base_orb) in set(base.subjects())


def test_a_note_no_shape_reads_validates_its_own_node_only(graph) -> None:  # type: ignore[no-untyped-def]
    """``rdfs:seeAlso`` on ORB is outside every shape's footprint: no node pointing at ORB is validated again
    (before, every configuration of ORB and every Measurement of those was); a range edit on a parameter is
    inside it, and walks back to the configurations that set the parameter."""
    kg, _, _ = graph
    note = kg.check(ChangeSet.adding([(NFEX.ORB, RDFS.seeAlso, NFEX.note_x)]))
    assert note.conforms and note.focus_nodes == 1
    old = set(kg.data_graph().triples((NFEX.ORB_nfeatures, NFEX.maxValue, None)))
    edit = kg.check(ChangeSet.of(added=[(NFEX.ORB_nfeatures, NFEX.maxValue, Literal(5))], removed=old))
    assert edit.focus_nodes > 1
    assert any(r.focus_node == str(NFEX.base_orb) for r in edit.violations), edit.text  # its 2000 is now out of range


NESTED = """@prefix sh: <http://www.w3.org/ns/shacl#> . @prefix xsd: <http://www.w3.org/2001/XMLSchema#> .
@prefix ex: <https://example.org/> .
ex:ThingShape a sh:NodeShape ; sh:targetClass ex:Thing ;
    sh:property [ sh:path ex:size ; sh:or ( [ sh:datatype xsd:integer ] [ sh:datatype xsd:double ] ) ] ;
    sh:property [ sh:path ex:part ; sh:node ex:PartShape ] .
ex:PartShape a sh:NodeShape ; sh:property [ sh:path ex:label ; sh:minCount 1 ] .
"""
DATA = """@prefix ex: <https://example.org/> .
ex:a a ex:Thing ; ex:size "big" ; ex:part ex:pa .  ex:pa ex:note "no label" .
ex:b a ex:Thing ; ex:size "huge" ; ex:part ex:pb .  ex:pb ex:note "no label" .
ex:c a ex:Thing ; ex:size 3 .
"""


def test_a_focused_validation_checks_nested_shapes_and_only_its_focus() -> None:
    """Regression: pySHACL's own focus_nodes option lets an sh:or over a literal, or an sh:node on a value that
    is not a focus node, pass vacuously; the focus here narrows only the top-level targets."""
    from nfex_core.kg.validation import run_pyshacl, shapes_in

    shapes = shapes_in(parse_rdf(NESTED))
    data = parse_rdf(DATA)
    ex = "https://example.org/"
    whole, _ = run_pyshacl(data, shapes, None)
    # pySHACL reports the nested sh:node violation twice: on the Thing, and as its detail on the part
    assert {(r.focus_node, r.path) for r in whole} == {(ex + n, ex + p) for n in "ab" for p in ("size", "part")} | {
        (ex + "pa", ex + "label"), (ex + "pb", ex + "label")}
    focused, text = run_pyshacl(data, shapes, {URIRef(ex + "a"), URIRef(ex + "pa"), URIRef(ex + "c")})
    assert {(r.focus_node, r.path) for r in focused} == {(ex + "a", ex + "size"), (ex + "a", ex + "part"), (ex + "pa", ex + "label")}
    assert focused == [r for r in whole if r.focus_node in (ex + "a", ex + "pa")]
    assert "Conforms: False" in text
    assert run_pyshacl(data, shapes, {URIRef(ex + "c"), URIRef(ex + "pb")})[0] == []  # pb is b's part: b is not in focus
    assert run_pyshacl(data, shapes, None)[0] == whole  # the kept shapes graph is not left focused


@pytest.fixture
def writable(tmp_path, seeded_template) -> Iterator[tuple[KnowledgeGraph, object, object]]:  # type: ignore[no-untyped-def]
    import shutil

    shutil.copytree(seeded_template, tmp_path / "store", ignore=shutil.ignore_patterns("LOCK"))
    kg = KnowledgeGraph.open(str(tmp_path / "store"))
    kg.add(parse_rdf(BASE), author="test")
    yield kg, kg.data_graph(), kg.shapes()
    kg.close()


@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(data=st.data())
def test_neighbourhoods_kept_across_commits_read_what_the_store_holds(writable, data) -> None:  # type: ignore[no-untyped-def]
    """``Neighbourhood``: commit after commit, a validation from the kept neighbourhoods reads the same data graph
    and gives the same report as one that reads everything from the store."""
    from nfex_core.kg.validation import validate_change

    kg, base, shapes = writable
    kinds = [new_configuration(), edit_parameter(base), remove_triple(base), new_condition_value(), new_measurement(), hub_note()]
    for change in data.draw(st.lists(st.one_of(*kinds), min_size=1, max_size=5)):
        head = kg.version
        effective = kg._effective(change)
        if effective.empty:
            continue
        kept = validate_change(kg.backend, effective, shapes, cache=kg._neighbourhood.at(head))
        fresh = validate_change(kg.backend, effective, shapes)
        assert (kept.conforms, kept.data_triples, kept.focus_nodes) == (fresh.conforms, fresh.data_triples, fresh.focus_nodes)
        assert sorted(map(str, kept.violations)) == sorted(map(str, fresh.violations))
        if kept.conforms:
            kg.commit(change, author="pytest")  # validated again from the kept neighbourhoods, which it then carries
            assert kg._neighbourhood.version == kg.version


def test_results_that_tie_on_node_shape_and_message_come_in_one_order() -> None:
    """Two results of one shape on one node with one message (a value each) come out in the same order whatever the
    results graph's order: the SHACL worker's report equals this process's (a failing case of
    test_shacl_process.py, where the worker listed a measurement's two sh:class violations the other way round)."""
    import rdflib

    from nfex_core.kg.namespaces import SH
    from nfex_core.kg.validation import parse_report

    def results(order: list[str]) -> rdflib.Graph:
        g = rdflib.Graph()
        for v in order:
            r = URIRef(f"urn:r:{v}")
            for p, o in ((RDF.type, SH.ValidationResult), (SH.focusNode, NFEX.meas_0), (SH.sourceShape, NFEX.MeasurementShape),
                         (SH.resultPath, SOSA.usedProcedure), (SH.value, NFEX[v]), (SH.resultMessage, Literal("one configuration")),
                         (SH.resultSeverity, SH.Violation)):
                g.add((r, p, o))
        return g

    one, other = parse_report(results(["base_orb", "nothing"]), rdflib.Graph()), parse_report(results(["nothing", "base_orb"]), rdflib.Graph())
    assert [r.value for r in one] == [r.value for r in other] == [str(NFEX.base_orb), str(NFEX.nothing)]


TARGETS = """@prefix sh: <http://www.w3.org/ns/shacl#> . @prefix rdfs: <http://www.w3.org/2000/01/rdf-schema#> .
@prefix ex: <https://example.org/> .
ex:ByClass a sh:NodeShape ; sh:targetClass ex:A .
ex:ByNode a sh:NodeShape ; sh:targetNode ex:n1, ex:absent .
ex:BySubject a sh:NodeShape ; sh:targetSubjectsOf ex:p .
ex:ByObject a sh:NodeShape ; sh:targetObjectsOf ex:q .
ex:Implicit a sh:NodeShape, rdfs:Class .
ex:Several a sh:NodeShape ; sh:targetClass ex:B ; sh:targetObjectsOf ex:p ; sh:targetNode ex:n3 .
ex:Sparql a sh:NodeShape ; sh:target [ a sh:SPARQLTarget ; sh:select "SELECT ?this WHERE { ?this <https://example.org/q> ?x }" ] .
"""
TARGET_NODES = [f"n{i}" for i in range(5)] + ["absent", "A", "B", "C", "Implicit"]


@settings(max_examples=60, deadline=None)
@example(triples=[("n1", "type", "C"), ("C", "subClassOf", "B"), ("B", "subClassOf", "A"), ("n2", "type", "Implicit")],
         focus={"n1", "n2"})  # a subclass chain, and a shape that is a class
@given(triples=st.lists(st.tuples(st.sampled_from(TARGET_NODES), st.sampled_from(["type", "subClassOf", "p", "q", "r"]),
                                  st.sampled_from(TARGET_NODES)), max_size=14),
       focus=st.sets(st.sampled_from(TARGET_NODES), max_size=6))
def test_the_focus_nodes_a_shape_targets_are_pyshacls(triples, focus) -> None:  # type: ignore[no-untyped-def]
    """``_Targets.among`` (a shape's targets read from the focus nodes' side) lists what pySHACL's own
    ``focus_nodes`` lists of the focus nodes, for every kind of target: classes through a subclass chain of the
    data graph, an explicit node the graph lacks, the subjects or objects of a predicate, a shape that is a class;
    a SHACL-AF target is left to pySHACL (None)."""
    import rdflib
    from pyshacl.graph_abstraction import DataGraph

    from nfex_core.kg.pyshacl_focus import _Focus, _ShapesGraph
    from nfex_core.kg.validation import shapes_in

    ex = rdflib.Namespace("https://example.org/")
    preds = {"type": RDF.type, "subClassOf": RDFS.subClassOf, "p": ex.p, "q": ex.q, "r": ex.r}
    g = rdflib.Graph()
    for s, p, o in triples:
        g.add((ex[s], preds[p], ex[o]))
    data = DataGraph.from_rdflib(g)
    sg = _ShapesGraph(shapes_in(parse_rdf(TARGETS)).graph)
    nodes = frozenset(ex[n] for n in focus)
    facts = _Focus(nodes).facts(data)
    for shape in super(_ShapesGraph, sg).shapes:
        targets = sg._targets[shape.node]
        if shape.node == ex.Sparql:
            assert targets is None
            continue
        assert targets is not None
        assert set(targets.among(facts)) == {f for f in shape.focus_nodes(data) if f in nodes}, shape.node
