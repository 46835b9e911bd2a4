"""The compiled context-shape check agrees with pySHACL, and shapes are data that transactions change.

Agreement: for every context over the shipped shapes' condition values (each value of every dimension
a shape mentions, and unknown) and for candidates Θ′ at, just inside and just outside every bound, the
set of shapes the compiled check says the candidate violates equals the set pySHACL reports on the
materialised candidate + context; after repair pySHACL reports nothing, and a pruned candidate still
violates the shape it is pruned by.
"""
from __future__ import annotations

import itertools
import math

import pytest
import rdflib
from rdflib.term import URIRef

from nfex_core.kg import KnowledgeGraph
from nfex_core.kg.shacl.validation import Shapes, run_pyshacl, shapes_closure
from nfex_core.kg.vocabulary.vocab import ParameterSpec, Value, Vocabulary
from nfex_core.rules.engine import compile_table
from nfex_core.rules.shape_check import enforce, materialise, violations
from nfex_core.rules.shapes import CompiledShape, context_shape_nodes

N = "https://w3id.org/nfex#"


def context_shapes_only(kg: KnowledgeGraph) -> Shapes:
    g = kg.shapes().graph
    return shapes_closure(set(context_shape_nodes(g)), lambda nodes: (t for n in nodes for t in g.triples((n, None, None))))


def contexts_over(shapes: list[CompiledShape], vocab: Vocabulary) -> list[dict[str, str | None]]:
    dims = sorted({a.dimension for s in shapes for a in s.atoms})
    axes = [[*vocab.dimensions[d].values, None] for d in dims]
    return [dict(zip(dims, combo, strict=True)) for combo in itertools.product(*axes)]


def near(p: ParameterSpec, b: Value) -> list[Value]:
    if p.datatype == "integer":
        return [int(math.floor(float(b))) + d for d in (-1, 0, 1)]
    f = float(b)
    return [math.nextafter(f, -math.inf), f, math.nextafter(f, math.inf)]


def candidates(vocab: Vocabulary, shapes: list[CompiledShape]) -> list[tuple[str, dict[str, Value]]]:
    """Defaults of every extractor, and Θ′ near every bound that ``shapes`` place on its parameters."""
    out: list[tuple[str, dict[str, Value]]] = [(x, spec.defaults()) for x, spec in vocab.extractors.items()]
    for b in [s.bound for s in shapes if s.bound is not None]:
        spec = vocab.extractor(b.extractor)
        for v in near(spec.parameters[b.parameter], b.literal.toPython()):
            out.append((b.extractor, {**spec.defaults(), b.parameter: v}))
    return out


def pyshacl_verdicts(data_graphs: list[rdflib.Graph], shapes: Shapes, batch: int = 120) -> dict[str, set[str]]:
    """Focus node → violated shapes; in batches (pySHACL's qualified value shapes grow quadratically)."""
    out: dict[str, set[str]] = {}
    for i in range(0, len(data_graphs), batch):
        data = rdflib.Graph()
        for g in data_graphs[i : i + batch]:
            data += g
        results, _ = run_pyshacl(data, shapes, None)
        for r in results:
            out.setdefault(r.focus_node, set()).add(r.source_shape)
    return out


def check_agreement(kg: KnowledgeGraph, contexts: list[dict[str, str | None]], cands: list[tuple[str, dict[str, Value]]]) -> int:
    """Assert the compiled verdicts equal pySHACL's on every (context, candidate); return the violations seen."""
    table = compile_table(kg)
    vocab = kg.vocabulary()
    graphs, expected, repaired = [], {}, {}
    for i, ctx in enumerate(contexts):
        decision = table.decide(ctx)
        for j, (x, theta) in enumerate(cands):
            spec = vocab.extractor(x)
            node = URIRef(f"{N}cand_{i}_{j}")
            graphs.append(materialise(vocab, x, theta, ctx, node))
            expected[str(node)] = {str(s.iri) for s in violations(spec, theta, decision.shapes)}
            outcome = enforce(spec, theta, decision.shapes)
            if outcome.pruned:
                assert x in decision.pruned or expected[str(node)]
            if outcome.adjustments:
                fixed = URIRef(f"{N}fixed_{i}_{j}")
                graphs.append(materialise(vocab, x, outcome.params, ctx, fixed))
                repaired[str(fixed)] = {c.rule for c in outcome.pruned}
            elif outcome.pruned:
                assert {c.rule for c in outcome.pruned} <= expected[str(node)]
    found = pyshacl_verdicts(graphs, context_shapes_only(kg))

    disagreements = [(n, want, found.get(n, set())) for n, want in expected.items() if found.get(n, set()) != want]
    assert disagreements == []
    for n, cited in repaired.items():
        if cited:  # pruned after a repair: the cited shape is still violated by what was left
            assert cited <= found.get(n, set()), n
        else:  # repaired: pySHACL agrees nothing is violated
            assert found.get(n, set()) == set(), n
    return sum(1 for v in expected.values() if v)


def shipped(kg: KnowledgeGraph) -> list[CompiledShape]:
    table = compile_table(kg)
    assert not table.errors
    out = sorted({s for d in table.decisions.values() for s in d.shapes}, key=lambda s: str(s.iri))
    assert {str(s.iri) for s in out} >= {N + "shape_orb_dark_fast_threshold", N + "shape_sift_fast_contrast"}
    return out


def test_each_shape_agrees_with_pyshacl_over_its_dimensions(kg: KnowledgeGraph) -> None:
    """Per shipped shape: every context over the dimensions it reads, Θ′ around its bound."""
    vocab = kg.vocabulary()
    seen = 0
    for shape in shipped(kg):
        cands = [(x, spec.defaults()) for x, spec in vocab.extractors.items()] + candidates(vocab, [shape])[len(vocab.extractors) :]
        seen += check_agreement(kg, contexts_over([shape], vocab), cands)
    assert seen > 20  # the grid does exercise violations


@pytest.mark.slow
def test_compiled_check_agrees_with_pyshacl_on_every_context(kg: KnowledgeGraph) -> None:
    """The joint grid: every context over all shipped shapes' values (and unknown), Θ′ near every bound."""
    vocab = kg.vocabulary()
    shapes = shipped(kg)
    contexts = contexts_over(shapes, vocab)
    assert len(contexts) >= 3 * 4 * 3 * 4  # light, agent, motion, texture: values and unknown
    assert check_agreement(kg, contexts, candidates(vocab, shapes)) > 100


def test_unknown_dimension_satisfies_no_atom(kg: KnowledgeGraph) -> None:
    table = compile_table(kg)
    d = table.decide({"texture": "low"})  # light unknown: "light is not bright" does not hold
    assert N + "shape_orb_low_texture_budget" not in {str(s.iri) for s in d.shapes}
    d = table.decide({"texture": "low", "light": "dark"})
    assert N + "shape_orb_low_texture_budget" in {str(s.iri) for s in d.shapes}


def test_prohibition_prunes_at_compile_time_and_cites_the_shape(kg: KnowledgeGraph) -> None:
    d = compile_table(kg).decide({"light": "dark", "texture": "low"})
    assert "BRISK" not in d.candidates
    [cite] = d.pruned["BRISK"]
    assert cite.rule == N + "shape_dark_low_texture_no_brisk" and cite.kind == "shape"
    assert "AGAST" in cite.reason
    assert "BRISK" in compile_table(kg).decide({"light": "dark"}).candidates


def test_bounds_are_repaired_by_clamping_and_prune_flag_prunes(kg: KnowledgeGraph) -> None:
    vocab = kg.vocabulary()
    table = compile_table(kg)
    orb, sift = vocab.extractor("ORB"), vocab.extractor("SIFT")
    d = table.decide({"light": "dark", "agent": "drone"})
    out = enforce(orb, {**orb.defaults(), "fastThreshold": 37, "nlevels": 12}, d.shapes)
    assert not out.pruned and out.params["fastThreshold"] == 10 and out.params["nlevels"] == 8
    cited = {a.parameter: a.citations[0] for a in out.adjustments}
    assert cited["fastThreshold"].rule == N + "shape_orb_dark_fast_threshold" and cited["fastThreshold"].kind == "shape"
    assert "fastThreshold <= 10" in cited["fastThreshold"].reason
    assert all(a.clamped for a in out.adjustments)
    # nfex:pruneOnViolation: SIFT with 4 layers on a drone is pruned, not clamped
    out = enforce(sift, {**sift.defaults(), "nOctaveLayers": 4}, d.shapes)
    assert [c.rule for c in out.pruned] == [N + "shape_drone_sift_layers"]
    assert not enforce(sift, sift.defaults(), d.shapes).pruned


BAD = """@prefix nfex: <https://w3id.org/nfex#> . @prefix sh: <http://www.w3.org/ns/shacl#> .
nfex:shape_test_vacuous a sh:NodeShape, nfex:ContextShape ; sh:targetClass nfex:CandidateConfiguration ;
    sh:or ( [ sh:not [ sh:property [ sh:path nfex:ofExtractor ; sh:hasValue nfex:BRISK ] ,
                                   [ sh:path nfex:underCondition ; sh:hasValue nfex:scene_indoor ] ] ]
            [ sh:property [ sh:path nfex:ofExtractor ; sh:minCount 1 ] ] ) .
nfex:shape_test_odd_gate a sh:NodeShape, nfex:ContextShape ; sh:targetClass nfex:CandidateConfiguration ;
    sh:or ( [ sh:not [ sh:property [ sh:path nfex:token ; sh:hasValue "x" ] ] ]
            [ sh:not [ sh:property [ sh:path nfex:ofExtractor ; sh:hasValue nfex:BRISK ] ] ] ) .
"""


def test_shapes_not_of_the_compiled_form_are_reported_not_applied(kg: KnowledgeGraph) -> None:
    import rdflib as _rdflib

    kg.add(_rdflib.Graph().parse(data=BAD, format="turtle"), author="t")
    table = compile_table(kg)
    vacuous = [e for e in table.errors if "shape_test_vacuous" in e]
    odd = [e for e in table.errors if "shape_test_odd_gate" in e]
    assert len(vacuous) == 1 and "neither a parameter bound nor violated" in vacuous[0] and "BRISK" in vacuous[0]
    assert len(odd) == 1 and "the gate may read" in odd[0]
    assert "BRISK" in table.decide({"scene": "indoor"}).candidates


def test_context_shapes_compile_again_only_when_shapes_or_vocabulary_change(kg: KnowledgeGraph, monkeypatch: pytest.MonkeyPatch) -> None:
    import rdflib as _rdflib

    from nfex_core.rules import shapes as shapes_module

    calls: list[object] = []
    real = shapes_module.compile_shape
    monkeypatch.setattr(shapes_module, "compile_shape", lambda g, vocab, node: calls.append(node) or real(g, vocab, node))
    first = compile_table(kg)
    n = len(calls)
    assert n > 0 and not any("shape_test_" in e for e in first.errors)
    kg.update("PREFIX nfex: <https://w3id.org/nfex#> INSERT DATA { nfex:ORB nfex:note 'unrelated' }", author="t")
    assert compile_table(kg, first).errors == first.errors and len(calls) == n  # the same shapes graph and vocabulary
    kg.add(_rdflib.Graph().parse(data=BAD, format="turtle"), author="t")  # a shape edit: compiled again, and seen
    errors = compile_table(kg).errors
    assert len(calls) > n and sum("shape_test_" in e for e in errors) == 2
    kg.remove(_rdflib.Graph().parse(data=BAD, format="turtle"), author="t")
    assert not any("shape_test_" in e for e in compile_table(kg).errors)
