"""nfex_core.advisor.impact: the contexts whose α or Θ′ a change would alter, computed without writing."""
from __future__ import annotations

from nfex_core.advisor import Advisor
from nfex_core.advisor.impact import contexts, impact, outcome, scratch_copy
from nfex_core.kg import ChangeSet, KnowledgeGraph
from nfex_core.rules.dsl import programs


def _program_change(kg: KnowledgeGraph, text: str, name: str = "impact_test") -> ChangeSet:
    _, graph = programs.compile_text(text, kg.vocabulary(), name=name)
    return programs.change_of(kg, graph, name)


def test_a_prune_changes_exactly_the_contexts_where_the_pruned_extractor_was_chosen(bare_kg: KnowledgeGraph) -> None:
    kg = bare_kg
    before = Advisor(scratch_copy(kg), neural="symbolic")  # answered from a copy, as impact() does
    chosen = {tuple(c.items()): outcome(before, c).extractor for c in contexts(kg)}
    x = max(set(chosen.values()) - {None}, key=lambda e: sum(v == e for v in chosen.values()))  # the most chosen α
    version, triples = kg.version, kg.triple_count()

    result = impact(kg, _program_change(kg, f'prune {x} when light is dark because "test"'),
                    make_advisor=lambda g: Advisor(g, neural="symbolic"))

    expected = {k for k, alpha in chosen.items() if alpha == x and dict(k)["light"] == "dark"}
    assert expected, "the test needs a dark context where the pruned extractor is chosen"
    assert {tuple(c.context.items()) for c in result.changes} == expected
    assert all(c.alpha_changed and c.after.extractor != x and x in c.after.pruned for c in result.changes)
    assert result.contexts == len(chosen) and result.conforms and result.added > 0
    assert (kg.version, kg.triple_count()) == (version, triples)  # nothing written
    doc = result.as_dict(limit=2)
    assert doc["changed"] == len(expected) and len(doc["changes"]) == 2 and doc["truncated"]


def test_an_adjust_changes_params_not_alpha(bare_kg: KnowledgeGraph) -> None:
    kg = bare_kg
    make = lambda g: Advisor(g, neural="symbolic")  # noqa: E731
    before = make(scratch_copy(kg))
    alphas = {outcome(before, c).extractor for c in contexts(kg) if c["agent"] == "drone"}
    x = sorted(a for a in alphas if a)[0]
    p = next(n for n, s in kg.vocabulary().extractor(x).parameters.items() if s.tunable and s.datatype == "integer" and s.default)
    result = impact(kg, _program_change(kg, f"adjust {x}.{p} by 2 when agent is drone"), make_advisor=make)
    assert result.changes and all(not c.alpha_changed and c.context["agent"] == "drone" for c in result.changes)
    assert all(set(c.params_changed()) == {p} for c in result.changes)


def test_no_change_changes_nothing_and_the_scratch_copy_is_the_graph(bare_kg: KnowledgeGraph) -> None:
    assert impact(bare_kg, ChangeSet(), make_advisor=lambda g: Advisor(g, neural="symbolic")).changes == []
    copy = scratch_copy(bare_kg)
    assert copy.triple_count() == bare_kg.triple_count()
    assert copy.location == ":memory:"
