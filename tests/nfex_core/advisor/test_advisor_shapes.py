"""A context shape added by a transaction changes the next selection, cited; a rollback undoes it."""
from __future__ import annotations

from rdflib.term import URIRef

from nfex_core.advisor import Advisor
from nfex_core.kg import KnowledgeGraph, parse_rdf
from nfex_core.rules.shape_text import require_shape

N = "https://w3id.org/nfex#"
CTX = {"scene": "outdoor", "reflectance": "reflective"}  # no shipped shape reads these dimensions


def prohibition(x: str) -> str:
    return f"""@prefix nfex: <{N}> . @prefix sh: <http://www.w3.org/ns/shacl#> . @prefix rdfs: <http://www.w3.org/2000/01/rdf-schema#> .
nfex:shape_test_no_{x} a sh:NodeShape, nfex:ContextShape ; rdfs:label "no {x} on shiny outdoor scenes" ;
    sh:targetClass nfex:CandidateConfiguration ; sh:message "test: {x} is not used on reflective outdoor scenes." ;
    sh:or ( [ sh:not [ sh:property [ sh:path nfex:ofExtractor ; sh:hasValue nfex:{x} ] ,
                                   [ sh:path nfex:underCondition ; sh:hasValue nfex:scene_outdoor ] ,
                                   [ sh:path nfex:underCondition ; sh:hasValue nfex:reflectance_reflective ] ] ]
            [ sh:not [ sh:property [ sh:path nfex:ofExtractor ; sh:hasValue nfex:{x} ] ] ] ) ."""


def test_a_shape_added_by_transaction_clamps_then_prunes_and_rollback_restores(bare_kg: KnowledgeGraph) -> None:
    kg = bare_kg  # without the shipped sweeps, whose outdoor evidence would make "indoor" choose differently
    advisor = Advisor(kg, poll_interval_s=0.0, neural="symbolic")
    before = advisor.select(CTX)
    x = before.extractor
    spec = kg.vocabulary().extractor(x)
    name, p = next((n, p) for n, p in spec.parameters.items() if p.tunable and p.datatype == "integer" and p.min is not None and p.default > p.min)
    bound = (int(p.min) + int(p.default)) // 2
    start = kg.version

    # a bound: the same extractor, its parameter clamped to the bound, citing the shape
    shape = N + "shape_test_bound"
    kg.add(require_shape(URIRef(shape), kg.vocabulary(), f"{x}.{name}", "<=", bound, ()), author="t")
    clamped = advisor.select(CTX)
    assert clamped.extractor == x and clamped.params[name] == bound
    [adj] = [a for c in clamped.candidates if c.extractor == x for a in c.adjustments if a.parameter == name]
    assert (adj.before, adj.after) == (before.params[name], bound) and adj.clamped
    assert [(c.rule, c.kind) for c in adj.citations] == [(shape, "shape")]
    assert f"{x}.{name} <= {bound}" in adj.citations[0].reason

    # a prohibition: the extractor is pruned, citing the shape and its message
    kg.add(parse_rdf(prohibition(x)), author="t")
    pruned = advisor.select(CTX)
    assert pruned.extractor != x
    [because] = [p.because for p in pruned.pruned if p.extractor == x]
    assert because[0].rule == N + f"shape_test_no_{x}" and because[0].kind == "shape"
    assert because[0].reason == f"test: {x} is not used on reflective outdoor scenes."
    assert advisor.select({"scene": "indoor"}).extractor == x  # another context: not affected

    kg.rollback(start, author="t")
    after = advisor.select(CTX)
    assert (after.extractor, after.params, after.pruned) == (before.extractor, before.params, before.pruned)
