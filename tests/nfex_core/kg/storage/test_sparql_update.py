"""change_of_update copies only what an update can read, and gives the change set of the whole-graph copy.

The reference is ``change_by_copy`` (the update run on a copy of the whole default graph, then diffed);
the property test runs both on random updates — INSERT/DELETE DATA, DELETE WHERE, DELETE/INSERT … WHERE
with OPTIONAL, MINUS, FILTER (NOT) EXISTS, UNION, VALUES, subqueries and property paths, several
operations in one request — over random small graphs, and wants the same change set or the same error.
"""
from __future__ import annotations

from collections.abc import Callable

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from rdflib import Literal, URIRef

from nfex_core.errors import BadInput, NfexError, ParseError
from nfex_core.kg.storage.backends import EmbeddedBackend
from nfex_core.kg.storage.changes import ChangeSet
from nfex_core.kg.storage.sparql_gate import ForbiddenOperation
from nfex_core.kg.storage.sparql_update import change_by_copy, change_of_update

PREFIXES = "PREFIX ex: <http://example.org/> PREFIX xsd: <http://www.w3.org/2001/XMLSchema#>\n"
IRIS = ["ex:a", "ex:b", "ex:c", "ex:d"]
PREDICATES = ["ex:p", "ex:q", "a"]
LITERALS = ['"x"', '"x"@en', "1", '"01"^^xsd:integer', "2.50", "true", '"y"']
VARS = ["?x", "?y", "?z"]
PATHS = ["ex:p|ex:q", "ex:p/ex:q", "^ex:p", "ex:p*", "ex:p+", "ex:q?", "!ex:p", "(ex:p/ex:q)*", "ex:p/ex:q*", "^ex:q/ex:p?"]

iri = st.sampled_from(IRIS)
obj = st.sampled_from(IRIS + LITERALS)
var = st.sampled_from(VARS)
ground = st.builds(lambda s, p, o: f"{s} {p} {o} .", iri, st.sampled_from(PREDICATES), obj)
node = st.one_of(iri, var)
pattern = st.builds(lambda s, p, o: f"{s} {p} {o} .", node, st.one_of(st.sampled_from(PREDICATES), var), st.one_of(obj, var))
path_pattern = st.builds(lambda s, p, o: f"{s} {p} {o} .", node, st.sampled_from(PATHS), st.one_of(iri, var))
simple = st.one_of(pattern, pattern, path_pattern)


def group(body: st.SearchStrategy[str]) -> st.SearchStrategy[str]:
    return st.one_of(
        body,
        body.map(lambda t: f"OPTIONAL {{ {t} }}"),
        body.map(lambda t: f"FILTER NOT EXISTS {{ {t} }}"),
        body.map(lambda t: f"FILTER EXISTS {{ {t} }}"),
        body.map(lambda t: f"MINUS {{ {t} }}"),
        st.builds(lambda a, b: f"{{ {a} }} UNION {{ {b} }}", body, body),
        st.builds(lambda v, a, b: f"VALUES {v} {{ {a} {b} }}", var, iri, iri),
        st.builds(lambda v, a: f"FILTER ({v} != {a})", var, iri),
        body.map(lambda t: f"{{ SELECT ?x (COUNT(*) AS ?n) WHERE {{ {t} }} GROUP BY ?x }}"),
    )


where = st.lists(group(simple), min_size=1, max_size=3).map(" ".join)
template = st.lists(pattern, min_size=1, max_size=2).map(" ".join)
insert_template = st.one_of(template, template, st.just("?x ex:q [ ex:p ?y ] ."), st.just("GRAPH ex:g { ?x ex:p ?y }"))
operation = st.one_of(
    st.lists(ground, min_size=1, max_size=3).map(lambda ts: f"INSERT DATA {{ {' '.join(ts)} }}"),
    st.lists(ground, min_size=1, max_size=3).map(lambda ts: f"DELETE DATA {{ {' '.join(ts)} }}"),
    st.lists(pattern, min_size=1, max_size=2).map(lambda ts: f"DELETE WHERE {{ {' '.join(ts)} }}"),
    st.builds(lambda d, i, w: f"DELETE {{ {d} }} INSERT {{ {i} }} WHERE {{ {w} }}", template, insert_template, where),
    st.builds(lambda i, w: f"INSERT {{ {i} }} WHERE {{ {w} }}", insert_template, where),
    st.builds(lambda d, w: f"DELETE {{ {d} }} WHERE {{ {w} }}", template, where),
)
updates = st.lists(operation, min_size=1, max_size=3).map(lambda ops: PREFIXES + " ;\n".join(ops))
graphs = st.lists(ground, max_size=14)


def store_of(triples: list[str], graph: str | None = None) -> EmbeddedBackend:
    """An in-memory store holding ``triples`` in its knowledge graph (``graph``: a named one, NFEX_STORE_GRAPH)."""
    backend = EmbeddedBackend(None, graph=graph)
    if triples:
        backend.update(PREFIXES + "INSERT DATA { " + backend.graph_block(" ".join(triples)) + " }")
    return backend


def outcome(fn: Callable[[EmbeddedBackend, str], ChangeSet], backend: EmbeddedBackend, update: str) -> ChangeSet | tuple[str, str]:
    try:
        return fn(backend, update)
    except NfexError as e:
        return type(e).__name__, str(e)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(graphs, updates, st.sampled_from([None, "urn:nfex:test:knowledge"]))
def test_the_change_set_is_that_of_the_whole_graph_copy(triples: list[str], update: str, graph: str | None) -> None:
    backend = store_of(triples, graph)
    assert outcome(change_of_update, backend, update) == outcome(change_by_copy, backend, update)


@pytest.mark.parametrize(
    "update",
    [
        "INSERT DATA { ex:a ex:p ex:b . ex:new ex:p 1 }",  # one triple is already there: not added
        "DELETE DATA { ex:a ex:p ex:b . ex:a ex:p ex:zzz }",  # one is absent: not removed
        "INSERT DATA { ex:a ex:p ex:c } ; DELETE WHERE { ex:a ex:p ?o }",  # a later operation sees the earlier one
        "DELETE WHERE { ex:a ex:p ?o } ; INSERT DATA { ex:a ex:p ex:b }",  # deleted, then put back: no change
        "INSERT { ?x ex:q ?x } WHERE { ?x ex:p* ?x }",  # a zero-length path between variables: every node
        "INSERT { ex:a ex:q ?y } WHERE { ex:a ex:p* ?y }",  # zero-length from an IRI: ex:a itself
        "INSERT { ex:zz ex:q ?y } WHERE { ex:zz ex:p? ?y }",  # … from an IRI the graph does not hold
        "DELETE { ?s ?p ?o } WHERE { ?s ?p ?o FILTER (?o = 1) }",  # nothing bounds the pattern: everything
        "DELETE { ?s ex:p ?o } WHERE { ?s !ex:q ?o }",
        "INSERT { ?s ex:q 2 } WHERE { ?s ex:p \"01\"^^xsd:integer }",  # literals are read by their value
    ],
)
def test_edge_cases_agree_with_the_copy(update: str) -> None:
    backend = store_of(["ex:a ex:p ex:b .", "ex:b ex:p ex:c .", "ex:c ex:p 1 .", "ex:b ex:q ex:b ."])
    assert outcome(change_of_update, backend, PREFIXES + update) == outcome(change_by_copy, backend, PREFIXES + update)


def test_an_insert_data_reads_nothing_but_what_it_inserts() -> None:
    backend = store_of(["ex:a ex:p ex:b ."])
    change = change_of_update(backend, PREFIXES + "INSERT DATA { ex:a ex:p ex:b . ex:n ex:p 'new' }")
    assert change == ChangeSet(added=frozenset({(URIRef("http://example.org/n"), URIRef("http://example.org/p"), Literal("new"))}))


@pytest.mark.parametrize(
    ("update", "error", "match"),
    [
        ("", BadInput, "empty"),
        ("INSERT NONSENSE", ParseError, "invalid SPARQL update"),
        ("DELETE { ?s ?p ?o } WHERE { ?s ?p ?o", ParseError, "invalid SPARQL update"),
        ("INSERT DATA { GRAPH <urn:x> { <urn:a> <urn:b> <urn:c> } }", BadInput, "named graphs"),
        ("INSERT { ?s <urn:p> [] } WHERE { ?s ?p ?o }", BadInput, "blank nodes"),
        ("INSERT DATA { <urn:a> <urn:p> [ <urn:q> 1 ] }", BadInput, "blank nodes"),
        ("LOAD <http://example.org/x>", ForbiddenOperation, "LOAD"),
    ],
)
def test_refusals_are_those_of_the_copy(update: str, error: type[Exception], match: str) -> None:
    backend = store_of(["ex:a ex:p ex:b ."])
    with pytest.raises(error, match=match):
        change_of_update(backend, update)
    assert outcome(change_of_update, backend, update) == outcome(change_by_copy, backend, update)
