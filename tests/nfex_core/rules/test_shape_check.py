"""Repairing a bound: the clamped value satisfies the bound (pySHACL's comparison) and the parameter's range."""
from __future__ import annotations

import math

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from rdflib import Literal
from rdflib.namespace import XSD

from nfex_core.kg import KnowledgeGraph
from nfex_core.kg.vocabulary.vocab import Vocabulary
from nfex_core.rules.shape_check import repair
from nfex_core.rules.types import Bound


@pytest.fixture(scope="module")
def vocab(seeded_template) -> Vocabulary:  # type: ignore[no-untyped-def]
    kg = KnowledgeGraph.open(str(seeded_template))
    try:
        return kg.vocabulary()  # type: ignore[no-any-return]
    finally:
        kg.close()


def numeric(vocab: Vocabulary) -> list[tuple[str, str]]:
    return [
        (x, n) for x, spec in vocab.extractors.items() for n, p in spec.parameters.items()
        if p.datatype in ("integer", "double") and p.allowed is None and p.min is not None and p.max is not None
    ]


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_repair_satisfies_the_bound_within_range_or_says_none(vocab: Vocabulary, data: st.DataObject) -> None:
    x, name = data.draw(st.sampled_from(numeric(vocab)))
    p = vocab.extractor(x).parameter(name)
    lo, hi = float(p.min), float(p.max)  # type: ignore[arg-type]
    cmp = data.draw(st.sampled_from(["<=", "<", ">=", ">", "="]))
    b = data.draw(st.floats(lo - (hi - lo) * 0.2 - 1, hi + (hi - lo) * 0.2 + 1, allow_nan=False))
    dt = data.draw(st.sampled_from([XSD.double, XSD.decimal, XSD.integer]))
    lit = Literal(round(b) if dt == XSD.integer else b, datatype=dt)
    bound = Bound(x, name, cmp, lit)
    fixed = repair(bound, p)
    if fixed is not None:
        assert bound.holds(p, fixed) and p.validate(fixed) == fixed
    else:  # no value of the parameter's type in its range satisfies the bound
        v = float(lit.toPython())
        if p.datatype == "integer":
            inside = [k for k in (math.floor(v) - 1, math.floor(v), math.ceil(v), math.ceil(v) + 1, int(lo), int(hi)) if lo <= k <= hi]
            assert not any(bound.holds(p, k) for k in inside)
        else:
            assert not any(bound.holds(p, c) for c in (lo, hi, min(max(v, lo), hi)))
