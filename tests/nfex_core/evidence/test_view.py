"""A view advanced from the last one (evidence/view.py, ``EvidenceView.advance``) equals a fresh view.

Random changes on the shipped graph — those of test_index.py, plus the trust setting flipped so that reports
leave or enter quarantine together — and after each batch the advanced view holds exactly the triples of a
view made from a dump of the store; the rule table compiled from the carried view equals a full compile."""
from __future__ import annotations

import io
import random

from hypothesis import given
from hypothesis import strategies as st

from nfex_core.evidence import TrustPolicy, admit
from nfex_core.evidence.groups import Grouped
from nfex_core.evidence.index import ObservationIndex
from nfex_core.evidence.view import EvidenceView, evidence_view, summary_lines
from nfex_core.feedback import Feedback, ReportWriter
from nfex_core.kg import KnowledgeGraph
from nfex_core.kg.storage.footprint import Reach, anchors
from nfex_core.rules import pruning
from nfex_core.rules.engine import compile_table
from tests.conftest import CARRIED_EXAMPLES

from .test_index import OPS, PREFIXES, _apply


def _reach(kg: KnowledgeGraph) -> Reach:
    """What the graph's SPARQL rules can read (kg/storage/footprint.py): the view a compile makes holds only these."""
    found = [anchors(rule.query) for rule in pruning.load_rules(kg)]
    assert all(a is not None for a in found)
    return Reach.of(a for stars in found for a in stars)  # type: ignore[union-attr]


def _view(kg: KnowledgeGraph, previous: EvidenceView | None = None, reach: Reach | None = None) -> EvidenceView:
    vocab = kg.vocabulary()
    observations = ObservationIndex.read(kg).all()
    admission = admit(observations, TrustPolicy.load(kg))
    values = {(d, v): str(s.iri) for d, dim in vocab.dimensions.items() for v, s in dim.values.items()}
    extractors = {x: str(e.iri) for x, e in vocab.extractors.items()}
    groups = Grouped.of(observations, TrustPolicy.load(kg)).groups["summary"]
    summary = frozenset(line for key, obs in groups.items() for line in summary_lines(key, obs, extractors, values))  # type: ignore[arg-type]
    return previous.advance(kg, admission, summary) if previous is not None else evidence_view(kg, admission, summary, reach)


def _triples(view: EvidenceView) -> set[bytes]:
    dump = io.BytesIO()
    view.backend.query_to("CONSTRUCT { ?s ?p ?o } WHERE { ?s ?p ?o }", "application/n-triples", dump)
    return set(dump.getvalue().splitlines()) - {b""}


def _trust(kg: KnowledgeGraph, rng: random.Random) -> None:
    n = rng.choice([1, 2, 3])
    kg.update(PREFIXES + f'DELETE {{ nfex:minSources nfex:value ?n }} INSERT {{ nfex:minSources nfex:value {n} }} '
              "WHERE { OPTIONAL { nfex:minSources nfex:value ?n } }", author="pytest")


@CARRIED_EXAMPLES
@given(ops=st.lists(st.sampled_from((*OPS, "trust", "trust")), min_size=1, max_size=4), seed=st.integers(0, 2**32 - 1))
def test_an_advanced_view_equals_a_fresh_view_after_random_changes(shipped_kg: KnowledgeGraph, ops: list[str], seed: int) -> None:
    rng = random.Random(seed)
    before = _view(shipped_kg)
    reach = _reach(shipped_kg)
    before_reach = _view(shipped_kg, reach=reach)  # what a compile makes: the triples its rules can read
    detached = before.detached()  # as a table kept on disk holds it (rules/persisted.py)
    quarantined = before.quarantined
    writer = ReportWriter(shipped_kg, max_items=1)
    try:
        for op in ops:
            _trust(shipped_kg, rng) if op == "trust" else _apply(shipped_kg, op, rng, writer)
    finally:
        writer.close()
    advanced = _view(shipped_kg, before)
    fresh = _view(shipped_kg)
    assert advanced.version == fresh.version == shipped_kg.version
    assert advanced.incremental and advanced.backend is before.backend
    assert advanced.quarantined == fresh.quarantined and advanced.summary == fresh.summary
    assert _triples(advanced) == _triples(fresh), f"quarantined before {len(quarantined)}, after {len(fresh.quarantined)}"
    within = _view(shipped_kg, before_reach)
    assert within.reach == reach and _triples(within) == _triples(_view(shipped_kg, reach=reach)) < _triples(fresh)
    # without its store, the view says the same of what changed: the rules due are the same
    moved = _view(shipped_kg, detached)
    assert moved.backend is None and moved.version == advanced.version
    assert (moved.delta, moved.quarantined, moved.summary) == (advanced.delta, advanced.quarantined, advanced.summary)


def test_a_compile_carries_the_view_and_answers_as_a_full_compile(shipped_kg: KnowledgeGraph, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    first = compile_table(shipped_kg)
    assert first.carry.view is not None and not first.carry.view.incremental
    writer = ReportWriter(shipped_kg, max_items=1)
    try:
        for reporter in ("r1", "r2", "r3"):  # corroborated by three sources: admitted, so the summaries change
            writer.write(Feedback("ORB", {}, {"agent": "car", "light": "dark"}, sequence="s9", dataset="pytest", reporter=reporter,
                                  frames=10, ate_rmse=40.0, extraction_ms=4.0, width=1241, height=376, tracking_lost=9))
    finally:
        writer.close()
    import nfex_core.rules.engine as engine

    reads: list[tuple[int, int | None]] = []
    versions: list[int] = []
    diff, read = shipped_kg.diff, engine.read_changes
    monkeypatch.setattr(shipped_kg, "diff", lambda since, until=None, **kw: reads.append((since, until)) or diff(since, until, **kw))
    monkeypatch.setattr(engine, "read_changes", lambda backend, n: versions.append(n) or read(backend, n))
    carried = compile_table(shipped_kg, first)
    monkeypatch.undo()
    assert reads == [(first.version, shipped_kg.version)], "the index and the view read the change once between them"
    assert sorted(versions) == list(range(first.version + 1, shipped_kg.version + 1)), "each version's change set read once"
    assert first.carry.view is None, "a view is handed to one compile only"
    assert carried.carry.view is not None and carried.carry.view.incremental
    full = compile_table(shipped_kg)
    assert _triples(carried.carry.view) == _triples(full.carry.view)  # type: ignore[arg-type]
    assert carried.decisions == full.decisions and carried.errors == full.errors


def test_a_view_read_while_a_commit_landed_is_not_advanced(shipped_kg: KnowledgeGraph) -> None:
    """A view whose version could not be pinned (a commit landed during its reads) is replaced, not advanced."""
    view = _view(shipped_kg)
    stale = EvidenceView(-1, view.backend, view.quarantined, view.summary)
    again = _view(shipped_kg, stale)
    assert not again.incremental and again.backend is not view.backend


def test_reports_that_leave_and_enter_quarantine_get_their_triples_back_and_lose_them(shipped_kg: KnowledgeGraph) -> None:
    writer = ReportWriter(shipped_kg, max_items=1)
    try:
        writer.write(Feedback("SIFT", {}, {"agent": "drone"}, sequence="s8", dataset="pytest", reporter="r1",
                              frames=10, ate_rmse=0.2, extraction_ms=40.0, width=752, height=480, tracking_lost=0))
    finally:
        writer.close()
    before = _view(shipped_kg)
    assert before.quarantined, "a report from one reporter waits for corroboration"
    rng = random.Random(0)
    for wanted in (1, 3):  # admitted, then quarantined again
        while True:
            _trust(shipped_kg, rng)
            if TrustPolicy.load(shipped_kg).min_sources == wanted:
                break
        before = _view(shipped_kg, before)
        assert bool(before.quarantined) == (wanted == 3)
        assert _triples(before) == _triples(_view(shipped_kg))


def test_a_literal_with_a_line_break_is_carried(shipped_kg: KnowledgeGraph) -> None:
    """Regression: added statements were loaded as N-Triples, which has no line breaks in literals (a rule's
    SPARQL text has them), and the advance failed."""
    before = _view(shipped_kg)
    shipped_kg.update(PREFIXES + 'INSERT DATA { <urn:nfex:test:note> rdfs:comment """two\nlines""" }', author="pytest")
    advanced = _view(shipped_kg, before)
    assert advanced.incremental and _triples(advanced) == _triples(_view(shipped_kg))


def test_the_rules_decide_on_their_reach_as_on_the_whole_graph(shipped_kg: KnowledgeGraph, bare_kg: KnowledgeGraph,
                                                               monkeypatch) -> None:  # type: ignore[no-untyped-def]
    """The view copies only what the rules can read (kg/storage/footprint.py ``Reach``): the shipped rules decide on it as
    on a copy of the whole graph, with their measurements (rules silent or measured) and without (the expert
    prior prunes)."""
    from nfex_core.rules import engine

    for kg in (shipped_kg, bare_kg):
        within = compile_table(kg)
        assert within.carry.view is not None and within.carry.view.reach is not None
        with monkeypatch.context() as m:
            m.setattr(engine, "_reach", lambda setup: None)
            whole = compile_table(kg)
        assert whole.carry.view is not None and whole.carry.view.reach is None
        assert len(_triples(within.carry.view)) < len(_triples(whole.carry.view))
        assert within.carry.plain == whole.carry.plain and within.errors == whole.errors
        assert any(d.pruned for d in within.carry.plain.values())
