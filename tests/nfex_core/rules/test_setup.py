"""A compile carried from the last version (rules/setup.py, the rules' footprints) equals a full compile.

Random changes on the shipped graph mix evidence (reports, ATEs, deleted Measurements — test_index.py's
operations) with configuration (a statement dropped, a rule disabled, a threshold or the trust setting
changed). After each batch, the table compiled from the previous one equals a full compile; a change of
evidence only keeps the configuration stage, and one of configuration reads it again."""
from __future__ import annotations

import random

from hypothesis import given
from hypothesis import strategies as st

from nfex_core.feedback import Feedback, ReportWriter
from nfex_core.kg import KnowledgeGraph
from nfex_core.kg.changes import ChangeSet, evidence_only, graph_triples
from nfex_core.kg.footprint import footprint, reads
from nfex_core.kg.namespaces import NFEX, RDF
from nfex_core.rules import pruning
from nfex_core.rules.dsl.programs import compile_text
from nfex_core.rules.engine import RuleTable, compile_table
from nfex_core.rules.setup import Setup
from tests.conftest import CARRIED_EXAMPLES

from ..evidence.test_index import OPS, PREFIXES, _apply
from ..evidence.test_view import _trust

CONFIGURATION = ("statement", "rule", "threshold", "trust")
CONTEXTS = [{"agent": "car", "light": "dark"}, {"agent": "drone"}, {"agent": "human", "scene": "indoor", "light": "dark"}, {}]


def _configure(kg: KnowledgeGraph, op: str, rng: random.Random) -> None:
    if op == "trust":
        _trust(kg, rng)
    elif op == "statement":
        rows = kg.select("SELECT ?s WHERE { ?s nfex:inProgram ?p }").rows
        if rows:
            kg.update(PREFIXES + f"DELETE WHERE {{ <{rng.choice(rows)['s']}> ?p ?o }}", author="pytest")
    elif op == "rule":
        rows = kg.select("SELECT ?r WHERE { ?r a nfex:SparqlRule }").rows
        kg.update(PREFIXES + f"INSERT DATA {{ <{rng.choice(rows)['r']}> nfex:enabled false }}", author="pytest")
    elif op == "threshold":
        kg.update(PREFIXES + f"DELETE {{ nfex:maxRelativeAte nfex:value ?v }} INSERT {{ nfex:maxRelativeAte nfex:value {rng.choice([1.2, 2.0, 5.0])} }} "
                  "WHERE { OPTIONAL { nfex:maxRelativeAte nfex:value ?v } }", author="pytest")


def _same(carried: RuleTable, full: RuleTable) -> None:
    assert carried.carry.plain == full.carry.plain and carried.errors == full.errors  # (``decisions`` gain evidence as contexts are asked)
    assert carried.configurations == full.configurations and carried.observed == full.observed
    assert carried.cost == full.cost and carried.admission == full.admission and carried.budget_terms == full.budget_terms
    for c in CONTEXTS:
        assert carried.decide(c) == full.decide(c)
        assert carried.measured(c) == full.measured(c)


@CARRIED_EXAMPLES
@given(ops=st.lists(st.sampled_from((*OPS, *CONFIGURATION)), min_size=1, max_size=4), seed=st.integers(0, 2**32 - 1))
def test_a_carried_compile_equals_a_full_compile_after_random_changes(shipped_kg: KnowledgeGraph, ops: list[str], seed: int) -> None:
    rng = random.Random(seed)
    table = shipped_kg.cached("test-setup", lambda: compile_table(shipped_kg))
    writer = ReportWriter(shipped_kg, max_items=1)
    try:
        for op in ops:
            before = shipped_kg.version
            _configure(shipped_kg, op, rng) if op in CONFIGURATION else _apply(shipped_kg, op, rng, writer)
            if shipped_kg.version == before:
                continue
            table = carried = compile_table(shipped_kg, table)
            full = compile_table(shipped_kg)
            _same(carried, full)
    finally:
        writer.close()


def _report(writer: ReportWriter, reporter: str, extractor: str = "ORB") -> None:
    writer.write(Feedback(extractor, {}, {"agent": "car", "light": "dark"}, sequence="s9", dataset="pytest", reporter=reporter,
                          frames=10, ate_rmse=40.0, extraction_ms=4.0, width=1241, height=376, tracking_lost=9))


def _reports(kg: KnowledgeGraph, *reporters: str) -> None:
    writer = ReportWriter(kg, max_items=1)
    try:
        for reporter in reporters:
            _report(writer, reporter)
    finally:
        writer.close()


def test_a_report_keeps_the_configuration_stage_and_a_statement_change_reads_it_again(shipped_kg: KnowledgeGraph) -> None:
    first = compile_table(shipped_kg)
    _reports(shipped_kg, "r1")
    after_report = compile_table(shipped_kg, first)
    assert after_report.carry.setup is first.carry.setup
    assert after_report.carry.grouped is not None and after_report.carry.grouped.dirty is not None, "the grouping was carried, not redone"
    assert sum(map(len, after_report.carry.grouped.dirty.values())) <= 12  # the groups of one report, not all
    row = shipped_kg.select("SELECT ?s WHERE { ?s nfex:inProgram ?p }").rows[0]
    shipped_kg.update(PREFIXES + f"DELETE WHERE {{ <{row['s']}> ?p ?o }}", author="pytest")
    after_edit = compile_table(shipped_kg, after_report)
    assert after_edit.carry.setup is not after_report.carry.setup
    _same(after_edit, compile_table(shipped_kg))


def test_a_quarantined_report_runs_no_measured_rule_and_a_corroborated_one_runs_them(shipped_kg: KnowledgeGraph, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    """Footprints: a report waiting for corroboration adds nothing to the rules' view that the measured rules
    read (its Measurement is out of the view), so their hits are kept; the third reporter admits all three,
    the evidence summaries change, and every measured rule runs again — with the answer of a full compile."""
    table = compile_table(shipped_kg)
    ran: list[str] = []
    evaluate = pruning.evaluate
    monkeypatch.setattr(pruning, "evaluate", lambda view, rule, query: ran.append(str(rule.iri)) or evaluate(view, rule, query))
    writer = ReportWriter(shipped_kg, max_items=1)
    try:
        for reporter in ("r1", "r2"):
            _report(writer, reporter)
            ran.clear()
            table = compile_table(shipped_kg, table)
            assert not [r for r in ran if "measured" in r], ran
        _report(writer, "r3")
        ran.clear()
        table = compile_table(shipped_kg, table)
    finally:
        writer.close()
    measured = {str(r.iri) for r in table.rules if "measured" in str(r.iri)}
    assert measured and measured <= set(ran)
    _same(table, compile_table(shipped_kg))


def test_evidence_only_tells_a_report_from_configuration(shipped_kg: KnowledgeGraph) -> None:
    v0 = shipped_kg.version
    _reports(shipped_kg, "r1")
    assert evidence_only(shipped_kg.backend, shipped_kg.diff(v0, shipped_kg.version))
    rule = shipped_kg.select("SELECT ?r WHERE { ?r a nfex:SparqlRule }").rows[0]["r"]
    assert not evidence_only(shipped_kg.backend, ChangeSet.adding([(rule, NFEX.enabled, NFEX.x)]))
    m = shipped_kg.select("SELECT ?m WHERE { ?m a nfex:Measurement }").rows[0]["m"]
    assert evidence_only(shipped_kg.backend, ChangeSet.adding([(m, NFEX.ateRmse, NFEX.x)]))
    # a Measurement retyped as a Parameter: its types after the change count
    assert not evidence_only(shipped_kg.backend, ChangeSet.adding([(m, RDF.type, NFEX.Parameter)]))
    # an untyped subject, such as a graph setting, is configuration
    assert not evidence_only(shipped_kg.backend, ChangeSet.adding([(NFEX.minSources, NFEX.value, NFEX.x)]))


def test_a_footprint_lists_what_a_rule_reads_or_gives_up() -> None:
    p = "PREFIX nfex: <https://w3id.org/nfex#> SELECT ?extractor ?reason WHERE { "
    fp = footprint(p + "?x a nfex:A ; nfex:b/^nfex:c* ?y . { SELECT ?x (COUNT(?z) AS ?n) WHERE { ?x nfex:d ?z } GROUP BY ?x } "
                           "OPTIONAL { ?x nfex:e ?w } MINUS { ?x nfex:f ?v } BIND (?x AS ?extractor) BIND ('r' AS ?reason) }")
    assert fp == {(str(RDF.type), str(NFEX.A)), *((str(NFEX[k]), None) for k in "bcdef")}
    for opaque in ("?x ?p ?y", "?x !nfex:b ?y", "?x a nfex:A FILTER NOT EXISTS { ?x ?p ?y }", "?x nfex:b ?y ; a ?t . GRAPH ?g { ?x nfex:c ?z }"):
        assert footprint(p + opaque + " }") is None, opaque
    # an EXISTS pattern, which rdflib's algebra leaves as parsed, is read too
    assert footprint(p + "?x a nfex:A FILTER (NOT EXISTS { ?x nfex:b ?y } || EXISTS { ?x nfex:c/nfex:d ?z }) }") == {
        (str(RDF.type), str(NFEX.A)), *((str(NFEX[k]), None) for k in "bcd")}
    assert footprint("not sparql") is None
    assert reads(fp, {(str(NFEX.d), "1")}) and reads(fp, {(str(RDF.type), str(NFEX.A))})
    assert not reads(fp, {(str(RDF.type), str(NFEX.B)), (str(NFEX.g), "x")})
    assert reads(None, set()) and reads(fp, None)


def test_a_change_a_rule_reads_runs_it_again(shipped_kg: KnowledgeGraph) -> None:
    """Regression guard for the footprints: an editor's rule that reads ``nfex:ateRmse`` must see a sweep's
    Measurement (admitted as written) get a wild ATE, with no configuration change in between."""
    query = ("PREFIX nfex: <https://w3id.org/nfex#> SELECT DISTINCT ?extractor ?reason WHERE { ?m a nfex:Measurement ; nfex:ateRmse ?a . "
             "FILTER (?a > 1000) BIND (nfex:ORB AS ?extractor) BIND ('a wild ATE' AS ?reason) }")
    shipped_kg.update(PREFIXES + f'INSERT DATA {{ nfex:rule_wild a nfex:SparqlRule ; rdfs:label "wild" ; nfex:query """{query}""" }}',
                      author="pytest")
    table = compile_table(shipped_kg)
    assert "ORB" in table.decide({"agent": "car"}).candidates
    m = shipped_kg.select("SELECT ?m WHERE { ?m a nfex:Measurement ; nfex:ateRmse ?a FILTER NOT EXISTS { ?m prov:wasAttributedTo ?r } } LIMIT 1").rows[0]["m"]
    shipped_kg.update(PREFIXES + f"DELETE {{ <{m}> nfex:ateRmse ?a }} INSERT {{ <{m}> nfex:ateRmse '5000.0'^^xsd:double }} WHERE {{ <{m}> nfex:ateRmse ?a }}",
                      author="pytest")
    carried = compile_table(shipped_kg, table)
    assert carried.carry.setup is table.carry.setup, "an ATE changed is evidence"
    assert "ORB" not in carried.decide({"agent": "car"}).candidates
    _same(carried, compile_table(shipped_kg))


def _reference(context: dict[str, str | None], setup: Setup) -> tuple[dict[str, list[str]], dict[str, object], tuple[str, ...]]:
    """A context's statement and shape effects the plain way: every statement and shape asked whether it applies."""
    pruned: dict[str, list[str]] = {}
    effects: dict[str, object] = {}
    for s in setup.statements:
        if s.applies(context):
            if s.kind == "prune" and s.extractor:
                pruned.setdefault(s.extractor, []).append(str(s.iri))
            effects.setdefault(s.kind, []).append(str(s.iri))  # type: ignore[attr-defined]
    shapes = tuple(str(sh.iri) for sh in setup.shapes if sh.applies(context))
    for sh in setup.shapes:
        if sh.applies(context) and sh.bound is None:
            for x in setup.vocab.extractors:
                if sh.concerns(x):
                    pruned.setdefault(x, []).append(str(sh.iri))
    return pruned, effects, shapes


def test_each_contexts_base_is_what_asking_every_statement_gives(shipped_kg: KnowledgeGraph) -> None:
    """``Setup`` walks statement by statement over the contexts each reaches; asking every statement in every
    context must give the same prunes (in order), the same statements in force and the same shapes."""
    program = ("prune ORB when light is dark and agent is not car\nprune BRISK when texture is not low and texture is not high\nadjust SIFT.nfeatures by 0.5 when texture is not one of (high, medium)\n"
               "prefer ORB_GRID by 0.2 when texture is low\nweight texturedness 2.0 when light is dark\nescalate at most 2 when motion is fast\n")
    shipped_kg.commit(ChangeSet.adding(graph_triples(compile_text(program, shipped_kg.vocabulary(), name="pytest-base")[1])),
                      author="pytest")
    setup = Setup.read(shipped_kg, {})
    kinds = {"prune", "adjust", "weight", "prefer", "escalate"}
    assert kinds <= {s.kind for s in setup.statements}
    for key, base in zip(setup.keys, setup.base, strict=True):
        pruned, effects, shapes = _reference(dict(zip(setup.dimensions, key, strict=True)), setup)
        assert {x: [c.rule for c in cites] for x, cites in base.pruned.items()} == pruned
        assert tuple(str(sh.iri) for sh in base.shapes) == shapes
        for params in base.factors.values():
            for factor in params.values():
                assert {c.rule for c in factor.citations} <= set(effects["adjust"])  # type: ignore[arg-type]
        for b in base.bonuses.values():
            assert {c.rule for c in b.citations} <= set(effects["prefer"])  # type: ignore[arg-type]
        forced = effects.get("escalate")
        assert (base.verification.escalation_citation is not None) == bool(forced)


def test_types_read_after_later_commits_are_taken_back_to_the_changes_version(shipped_kg: KnowledgeGraph) -> None:
    """``evidence_only``'s ``later``: a compile pinned to version v reads the types after commits that landed
    since; a Measurement retyped after v must be judged by its types at v."""
    v0 = shipped_kg.version
    _reports(shipped_kg, "r1")
    v1 = shipped_kg.version
    m = next(t[0] for t in shipped_kg.diff(v0, v1).added if t[1] == RDF.type and t[2] == NFEX.Measurement)
    shipped_kg.commit(ChangeSet.adding([(m, RDF.type, NFEX.Curiosity)]), author="pytest")  # a class of no evidence
    change, later = shipped_kg.diff(v0, v1), shipped_kg.diff(v1, shipped_kg.version)
    assert not evidence_only(shipped_kg.backend, change), "read now, it is something else too"
    assert evidence_only(shipped_kg.backend, change, later), "at v1 it was a Measurement"


def test_under_a_stream_of_reports_each_compile_carries_the_last(shipped_kg: KnowledgeGraph, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    """Regression: a compile that saw a commit land while it ran gave its view version −1, so under a stream
    every compile dumped the graph again and read its configuration again. A compile is now pinned to the
    version it started at: the view is advanced and the configuration stage carried while reports land.
    Each compile's read of the evidence waits for the stream's next commit (``KnowledgeGraph.on_commit``), so a
    commit lands inside every compile while the stream runs; the stream goes on until three compiles ran."""
    import threading

    from nfex_core.evidence.index import ObservationIndex

    done, enough, committed = threading.Event(), threading.Event(), threading.Event()
    shipped_kg.on_commit(lambda version: committed.set())
    advance = ObservationIndex.advance

    def after_a_commit(self: ObservationIndex, *a):  # type: ignore[no-untyped-def]
        committed.clear()
        if not done.is_set():  # the stream's end sets ``committed`` after ``done``: no wait is left hanging
            assert committed.wait(60), "no commit landed: the stream stopped"
        return advance(self, *a)

    monkeypatch.setattr(ObservationIndex, "advance", after_a_commit)
    table = compile_table(shipped_kg)
    first = table.carry.setup
    writer = ReportWriter(shipped_kg, max_items=4)

    def stream() -> None:
        try:
            for i in range(400):  # a bound, should compiles stop: the assertion below then fails
                if i >= 24 and enough.is_set():
                    break
                _report(writer, f"r{i % 2}")
        finally:
            done.set()
            committed.set()

    thread = threading.Thread(target=stream)
    thread.start()
    compiles = carried = 0
    try:
        while not done.is_set():
            if shipped_kg.version != table.version:
                table = compile_table(shipped_kg, table)
                compiles += 1
                carried += table.carry.setup is first and table.carry.view is not None and table.carry.view.incremental and table.carry.view.version >= 0
                if compiles >= 3:
                    enough.set()
    finally:
        thread.join()
        writer.close()
    table = compile_table(shipped_kg, table)
    assert compiles >= 3 and carried == compiles, (carried, compiles)
    assert table.carry.setup is first
    _same(table, compile_table(shipped_kg))


def test_an_editors_change_that_no_rule_reads_keeps_every_rules_hits(shipped_kg: KnowledgeGraph, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    """A statement dropped is configuration (the stage is read again) but no SPARQL rule reads statements:
    their hits stand. A threshold the relative-ATE rule reads runs that rule again."""
    table = compile_table(shipped_kg)
    ran: list[str] = []
    evaluate = pruning.evaluate
    monkeypatch.setattr(pruning, "evaluate", lambda view, rule, query: ran.append(str(rule.iri)) or evaluate(view, rule, query))
    row = shipped_kg.select("SELECT ?s WHERE { ?s nfex:inProgram ?p } ORDER BY ?s").rows[0]
    shipped_kg.update(PREFIXES + f"DELETE WHERE {{ <{row['s']}> ?p ?o }}", author="pytest")
    table = compile_table(shipped_kg, table)
    assert ran == [] and table.carry.setup is not None
    _same(table, compile_table(shipped_kg))
    ran.clear()
    _configure(shipped_kg, "threshold", random.Random(1))
    table = compile_table(shipped_kg, table)
    assert any("relative" in r for r in ran), ran
    _same(table, compile_table(shipped_kg))


def test_a_report_outside_a_rules_star_does_not_run_it(bare_kg: KnowledgeGraph, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    """The expert rule takes out extractors with Measurements under agent = car and motion = fast (kg/footprint.py
    stars): an admitted report under car + dark leaves its hits as they were without running it; one under car +
    fast runs it, and the prior yields; once it has, more reports under car + fast can only take rows out of an
    empty answer (signs), so they do not run it either — until a measurement under car + fast is deleted. Each
    carried table equals a full compile."""
    bare_kg.update(PREFIXES + "DELETE { nfex:minSources nfex:value ?n } INSERT { nfex:minSources nfex:value 1 } "
                   "WHERE { OPTIONAL { nfex:minSources nfex:value ?n } }", author="pytest")
    ran: list[str] = []
    evaluate = pruning.evaluate
    monkeypatch.setattr(pruning, "evaluate", lambda view, rule, query: ran.append(rule.label) or evaluate(view, rule, query))
    expert = "Gradient-histogram descriptors fail on fast car motion"
    fast = {"agent": "car", "motion": "fast"}
    table = compile_table(bare_kg)
    assert "SIFT" in table.decide(fast).pruned
    writer = ReportWriter(bare_kg, max_items=1)
    try:
        # the first report also adds its configuration and the summaries of its conditions, whose
        # ``nfex:ofExtractor`` the path's second step reads: a second report under the same conditions does not
        dark = {"agent": "car", "light": "dark"}
        for i, conditions in enumerate((dark, dark, fast, fast, dark)):
            ran.clear()
            writer.write(Feedback("SIFT", {}, conditions, sequence=f"star-{i}", dataset="pytest", reporter="r1", frames=10,
                                  ate_rmse=0.1, extraction_ms=40.0, width=640, height=480, tracking_lost=0))
            table = compile_table(bare_kg, table)
            assert (expert in ran) == (i in (0, 2)), (i, ran)
            _same(table, compile_table(bare_kg))
    finally:
        writer.close()
    assert "SIFT" not in table.decide(fast).pruned
    ran.clear()
    bare_kg.update(PREFIXES + "DELETE { ?m ?p ?o } WHERE { ?m nfex:underCondition nfex:motion_fast ; ?p ?o }", author="pytest")
    table = compile_table(bare_kg, table)
    assert expert in ran
    assert "SIFT" in table.decide(fast).pruned
    _same(table, compile_table(bare_kg))
