"""`nfex kg export --owl`: the knowledge for OWL tools, without the SHACL shapes mixed in."""
from __future__ import annotations

from pathlib import Path

import pytest
import rdflib
from rdflib.namespace import OWL, RDF, SH

from nfex_core.kg import KnowledgeGraph
from nfex_core.kg.namespaces import NFEX
from nfex_core.kg.owl import CORE, owl_only
from nfex_core.kg.terms import is_skolem
from tests.conftest import run_cli


def _terms(g: rdflib.Graph) -> set[rdflib.term.Node]:
    return {t for triple in g for t in triple}


def test_the_owl_export_has_no_shacl_and_keeps_the_ontology(kg: KnowledgeGraph) -> None:
    full = kg.data_graph()
    assert any(str(t).startswith(str(SH)) for t in _terms(full))  # the store does mix them
    owl = owl_only(full)
    assert not any(str(t).startswith(str(SH)) for t in _terms(owl))
    assert not set(owl.subjects(RDF.type, SH.NodeShape))
    # the OWL is all there: every class, property and individual declaration of the full graph
    declarations = {(s, o) for s, o in full.subject_objects(RDF.type) if str(o).startswith(str(OWL)) and o != OWL.Ontology}
    assert declarations and declarations <= set(owl.subject_objects(RDF.type))
    assert (NFEX.ORB, RDF.type, NFEX.FeatureExtractor) in owl
    assert list(owl.subjects(RDF.type, OWL.Ontology)) == [CORE] and not list(owl.objects(None, OWL.imports))
    # no orphaned pieces of shapes: every skolemised node left is reached from a named node or is an OWL axiom
    # of its own (owl:AllDisjointClasses)
    roots = {s for s in owl.subjects() if not is_skolem(s)} | {s for s, o in owl.subject_objects(RDF.type) if str(o).startswith(str(OWL))}
    reached = set(roots) | {o for s, o in owl.subject_objects() if s in roots}
    for _ in range(10):
        reached |= {o for s, o in owl.subject_objects() if s in reached}
    assert {s for s in owl.subjects() if is_skolem(s)} <= reached


def test_kg_export_owl_writes_it(cli_env: dict[str, str], tmp_path: Path) -> None:
    out = tmp_path / "nfex.owl.ttl"
    p = run_cli(["kg", "export", "--owl", "-o", str(out)], cli_env)
    assert p.returncode == 0, p.stderr
    g = rdflib.Graph().parse(out)
    assert "http://www.w3.org/ns/shacl#" not in out.read_text() and (NFEX.SIFT, RDF.type, NFEX.FeatureExtractor) in g
    owlready2 = pytest.importorskip("owlready2")
    nt = tmp_path / "nfex.nt"
    nt.write_text(g.serialize(format="nt"))
    world = owlready2.World()
    world.get_ontology(nt.as_uri()).load(only_local=True)
    assert world["https://w3id.org/nfex#ORB"] is not None


def test_the_owl_export_is_owl2_dl_where_the_mixed_graph_is_not(kg: KnowledgeGraph) -> None:
    profiles = pytest.importorskip("pyowl2_profiles")
    import pyoxigraph as ox

    def violations(g: rdflib.Graph) -> int:
        store = ox.Store()
        store.load(g.serialize(format="nt").encode(), format=ox.RdfFormat.N_TRIPLES)
        return int(profiles.detect_profiles(store, graph_iri=None)["dl"]["total_violations"])

    full = kg.data_graph()
    assert violations(full) > 0  # SHACL's terms are undeclared properties to OWL
    assert violations(owl_only(full)) == 0
