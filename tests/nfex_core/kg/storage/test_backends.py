"""kg/storage/backends.py: what the embedded store answers by its own means gives what the SPARQL path gives."""
from __future__ import annotations

import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from rdflib import Literal, URIRef
from rdflib.namespace import XSD

from nfex_core.errors import ParseError
from nfex_core.kg.rdf.terms import triple_nt
from nfex_core.kg.storage.backends import Backend, EmbeddedBackend

EX = "https://example.org/"
iri = st.sampled_from("abc").map(lambda s: URIRef(EX + s))
literal = st.one_of(
    st.sampled_from(["1", "01", "+1", "-0"]).map(lambda s: Literal(s, datatype=XSD.integer)),
    st.sampled_from(["0.0", "1.50", "2", "abc"]).map(lambda s: Literal(s, datatype=XSD.decimal)),  # "abc": ill-typed
    st.sampled_from(["1.0", "1e0", "NaN"]).map(lambda s: Literal(s, datatype=XSD.double)),
    st.sampled_from(["x", ""]).map(lambda s: Literal(s, datatype=XSD.string)),
    st.sampled_from(["x", "", 'a "q"\nline']).map(Literal),
    st.sampled_from(["x", "X"]).map(lambda s: Literal(s, lang="en")),
)
triple = st.tuples(st.one_of(iri, literal), iri, st.one_of(iri, literal))


@settings(max_examples=60, deadline=None)
@example(stored=[(URIRef(EX + "a"), URIRef(EX + "b"), Literal("x", datatype=XSD.string)),
                 (URIRef(EX + "a"), URIRef(EX + "b"), Literal("1.50", datatype=XSD.decimal))], asked=[], named=False)
@given(stored=st.lists(triple, max_size=8), asked=st.lists(triple, max_size=12), named=st.booleans())
def test_present_by_lookup_is_present_by_query(stored, asked, named) -> None:  # type: ignore[no-untyped-def]
    """``EmbeddedBackend.present`` (each triple looked up in the indexes) finds what the VALUES query of
    ``Backend.present`` finds: the same literal in another lexical form (``"01"`` and ``"1"``, xsd:string and
    plain), a literal where no store puts one, in the default graph or in a named one (NFEX_STORE_GRAPH)."""
    backend = EmbeddedBackend(None, graph=EX + "knowledge" if named else None)
    lines = "\n".join(triple_nt(t) for t in stored if not isinstance(t[0], Literal))
    if lines:
        backend.update(f"INSERT DATA {{ {backend.graph_block(lines)} }}")
    by_query = Backend.present(backend, asked + stored)
    assert backend.present(asked + stored) == by_query
    assert {t for t in stored if not isinstance(t[0], Literal)} <= by_query <= set(asked + stored)  # as given


def test_a_term_the_store_refuses_fails_as_the_query_fails() -> None:
    """An IRI Oxigraph refuses (a space) is not looked up, and fails as the query fails (a ParseError)."""
    backend = EmbeddedBackend(None)
    bad = (URIRef(EX + "a b"), URIRef(EX + "p"), URIRef(EX + "c"))
    with pytest.raises(ParseError):
        backend.present([bad])
