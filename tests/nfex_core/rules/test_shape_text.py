"""require_shape writes the compiled form; describe prints it back; every comparator agrees with pySHACL."""
from __future__ import annotations

import sys
from pathlib import Path

import pytest
from rdflib.term import URIRef

from nfex_core.kg import KnowledgeGraph
from nfex_core.rules.engine import compile_table
from nfex_core.rules.shape_text import describe, require_shape
from nfex_core.rules.types import ConditionAtom as Atom

sys.path.insert(0, str(Path(__file__).parent))
from test_shapes_compiled import candidates, check_agreement, contexts_over  # noqa: E402

N = "https://w3id.org/nfex#"


def compiled(kg: KnowledgeGraph, iri: str):  # type: ignore[no-untyped-def]
    table = compile_table(kg)
    assert not table.errors
    return next(s for d in table.decisions.values() for s in d.shapes if str(s.iri) == iri)


def test_shipped_shapes_print_as_dsl_lines(kg: KnowledgeGraph) -> None:
    assert describe(compiled(kg, N + "shape_orb_dark_fast_threshold")) == "require ORB.fastThreshold <= 10 when light is dark"
    assert describe(compiled(kg, N + "shape_sift_fast_contrast")) == "require SIFT.contrastThreshold <= 0.03 when motion is fast"
    assert describe(compiled(kg, N + "shape_drone_sift_layers")) == (
        "require SIFT.nOctaveLayers <= 3 when agent is one of (drone, human)   # prune on violation"
    )
    assert describe(compiled(kg, N + "shape_dark_low_texture_no_brisk")) == "prune BRISK when light is dark and texture is low"
    assert "light is not bright" in describe(compiled(kg, N + "shape_orb_low_texture_budget"))


@pytest.mark.parametrize(
    ("parameter", "cmp", "bound", "atoms", "text"),
    [
        ("ORB.scaleFactor", "<", 1.3, (Atom("scene", frozenset({"outdoor"})),), "require ORB.scaleFactor < 1.3 when scene is outdoor"),
        ("AKAZE.threshold", ">=", 0.002, (Atom("reflectance", frozenset({"reflective"}), True),), "require AKAZE.threshold >= 0.002 when reflectance is not reflective"),
        ("BRISK.thresh", ">", 40, (Atom("agent", frozenset({"car", "human"})),), "require BRISK.thresh > 40 when agent is one of (car, human)"),
        ("BRISK.octaves", "=", 2, (), "require BRISK.octaves = 2"),
    ],
)
def test_require_shapes_round_trip_and_agree_with_pyshacl(kg: KnowledgeGraph, parameter, cmp, bound, atoms, text) -> None:  # type: ignore[no-untyped-def]
    iri = URIRef(N + "shape_test")
    kg.add(require_shape(iri, kg.vocabulary(), parameter, cmp, bound, atoms), author="t", message="a require shape")
    shape = compiled(kg, str(iri))
    assert describe(shape) == text
    vocab = kg.vocabulary()
    contexts = contexts_over([shape], vocab)
    assert check_agreement(kg, contexts, candidates(vocab, [shape])) > 0


REQUIRE = '''program site
require ORB.fastThreshold <= 7 when scene is outdoor and reflectance is reflective because "glare: keep weak corners"
require AKAZE.nOctaves >= 5 when scene is outdoor and reflectance is reflective
'''


def test_a_dsl_require_becomes_a_shape_that_the_advisor_applies_and_remove_takes_away(kg: KnowledgeGraph) -> None:
    from nfex_core.advisor import Advisor
    from nfex_core.rules.dsl import programs
    from nfex_core.rules.shape_text import program_shapes

    ctx = {"scene": "outdoor", "reflectance": "reflective"}
    advisor = Advisor(kg, poll_interval_s=0.0, neural="symbolic")
    before = {c.extractor: c.params for c in advisor.select(ctx).candidates}
    outdoor = {c.extractor: c.params for c in advisor.select({"scene": "outdoor"}).candidates}
    triples = kg.triple_count()
    _, graph = programs.compile_text(REQUIRE, kg.vocabulary(), name="site")
    programs.apply(kg, graph, "site", author="t")

    table = compile_table(kg)
    assert not table.errors
    shapes = {describe(s): s for s in table.decide(ctx).shapes}
    line = "require ORB.fastThreshold <= 7 when scene is outdoor and reflectance is reflective"
    assert set(shapes) == {line, "require AKAZE.nOctaves >= 5 when scene is outdoor and reflectance is reflective"}
    assert shapes[line].kind == "shape" and str(shapes[line].iri).endswith("_shape")
    assert shapes[line].message == "glare: keep weak corners"
    assert [ln for _, ln in program_shapes(kg, "site")][0].startswith(line + "   # " + N + "statement_site_")

    sel = {c.extractor: c for c in advisor.select(ctx).candidates}
    assert sel["ORB"].params["fastThreshold"] == 7 and sel["AKAZE"].params["nOctaves"] == 5
    [adj] = [a for a in sel["ORB"].adjustments if a.parameter == "fastThreshold" and a.citations[0].kind == "shape"]
    assert adj.citations[0].rule == str(shapes[line].iri) and adj.citations[0].reason == "glare: keep weak corners"
    assert {c.extractor: c.params for c in advisor.select({"scene": "outdoor"}).candidates} == outdoor  # not in force there

    programs.remove(kg, "site", author="t")  # the statements and their shapes go together
    assert kg.triple_count() == triples
    assert {c.extractor: c.params for c in advisor.select(ctx).candidates} == before
