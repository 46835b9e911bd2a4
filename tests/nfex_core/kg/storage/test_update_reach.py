"""Which triples an update can read or delete: the patterns ``sparql_update`` copies instead of the graph."""
from __future__ import annotations

import pytest
from rdflib import URIRef

from nfex_core.kg.storage.update_reach import EVERYTHING, Reach, only_inserts_data, reach

P = "PREFIX ex: <http://example.org/> "
A, B, PP, Q = (URIRef(f"http://example.org/{x}") for x in ("a", "b", "p", "q"))


@pytest.mark.parametrize(
    ("update", "expected"),
    [
        ("INSERT DATA { ex:a ex:p 'x'@en-GB , true , 1e5 }", Reach()),
        ("DELETE DATA { ex:a ex:p ex:b . ex:b ex:q 'lit' }", Reach(frozenset({(A, PP, B), (B, Q, None)}))),
        ("DELETE WHERE { ex:a ?p ?o }", Reach(frozenset({(A, None, None)}))),
        ("INSERT { ?s ?p ?o } WHERE { ?s ex:p ex:b }", Reach(frozenset({(None, PP, B)}))),
        ("DELETE { ?s ex:q ?o } WHERE { ?s ex:p+/^ex:q ?o }", Reach(frozenset({(None, Q, None), (None, PP, None)}))),
        ("INSERT { ?c ex:q 1 } WHERE { ?c ex:p* ex:a }", Reach(frozenset({(None, PP, None), (A, None, None), (None, None, A)}))),
        ("INSERT { ?x ex:q 1 } WHERE { FILTER NOT EXISTS { ex:b ex:q ?x } }", Reach(frozenset({(B, Q, None)}))),
        ("DELETE { ?s ?p ?o } WHERE { ?s ?p ?o }", EVERYTHING),
        ("DELETE { ?s ex:p ?o } WHERE { ?s ex:p* ?o }", EVERYTHING),
        ("DELETE { ?s ex:p ?o } WHERE { ?s !ex:q ?o }", EVERYTHING),
        ("BASE <http://example.org/> DELETE WHERE { <a> ?p ?o }", None),
        ("DELETE WHERE { <http://example.org/\\u0061> ?p ?o }", None),
        ("DELETE WHERE { ex:a\\.b ?p ?o }", None),
        ("DELETE WHERE { ex:a ?p ?o", None),
    ],
)
def test_reach(update: str, expected: Reach | None) -> None:
    assert reach(P + update) == expected


def test_only_a_modify_reads_the_graph() -> None:
    assert only_inserts_data(P + "INSERT DATA { ex:a ex:p 'DELETE WHERE' } ; INSERT DATA { GRAPH ex:g { ex:a a ex:b } }")
    assert not only_inserts_data(P + "INSERT { ex:a ex:p 1 } WHERE {}")
    assert not only_inserts_data(P + "DELETE DATA { ex:a ex:p 1 }")
