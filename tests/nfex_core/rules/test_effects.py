"""nfex_core.rules.effects: what each rule does over the compiled table."""
from __future__ import annotations

from nfex_core.kg import KnowledgeGraph
from nfex_core.rules.effects import effects
from nfex_core.rules.engine import RuleEngine


def test_effects_count_the_contexts_of_each_statement(bare_kg: KnowledgeGraph) -> None:
    table = RuleEngine(bare_kg).table()
    found = effects(table)
    dark = [d for d in table.decisions.values() if d.context["light"] == "dark"]
    # every adjust statement of the default program "… when light is dark" acts in every dark context, nowhere else
    dark_adjusts = {s for s in table.statements if s.kind == "adjust" and [(a.dimension, set(a.values)) for a in s.atoms] == [("light", {"dark"})]}
    assert dark_adjusts
    for s in dark_adjusts:
        e = found[str(s.iri)].effects[f"adjusts {s.extractor}.{s.parameter}"]
        assert e.contexts == len(dark) and e.example["light"] == "dark"
        assert s.reason in found[str(s.iri)].reasons
    # the pruned counts agree with the table
    for rule in found.values():
        for what, e in rule.effects.items():
            if what.startswith("prunes "):
                x = what.removeprefix("prunes ")
                assert e.contexts == sum(any(c.rule == rule.iri for c in d.pruned.get(x, ())) for d in table.decisions.values())
