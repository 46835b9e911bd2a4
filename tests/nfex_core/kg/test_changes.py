"""The change-set algebra that versions and rollbacks rest on (property tests)."""
from __future__ import annotations

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
