"""Stars and signs (kg/storage/footprint.py ``anchors``, ``change_effect``): a change that misses every pattern's star leaves
a query's answer as it was, and one that only adds to its negative patterns (or removes from its positive ones) only
takes rows out; and the triples in a query's reach (``Reach``) answer it as the whole graph does.

The property test draws a small graph, a change and a query from a handful of shapes (stars, paths, OPTIONAL,
subqueries with COUNT, MINUS and nested MINUS, NOT EXISTS, constant subjects), and checks with Oxigraph: where
``change_effect`` says ``NONE``, the answers before and after are the same multiset; where it says ``SHRINKS``, each
row after is one before, at most as often."""
from __future__ import annotations

from collections import Counter
from pathlib import Path

import pyoxigraph as ox
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from rdflib import RDF, URIRef

from nfex_core.kg.storage.footprint import Anchor, Delta, Effect, Reach, anchors, change_effect

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
    "SELECT ?x WHERE { ?x a :A . MINUS { ?x :p ?y . MINUS { ?y :q :B } } }",
    "SELECT ?x WHERE { ?x :p :B . FILTER NOT EXISTS { ?x :q :A } }",
    "SELECT ?x ?y WHERE { ?x :p :A . OPTIONAL { ?x :q ?y } MINUS { ?x :r ?y } }",
    "SELECT ?x WHERE { { SELECT ?x WHERE { ?x a :A ; :p :B . MINUS { ?x :p :B . ?c :q ?x . ?m :r ?c ; :p :A , :B } } } }",
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


@pytest.mark.parametrize("query", QUERIES)
@settings(max_examples=200, deadline=None)
@given(graph=st.sets(TRIPLES, max_size=14), add=st.sets(TRIPLES, max_size=3), remove=st.sets(TRIPLES, max_size=3))
def test_a_change_that_misses_every_star_keeps_the_answer(graph: set, add: set, remove: set, query: str) -> None:
    removed = (remove & graph) - add
    added = add - graph
    after = (graph - removed) | added
    found = anchors(P + query)
    assert found is not None
    reach = Reach.of(found)  # the triples it can read answer it as the whole graph does
    assert _answer(_store({t for t in graph if reach.holds(t)}), query) == _answer(_store(graph), query)
    effect = change_effect(found, Delta(frozenset(added), frozenset(removed)), _holds(after, []))
    before, now = _answer(_store(graph), query), _answer(_store(after), query)
    if effect is Effect.NONE:
        assert before == now
    elif effect is Effect.SHRINKS:
        assert now <= before


def test_a_match_of_an_optional_or_an_aggregate_moves_the_answer_either_way() -> None:
    """An OPTIONAL's match replaces a row with its unbound variable (x, –) by (x, y): not a row of the answer before;
    a COUNT moves up, and so out of a HAVING it passed. Neither is a shrinking answer, whatever MINUS stands around."""
    s0, q, b = URIRef(E + "s0"), URIRef(E + "q"), URIRef(E + "B")
    graph = {(s0, URIRef(E + "p"), URIRef(E + "A")), (s0, q, URIRef(E + "A"))}
    for query in ("SELECT ?x ?y WHERE { ?x :p :A . OPTIONAL { ?x :q ?y } MINUS { ?x :r ?y } }",
                  "SELECT ?x WHERE { ?x :p :A . MINUS { SELECT ?x WHERE { ?x :q ?y } GROUP BY ?x HAVING (COUNT(?y) < 2) } }"):
        found = anchors(P + query)
        assert found is not None
        assert _answer(_store(graph | {(s0, q, b)}), query) != _answer(_store(graph), query)
        assert change_effect(found, Delta(frozenset({(s0, q, b)}), frozenset()), _holds(graph | {(s0, q, b)}, [])) is Effect.ANY


def test_a_path_of_length_zero_between_variables_reads_every_node() -> None:
    """``?x :q* ?y`` pairs every node of the graph with itself, so any triple can change its answer."""
    assert anchors(P + "SELECT ?x ?y WHERE { ?x :q* ?y }") is None
    assert anchors(P + "SELECT ?x WHERE { ?x :q?/:r? ?x }") is None
    assert anchors(P + "SELECT ?y WHERE { :s0 :q* ?y }") is not None  # from a constant: (s0, s0) whatever the graph


def test_a_constant_subject_narrows_a_pattern_to_its_triples() -> None:
    found = anchors(P + "SELECT ?n WHERE { :s0 :p ?n . ?x :q ?n }")
    assert found is not None
    s0, s1, p = URIRef(E + "s0"), URIRef(E + "s1"), URIRef(E + "p")
    assert change_effect(found, Delta(frozenset({(s0, p, URIRef(E + "A"))}), frozenset()), _holds(set(), [])) is Effect.ANY
    assert change_effect(found, Delta(frozenset({(s1, p, URIRef(E + "A"))}), frozenset()), _holds(set(), [])) is Effect.NONE
    reach = Reach.of(found)
    assert reach.holds((s0, p, s1)) and not reach.holds((s1, p, s0)) and reach.holds((s1, URIRef(E + "q"), s0))


def test_the_expert_rule_reads_only_a_measurement_under_car_and_fast_and_then_only_shrinks() -> None:
    """rules/pruning/expert-fast-car-gradient-histograms.rq: a report under car + dark misses the star of its MINUS, one
    under car + fast only takes extractors out (so once the rule is silent it stays silent), and one removed may
    bring one back; the subject's star is asked of the graph only for what the change does not settle."""
    n, sosa = "https://w3id.org/nfex#", "http://www.w3.org/ns/sosa/"
    found = anchors((Path(__file__).resolve().parents[4] / "rules/pruning/expert-fast-car-gradient-histograms.rq").read_text())
    assert found is not None
    star = frozenset({(RDF.type, URIRef(n + "Measurement")), (URIRef(n + "underCondition"), URIRef(n + "agent_car")),
                      (URIRef(n + "underCondition"), URIRef(n + "motion_fast"))})
    assert Anchor(URIRef(sosa + "usedProcedure"), None, star, sign=-1) in found
    assert Anchor(URIRef(n + "ofExtractor"), None, frozenset(), sign=-1) in found
    m, cfg = URIRef(n + "m_new"), URIRef(n + "cfg")
    report = {(m, RDF.type, URIRef(n + "Measurement")), (m, URIRef(sosa + "usedProcedure"), cfg),
              (m, URIRef(n + "underCondition"), URIRef(n + "agent_car")), (m, URIRef(n + "underCondition"), URIRef(n + "light_dark"))}
    asked: list[set] = []
    assert change_effect(found, Delta(frozenset(report), frozenset()), _holds(report, asked)) is Effect.NONE
    assert asked == [{(m, URIRef(n + "underCondition"), URIRef(n + "motion_fast"))}]
    fast = report | {(m, URIRef(n + "underCondition"), URIRef(n + "motion_fast"))}
    assert change_effect(found, Delta(frozenset(fast), frozenset()), _holds(fast, [])) is Effect.SHRINKS
    # the missing condition already in the graph (added to a Measurement that had it): the change is read
    assert change_effect(found, Delta(frozenset(report), frozenset()), _holds(fast, [])) is Effect.SHRINKS
    # a holds that cannot tell: anything
    assert change_effect(found, Delta(frozenset(report), frozenset()), lambda ts: None) is Effect.ANY
    # a removal is judged by the graph before the change: motion_fast removed with the rest may bring a prune back
    assert change_effect(found, Delta(frozenset(), frozenset(fast)), _holds(set(), [])) is Effect.ANY
    assert change_effect(found, Delta(frozenset(), frozenset(report)), _holds(set(), [])) is Effect.NONE
    # a configuration's extractor reaches every Measurement through it
    assert change_effect(found, Delta(frozenset({(cfg, URIRef(n + "ofExtractor"), URIRef(n + "SIFT"))}), frozenset()),
                         _holds(set(), [])) is Effect.SHRINKS
    # a new gradient-histogram extractor is read both ways (the rule may prune it)
    x = URIRef(n + "NEWX")
    new = {(x, RDF.type, URIRef(n + "FeatureExtractor")), (x, URIRef(n + "performs"), URIRef(n + "GradientHistogram"))}
    assert change_effect(found, Delta(frozenset(new), frozenset()), _holds(new, [])) is Effect.ANY
