"""The advisor from the context alone: candidates, Θ′ within the graph's ranges, cited rules, versions."""
from __future__ import annotations

import pytest

from nfex_core.advisor import Advisor
from nfex_core.errors import NoCandidate, UnknownName
from nfex_core.kg import KnowledgeGraph, parse_rdf

N = "https://w3id.org/nfex#"
RULE = """@prefix nfex: <https://w3id.org/nfex#> . @prefix rdfs: <http://www.w3.org/2000/01/rdf-schema#> .
nfex:rule_no_orb_on_mirrors a nfex:SparqlRule ; rdfs:label "No ORB on mirrors" ; nfex:sourceFile "test" ;
  nfex:query \"\"\"PREFIX nfex: <https://w3id.org/nfex#>
SELECT ?extractor ?reason WHERE { FILTER (?reflectance = nfex:reflectance_reflective)
  ?extractor nfex:token "ORB" . BIND ("test: FAST corners fire on specular highlights" AS ?reason) }\"\"\" .
"""


def test_context_only_selection_gives_a_full_parameter_set_within_ranges(kg: KnowledgeGraph) -> None:
    sel = Advisor(kg, neural="symbolic").select({"agent": "car", "motion": "fast", "light": "dark"})
    assert sel.mode == "prior"
    vocab = kg.vocabulary()
    for cand in sel.candidates:
        spec = vocab.extractor(cand.extractor)
        assert set(cand.params) == set(spec.parameters)
        for name, value in cand.params.items():
            assert spec.parameter(name).validate(value) == value  # in range, of its datatype
    assert "SIFT" in {p.extractor for p in sel.pruned}  # expert SPARQL rule
    assert {e.dimension: e.source for e in sel.context}["agent"] == "given"
    assert {e.dimension: e.source for e in sel.context}["texture"] == "unknown"
    orb = next(c for c in sel.candidates if c.extractor == "ORB")
    nfeatures = next(a for a in orb.adjustments if a.parameter == "nfeatures")
    assert nfeatures.factor == pytest.approx(1.6 * 1.25 * 1.5)  # dark × fast × car, from default.nfex
    assert {c.label for c in nfeatures.citations} == {
        "adjust ORB.nfeatures by 1.6 when light is dark",
        "adjust ORB.nfeatures by 1.25 when motion is fast",
        "adjust ORB.nfeatures by 1.5 when agent is car",
    }
    assert sel.weights["texturedness"].value == 2.0


def test_a_sparql_rule_added_by_transaction_changes_the_next_selection_and_rollback_restores(bare_kg: KnowledgeGraph) -> None:
    kg = bare_kg  # without the shipped sweeps: their measured accuracy (SIFT best under bright light) would decide
    advisor = Advisor(kg, neural="symbolic")
    ctx = {"reflectance": "reflective", "light": "bright", "texture": "high"}
    before = advisor.select(ctx)
    assert before.extractor == "ORB"
    v0 = kg.version
    kg.add(parse_rdf(RULE), author="test")
    after = advisor.select(ctx)
    assert after.extractor != "ORB"
    [cite] = next(p for p in after.pruned if p.extractor == "ORB").because
    assert (cite.rule, cite.label, cite.kind) == (N + "rule_no_orb_on_mirrors", "No ORB on mirrors", "sparql")
    assert cite.reason == "test: FAST corners fire on specular highlights"
    assert advisor.select({"reflectance": "matte"}).pruned == ()  # other contexts unaffected
    kg.rollback(v0, author="test")
    restored = advisor.select(ctx)
    assert restored.extractor == "ORB" and restored.pruned == before.pruned and restored.versions["graph"] == v0 + 2


def test_unknown_context_names_are_rejected_with_the_known_ones(kg: KnowledgeGraph) -> None:
    with pytest.raises(UnknownName, match="known: bright, dark"):
        Advisor(kg).select({"light": "dim"})


def test_everything_pruned_is_an_error_that_says_why(kg: KnowledgeGraph) -> None:
    from nfex_core.rules.dsl import programs

    _, g = programs.compile_text("program block\n" + "\n".join(f"prune {x} when scene is indoor" for x in sorted(kg.vocabulary().extractors)),
                                 kg.vocabulary(), name="block")
    programs.apply(kg, g, "block", author="test")
    with pytest.raises(NoCandidate, match="prune ORB when scene is indoor"):
        Advisor(kg).select({"scene": "indoor"})


def test_current_snapshot_and_freshness(bare_kg: KnowledgeGraph) -> None:
    advisor = Advisor(bare_kg, neural="symbolic", poll_interval_s=60)
    assert advisor.current_snapshot() is None and not advisor.is_fresh()
    advisor.select({"agent": "car"})
    snap = advisor.current_snapshot()
    assert snap is not None and snap.version == bare_kg.version and advisor.is_fresh()
    bare_kg.add(parse_rdf('<urn:x> <urn:p> "1" .', format="nt"), author="test")  # a commit marks it stale
    assert not advisor.is_fresh() and advisor.current_snapshot() is snap
    advisor.select({"agent": "car"})
    assert advisor.is_fresh() and advisor.current_snapshot().version == bare_kg.version  # type: ignore[union-attr]
