"""kg/rdf/terms.py: Oxigraph's terms as rdflib's, converted once per process (term_converter's memo), and the same
whether the memo holds them or not."""
from __future__ import annotations

import pyoxigraph as ox
import pytest
from hypothesis import given
from hypothesis import strategies as st

from nfex_core.kg.rdf import terms
from nfex_core.kg.rdf.terms import from_oxigraph, term_converter

XSD = "http://www.w3.org/2001/XMLSchema#"
oxterm = st.one_of(
    st.text(alphabet="abcxyz0123456789", min_size=1, max_size=8).map(lambda s: ox.NamedNode("https://example.org/" + s)),
    st.integers(-10, 10).map(lambda i: ox.Literal(str(i), datatype=ox.NamedNode(XSD + "integer"))),
    st.sampled_from(["0.0", "1.50", "2"]).map(lambda s: ox.Literal(s, datatype=ox.NamedNode(XSD + "decimal"))),
    st.text(max_size=5).map(lambda s: ox.Literal(s)),
    st.text(max_size=5).map(lambda s: ox.Literal(s, language="en")),
)


@given(st.lists(oxterm, max_size=30), st.booleans())
def test_the_memo_gives_what_a_fresh_conversion_gives(items: list[object], as_written: bool) -> None:
    convert = term_converter(as_written=as_written)
    for term in items + items:  # the second pass is answered from the memo
        got, want = convert(term), from_oxigraph(term, as_written=as_written)
        assert got == want and type(got) is type(want) and str(got) == str(want)


def test_terms_alike_in_text_stay_apart() -> None:
    """The memo is keyed by the whole term: the same text as an IRI, a plain, typed or tagged literal, read
    as written or canonically, is converted to four different terms, each every time."""
    decimal = ox.NamedNode(XSD + "decimal")
    items = [ox.Literal("1.50", datatype=decimal), ox.Literal("1.50"), ox.Literal("1.50", language="en"), ox.NamedNode("https://example.org/1.50")]
    for _ in range(2):
        plain_read = [term_converter()(t) for t in items]
        written = [term_converter(as_written=True)(t) for t in items]
        assert len(set(plain_read)) == 4 and str(plain_read[0]) == "1.5"  # canonical: the memo of one mode…
        assert str(written[0]) == "1.50"  # …is not the other's


def test_the_memo_is_bounded(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(terms, "CONVERTED_MAX", 5)
    convert = term_converter()
    for i in range(50):
        convert(ox.NamedNode(f"https://example.org/n{i}"))
        assert len(terms._CONVERTED[False]) <= 5  # noqa: SLF001
    assert convert(ox.NamedNode("https://example.org/n3")) == from_oxigraph(ox.NamedNode("https://example.org/n3"))
