"""A grouping carried by ``Grouped.advance`` equals one made from scratch (``Grouped.of``), whatever changed.

Random observations — sweeps' and reports from up to four reporters, some accepted, some timed — and random
changes (new rows, deleted rows, a row whose ATE, reporter, conditions or acceptance changed); after each,
the carried admission and every reader's groups equal a fresh grouping, and ``dirty`` names at least every
group whose content changed."""
from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from nfex_core.evidence import Observation, TrustPolicy
from nfex_core.evidence.groups import READERS, Grouped

CONDITIONS = [("light", "dark"), ("light", "bright"), ("agent", "car"), ("texture", "low")]


@st.composite
def observation(draw, iri: str) -> Observation:  # type: ignore[no-untyped-def]
    reporter = draw(st.sampled_from([None, None, "r1", "r2", "r3", "r4"]))
    timed = draw(st.booleans())
    return Observation(
        iri=iri, extractor=draw(st.sampled_from(["ORB", "SIFT"])), configuration=draw(st.sampled_from(["c1", "c2"])),
        conditions=frozenset(draw(st.lists(st.sampled_from(CONDITIONS), max_size=2, unique_by=lambda c: c[0]))),
        ate=draw(st.one_of(st.none(), st.floats(0.01, 5.0))), extraction_ms=draw(st.floats(1, 80)) if timed else None,
        width=draw(st.sampled_from([752, 1241])) if timed else None, height=376 if timed else None,
        failed=draw(st.booleans()), run="run_1" if reporter is None else None, reporter=reporter,
        accepted_by=draw(st.sampled_from([None, None, None, "editor"])) if reporter else None,
    )


@st.composite
def rows(draw, iris: list[str]) -> dict[str, Observation]:  # type: ignore[no-untyped-def]
    return {i: draw(observation(i)) for i in iris}


@settings(max_examples=80, deadline=None)
@given(data=st.data(), minimum=st.integers(1, 3))
def test_a_carried_grouping_equals_a_fresh_one(data: st.DataObject, minimum: int) -> None:
    policy = TrustPolicy(minimum)
    before = data.draw(rows([f"m{i:02d}" for i in range(data.draw(st.integers(0, 12)))]))
    grouped = Grouped.of(before.values(), policy)
    for _ in range(data.draw(st.integers(1, 3))):
        after = dict(before)
        for iri in data.draw(st.lists(st.sampled_from(sorted(before)), max_size=3, unique=True)) if before else []:
            if data.draw(st.booleans()):
                del after[iri]
            else:
                after[iri] = data.draw(observation(iri))
        for i in range(data.draw(st.integers(0, 3))):
            iri = f"n{len(after):02d}{i}"
            after[iri] = data.draw(observation(iri))
        changed = {i for i in set(before) | set(after) if before.get(i) != after.get(i)}
        carried = grouped.advance(before, after, changed, policy)
        fresh = Grouped.of(after.values(), policy)
        assert carried.admission == fresh.admission
        for reader in READERS:
            assert carried.groups[reader] == fresh.groups[reader], reader
            moved = {k for k in set(grouped.groups[reader]) | set(fresh.groups[reader])
                     if grouped.groups[reader].get(k) != fresh.groups[reader].get(k)}
            assert carried.dirty is not None and moved <= carried.dirty[reader]
        before, grouped = after, carried
