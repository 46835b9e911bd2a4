"""advisor/bounds.py: the bounds contain every score, and extracting by them finds the α* (and the first k) of
scoring everything — for any weights (negative ones too), bonuses, accuracies and metric values."""
from __future__ import annotations

import math

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from nfex_core.advisor.bounds import SCORE_MARGIN, contenders, next_extraction, score_bounds
from nfex_core.advisor.ranges import MetricRanges
from nfex_core.kg import KnowledgeGraph
from nfex_core.rules.fitness import f_metrics
from nfex_core.rules.types import Decision, Factor
from nfex_core.vision.metrics import SINGLE_FRAME, TEMPORAL

METRICS = (*SINGLE_FRAME, *TEMPORAL)
unit = st.floats(0.0, 1.0)
candidate = st.fixed_dictionaries({
    "bonus": st.floats(-2.0, 2.0), "accuracy": unit, "ms": st.floats(0.1, 50.0), "temporal": st.booleans(),
    "metrics": st.fixed_dictionaries({m: unit for m in METRICS}),
})
problem = st.fixed_dictionaries({
    "weights": st.fixed_dictionaries({m: st.floats(-1.0, 2.0) for m in METRICS}),
    "candidates": st.lists(candidate, min_size=1, max_size=6),
})


@pytest.fixture(scope="module")
def specs(seeded_template):  # type: ignore[no-untyped-def]
    import shutil
    import tempfile
    from pathlib import Path

    folder = Path(tempfile.mkdtemp()) / "store"
    shutil.copytree(seeded_template, folder, ignore=shutil.ignore_patterns("LOCK"))
    kg = KnowledgeGraph.open(str(folder))
    try:
        yield kg.vocabulary().metrics
    finally:
        kg.close()


def scores(p: dict, specs) -> tuple[Decision, dict[str, float], dict[str, tuple[float, float]], dict[str, float]]:  # type: ignore[no-untyped-def, type-arg]
    names = [f"X{i}" for i in range(len(p["candidates"]))]
    weights = {m: Factor(w) for m, w in p["weights"].items()}
    decision = Decision({}, tuple(names), {}, {}, weights, {x: Factor(c["bonus"]) for x, c in zip(names, p["candidates"], strict=True)})
    H = sum(w.value for w in weights.values())
    exact, bounds, ms = {}, {}, {}
    for x, c in zip(names, p["candidates"], strict=True):
        have = METRICS if c["temporal"] else SINGLE_FRAME
        exact[x] = f_metrics({m: c["metrics"][m] for m in have}, weights, specs, c["bonus"]) + H * c["accuracy"]
        bounds[x] = score_bounds(decision, specs, have, x, c["accuracy"], H)
        ms[x] = c["ms"]
    return decision, exact, bounds, ms


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(problem)
def test_the_bounds_hold_and_extraction_finds_the_exhaustive_alpha(specs, p: dict) -> None:  # type: ignore[no-untyped-def, type-arg]
    _, exact, bounds, ms = scores(p, specs)
    for x in exact:
        assert bounds[x][0] - 1e-9 <= exact[x] <= bounds[x][1] + 1e-9
    intervals, done = dict(bounds), set()
    while (pick := next_extraction(intervals, [x for x in intervals if x not in done], ms)) is not None:
        assert pick not in done
        done.add(pick)
        intervals[pick] = (exact[pick], exact[pick])
    top = max(exact.values())
    alpha, rivals = contenders(intervals)
    if alpha not in done:  # settled by bounds: every other candidate's score is certainly below α*'s
        assert not rivals and all(exact[x] < exact[alpha] for x in exact if x != alpha)
    else:  # every candidate that can reach the best score was scored
        assert all(x in done for x in exact if exact[x] >= top - SCORE_MARGIN)
        assert max(exact[x] for x in done) == top


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(problem, st.integers(2, 4))
def test_the_first_k_are_scored_in_exact_order(specs, p: dict, k: int) -> None:  # type: ignore[no-untyped-def, type-arg]
    _, exact, bounds, ms = scores(p, specs)
    intervals, done = dict(bounds), set()
    while (pick := next_extraction(intervals, [x for x in intervals if x not in done], ms, k)) is not None:
        done.add(pick)
        intervals[pick] = (exact[pick], exact[pick])
    best = sorted(exact, key=lambda x: -exact[x])[:k]
    kth = exact[best[-1]]
    # every candidate scoring at least the k-th best was scored, so the first k in score order are exact
    assert all(x in done for x in exact if exact[x] >= kth - SCORE_MARGIN or math.isclose(exact[x], kth))


span = st.tuples(unit, unit).map(sorted).map(tuple)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(problem, st.data())
def test_measured_ranges_bound_every_score_whose_metrics_lie_in_them(specs, p: dict, data) -> None:  # type: ignore[no-untyped-def, type-arg]
    """Any metric values inside the ranges give a score inside the ranged score_bounds, which lie inside the sound bounds."""
    decision, _, bounds, _ = scores(p, specs)
    H = sum(w.value for w in decision.weights.values())
    for i, c in enumerate(p["candidates"]):
        x, have = f"X{i}", METRICS if c["temporal"] else SINGLE_FRAME
        spans = {m: data.draw(span) for m in have}
        metrics = {m: data.draw(st.floats(*spans[m])) for m in have}
        low, high = score_bounds(decision, specs, have, x, c["accuracy"], H, spans)
        score = f_metrics(metrics, decision.weights, specs, c["bonus"]) + H * c["accuracy"]
        assert low - 1e-9 <= score <= high + 1e-9
        assert bounds[x][0] - 1e-9 <= low <= high <= bounds[x][1] + 1e-9


@given(st.tuples(unit, unit).map(sorted), st.tuples(st.floats(-1, 1), st.floats(-1, 1)).map(sorted), unit)
def test_a_metric_range_narrows_by_what_was_extracted_or_says_it_does_not_hold(single, paired, other: float) -> None:  # type: ignore[no-untyped-def]
    ranges = MetricRanges({("A", "density"): tuple(single)}, {("A", "B", "density"): tuple(paired)})  # type: ignore[arg-type]
    alone = ranges.span("A", "density", {})
    assert alone == tuple(single)
    got = ranges.span("A", "density", {"B": {"density": other}})
    lo, hi = max(single[0], other + paired[0], 0.0), min(single[1], other + paired[1], 1.0)
    assert got == ((lo, hi) if lo <= hi else None)
    assert ranges.span("C", "density", {"B": {"density": other}}) == (0.0, 1.0)  # no range: the sound [0, 1]
    assert ranges.holds({"A": {"density": single[0]}}) and ranges.holds({"C": {"density": 0.5}})
    assert not ranges.holds({"A": {"density": single[1] + 1e-3}})
