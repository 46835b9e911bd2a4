"""The change-set algebra that versions and rollbacks rest on (property tests)."""
from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st
from rdflib import Literal, URIRef

from nfex_core.kg import ChangeSet

triples = st.tuples(
    st.sampled_from([URIRef(f"urn:s{i}") for i in range(4)]),
    st.sampled_from([URIRef(f"urn:p{i}") for i in range(2)]),
    st.sampled_from([Literal(i) for i in range(3)]),
)
states = st.frozensets(triples, max_size=12)


def apply(state: frozenset, change: ChangeSet) -> frozenset:  # type: ignore[type-arg]
    return (state - change.removed) | change.added


def effective(state: frozenset, added: frozenset, removed: frozenset) -> ChangeSet:  # type: ignore[type-arg]
    c = ChangeSet.of(added, removed)
    return ChangeSet(added=c.added - state, removed=c.removed & state)


@given(states, states, states)
def test_inverse_undoes_an_effective_change(state, added, removed) -> None:  # type: ignore[no-untyped-def]
    c = effective(state, added, removed)
    assert apply(apply(state, c), c.inverse()) == state


@given(states, states, states, states, states)
def test_then_composes(state, a1, r1, a2, r2) -> None:  # type: ignore[no-untyped-def]
    c1 = effective(state, a1, r1)
    mid = apply(state, c1)
    c2 = effective(mid, a2, r2)
    assert apply(state, c1.then(c2)) == apply(mid, c2)


@given(states, st.lists(st.tuples(states, states), max_size=5))
def test_rollback_by_composed_inverses(state, steps) -> None:  # type: ignore[no-untyped-def]
    history = [state]
    changes = []
    for a, r in steps:
        c = effective(history[-1], a, r)
        changes.append(c)
        history.append(apply(history[-1], c))
    net = ChangeSet()
    for c in reversed(changes):
        net = net.then(c.inverse())
    assert apply(history[-1], net) == state


def test_read_rdf_file_reads_gzip_by_the_inner_suffix(tmp_path: Path) -> None:
    """Shipped measurement bundles are compressed N-Triples or Turtle (`kg add x.nt.gz`)."""
    import gzip

    from nfex_core.errors import BadInput, ParseError
    from nfex_core.kg.storage.changes import read_rdf_file

    text = "<urn:a> <urn:p> \"1\" .\n<urn:b> <urn:p> <urn:a> .\n"
    (tmp_path / "m.nt.gz").write_bytes(gzip.compress(text.encode()))
    (tmp_path / "m.nt").write_text(text)
    assert set(read_rdf_file(tmp_path / "m.nt.gz")) == set(read_rdf_file(tmp_path / "m.nt")) and len(read_rdf_file(tmp_path / "m.nt")) == 2
    with pytest.raises(ParseError, match="unknown RDF file type '.csv'"):
        read_rdf_file(tmp_path / "m.csv.gz")
    (tmp_path / "bad.ttl.gz").write_bytes(b"not gzip at all")
    with pytest.raises(BadInput, match="cannot read"):
        read_rdf_file(tmp_path / "bad.ttl.gz")
