"""Stars (kg/footprint.py ``anchors``, ``change_reads``): a change that misses every pattern's star leaves a query's
answer as it was; and the triples in a query's reach (``Reach``) answer it as the whole graph does.

The property test draws a small graph, a change and a query from a handful of shapes (stars, paths, OPTIONAL,
subqueries with COUNT, MINUS, constant subjects), and checks with Oxigraph: where ``change_reads`` says no, the
answers before and after are the same multiset."""
from __future__ import annotations

from collections import Counter

import pyoxigraph as ox
from hypothesis import given, settings
from hypothesis import strategies as st
from rdflib import RDF, URIRef

from nfex_core.kg.footprint import Anchor, Delta, Reach, anchors, change_reads

E = "http://example.org/"
P = f"PREFIX : <{E}> "
S = [URIRef(E + f"s{i}") for i in range(4)]
PREDICATES = [RDF.type, URIRef(E + "p"), URIRef(E + "q"), URIRef(E + "r")]
OBJECTS = [URIRef(E + "A"), URIRef(E + "B"), *S[:2]]
QUERIES = [
    "SELECT ?x ?y WHERE { ?x a :A ; :p :B ; :q ?y }",
    "SELECT ?x (COUNT(?m) AS ?n) WHERE { ?x a :A . OPTIONAL { SELECT ?x (COUNT(?m) AS ?c) WHERE { ?m :p :A , :B ; :q/:r ?x } GROUP BY ?x } "
    "OPTIONAL { ?m :p ?x } } GROUP BY ?x",
    "SELECT ?x ?y WHERE { ?x :p :A . ?y ^:q ?x }",
    "SELECT ?x WHERE { ?x a :B . MINUS { ?x :r :A } }",
    "SELECT ?y ?z WHERE { :s0 :p ?y . :s1 :q*/:r ?z }",
    "SELECT ?x ?y WHERE { :s0 :p ?y ; :r ?y . :s1 :q ?x }",
    "SELECT ?x WHERE { ?x :p :A , ?o . ?o a :B }",
    "SELECT ?x WHERE { [] :p :B ; :q ?x }",
]
TRIPLES = st.tuples(st.sampled_from(S), st.sampled_from(PREDICATES), st.sampled_from(OBJECTS))


def _store(triples: set[tuple[URIRef, URIRef, URIRef]]) -> ox.Store:
    store = ox.Store()
    store.extend(ox.Quad(ox.NamedNode(s), ox.NamedNode(p), ox.NamedNode(o), ox.DefaultGraph()) for s, p, o in triples)
    return store


def _answer(store: ox.Store, query: str) -> Counter[tuple[str, ...]]:
    res = store.query(P + query)
    assert isinstance(res, ox.QuerySolutions)
    names = [v.value for v in res.variables]
    return Counter(tuple(str(row[n]) for n in names) for row in res)


def _holds(graph: set[tuple[URIRef, URIRef, URIRef]], asked: list[set[tuple[URIRef, URIRef, URIRef]]]):  # type: ignore[no-untyped-def]
    def holds(triples):  # type: ignore[no-untyped-def]
        asked.append(set(triples))
        return {t for t in triples if t in graph}
    return holds


@settings(max_examples=300, deadline=None)
@given(graph=st.sets(TRIPLES, max_size=14), add=st.sets(TRIPLES, max_size=3), remove=st.sets(TRIPLES, max_size=3),
       query=st.sampled_from(QUERIES))
def test_a_change_that_misses_every_star_keeps_the_answer(graph: set, add: set, remove: set, query: str) -> None:
    removed = (remove & graph) - add
    added = add - graph
    after = (graph - removed) | added
    found = anchors(P + query)
    assert found is not None
    reach = Reach.of(found)  # the triples it can read answer it as the whole graph does
    assert _answer(_store({t for t in graph if reach.holds(t)}), query) == _answer(_store(graph), query)
    if change_reads(found, Delta(frozenset(added), frozenset(removed)), _holds(after, [])):
        return
    assert _answer(_store(graph), query) == _answer(_store(after), query)


def test_a_path_of_length_zero_between_variables_reads_every_node() -> None:
    """``?x :q* ?y`` pairs every node of the graph with itself, so any triple can change its answer."""
    assert anchors(P + "SELECT ?x ?y WHERE { ?x :q* ?y }") is None
    assert anchors(P + "SELECT ?x WHERE { ?x :q?/:r? ?x }") is None
    assert anchors(P + "SELECT ?y WHERE { :s0 :q* ?y }") is not None  # from a constant: (s0, s0) whatever the graph


def test_a_constant_subject_narrows_a_pattern_to_its_triples() -> None:
    found = anchors(P + "SELECT ?n WHERE { :s0 :p ?n . ?x :q ?n }")
    assert found is not None
    s0, s1, p = URIRef(E + "s0"), URIRef(E + "s1"), URIRef(E + "p")
    assert change_reads(found, Delta(frozenset({(s0, p, URIRef(E + "A"))}), frozenset()), _holds(set(), []))
    assert not change_reads(found, Delta(frozenset({(s1, p, URIRef(E + "A"))}), frozenset()), _holds(set(), []))
    reach = Reach.of(found)
    assert reach.holds((s0, p, s1)) and not reach.holds((s1, p, s0)) and reach.holds((s1, URIRef(E + "q"), s0))


def test_the_expert_rules_count_reads_only_a_measurement_under_car_and_fast() -> None:
    """The shape of rules/pruning/expert-fast-car-gradient-histograms.rq: a report under car + dark misses its
    star, one under car + fast does not; the subject's star is asked of the graph only for what the change does
    not settle."""
    n, sosa = "https://w3id.org/nfex#", "http://www.w3.org/ns/sosa/"
    query = (f"PREFIX nfex: <{n}> PREFIX sosa: <{sosa}> SELECT ?x (COUNT(?m) AS ?c) WHERE {{ ?m a nfex:Measurement ; "
             "sosa:usedProcedure/nfex:ofExtractor ?x ; nfex:underCondition nfex:agent_car, nfex:motion_fast } GROUP BY ?x")
    found = anchors(query)
    assert found is not None
    star = frozenset({(RDF.type, URIRef(n + "Measurement")), (URIRef(n + "underCondition"), URIRef(n + "agent_car")),
                      (URIRef(n + "underCondition"), URIRef(n + "motion_fast"))})
    assert Anchor(URIRef(sosa + "usedProcedure"), None, star) in found
    assert Anchor(URIRef(n + "ofExtractor"), None, frozenset()) in found  # the path's second step: any subject
    m, cfg = URIRef(n + "m_new"), URIRef(n + "cfg")
    report = {(m, RDF.type, URIRef(n + "Measurement")), (m, URIRef(sosa + "usedProcedure"), cfg),
              (m, URIRef(n + "underCondition"), URIRef(n + "agent_car")), (m, URIRef(n + "underCondition"), URIRef(n + "light_dark"))}
    asked: list[set] = []
    assert not change_reads(found, Delta(frozenset(report), frozenset()), _holds(report, asked))
    assert asked == [{(m, URIRef(n + "underCondition"), URIRef(n + "motion_fast"))}]
    fast = report | {(m, URIRef(n + "underCondition"), URIRef(n + "motion_fast"))}
    assert change_reads(found, Delta(frozenset(fast), frozenset()), _holds(fast, []))
    # the missing condition already in the graph (added to a Measurement that had it): the change is read
    assert change_reads(found, Delta(frozenset(report), frozenset()), _holds(fast, []))
    # a holds that cannot tell: read
    assert change_reads(found, Delta(frozenset(report), frozenset()), lambda ts: None)
    # a removal is judged by the graph before the change: motion_fast removed with the rest
    assert change_reads(found, Delta(frozenset(), frozenset(fast)), _holds(set(), []))
    assert not change_reads(found, Delta(frozenset(), frozenset(report)), _holds(set(), []))
    # a change of a configuration's extractor reaches every Measurement through the path
    assert change_reads(found, Delta(frozenset({(cfg, URIRef(n + "ofExtractor"), URIRef(n + "SIFT"))}), frozenset()), _holds(set(), []))
