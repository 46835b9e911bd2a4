"""The ontology parses, says what the paper describes, documents every term, and is consistent OWL."""
from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest
import rdflib
from rdflib.namespace import OWL, RDF, RDFS

from nfex_core.kg.namespaces import NFEX

ONTOLOGY = Path(__file__).resolve().parents[2] / "ontology"


@pytest.fixture(scope="module")
def onto() -> rdflib.Graph:
    g = rdflib.Graph()
    for f in sorted(ONTOLOGY.rglob("*.ttl")):
        g.parse(f)
    # all modules merged: what they import of each other is inside (test_modules.py loads them one by one)
    g.remove((None, OWL.imports, None))
    return g


def test_every_nfex_term_has_a_label_and_a_comment(onto: rdflib.Graph) -> None:
    declared = {s for s in onto.subjects(RDF.type, None) if isinstance(s, rdflib.URIRef) and str(s).startswith(str(NFEX))}
    kinds = {OWL.Class, OWL.ObjectProperty, OWL.DatatypeProperty, OWL.AnnotationProperty, OWL.NamedIndividual}
    terms = {s for s in declared if set(onto.objects(s, RDF.type)) & kinds or (s, RDF.type, OWL.NamedIndividual) in onto}
    assert len(terms) > 150
    missing = sorted(str(t) for t in terms if onto.value(t, RDFS.label) is None or onto.value(t, RDFS.comment) is None)
    assert missing == []


def test_orb_and_sift_perform_the_papers_operations(onto: rdflib.Graph) -> None:
    ops = {x: {str(o).rsplit("#")[-1] for o in onto.objects(NFEX[x], NFEX.performs)} for x in ("ORB", "SIFT")}
    assert ops["ORB"] == {"ImagePyramid", "FASTHarris", "IntensityCentroid", "SteeredBRIEF"}
    assert ops["SIFT"] == {"GaussianScaleSpace", "DifferenceOfGaussians", "GradientOrientation", "GradientHistogram"}
    for x in ("ORB", "SIFT"):
        kinds = {c for o in ops[x] for c in onto.objects(NFEX[o], RDF.type)} - {OWL.NamedIndividual}
        assert kinds == {NFEX.ScaleSpaceRepresentation, NFEX.KeypointDetection, NFEX.TransformInvariance, NFEX.DescriptorGeneration}
        assert onto.value(NFEX[x], NFEX.opencvConstructor) is not None


def _params(onto: rdflib.Graph, x: str) -> dict[str, str]:
    return {
        str(onto.value(p, NFEX.opencvName)): str(onto.value(p, NFEX.role)).rsplit("#")[-1]
        for p in onto.subjects(NFEX.parameterOf, NFEX[x])
    }


def test_parameters_with_roles_as_the_paper_names_them(onto: rdflib.Graph) -> None:
    orb = _params(onto, "ORB")
    # every argument of ORB_create
    assert set(orb) == {"nfeatures", "scaleFactor", "nlevels", "edgeThreshold", "firstLevel", "WTA_K", "scoreType", "patchSize", "fastThreshold"}
    assert (orb["nfeatures"], orb["scaleFactor"], orb["nlevels"], orb["fastThreshold"]) == ("NF", "SF", "NL", "ST")
    sift = _params(onto, "SIFT")
    assert {"nfeatures", "nOctaveLayers", "contrastThreshold", "edgeThreshold", "sigma"} <= set(sift)
    assert sift["nfeatures"] == "NF" and sift["contrastThreshold"] == "ST"


def test_condition_dimensions_and_values(onto: rdflib.Graph) -> None:
    dims: dict[str, set[str]] = {}
    for v in onto.subjects(RDF.type, NFEX.ConditionValue):
        d = onto.value(v, NFEX.inDimension)
        dims.setdefault(str(onto.value(d, NFEX.token)), set()).add(str(onto.value(v, NFEX.token)))
    assert dims == {
        "agent": {"car", "drone", "human"},
        "motion": {"slow", "fast"},
        "scene": {"indoor", "outdoor"},
        "light": {"bright", "dark"},
        "reflectance": {"reflective", "matte"},
        "texture": {"low", "medium", "high"},
    }


def test_quality_metrics_m1_to_m7_with_formulas(onto: rdflib.Graph) -> None:
    symbols = {str(onto.value(m, NFEX.symbol)): onto.value(m, NFEX.formula) for m in onto.subjects(RDF.type, NFEX.QualityMetric)}
    assert sorted(symbols) == [f"m{i}" for i in range(1, 8)]
    assert all(f is not None and len(str(f)) > 5 for f in symbols.values())


def test_measurement_is_a_sosa_observation_with_prov(onto: rdflib.Graph) -> None:
    assert (NFEX.Measurement, RDFS.subClassOf, rdflib.URIRef("http://www.w3.org/ns/sosa/Observation")) in onto
    assert (NFEX.Configuration, RDFS.subClassOf, rdflib.URIRef("http://www.w3.org/ns/sosa/Procedure")) in onto
    assert (NFEX.Run, RDFS.subClassOf, rdflib.URIRef("http://www.w3.org/ns/prov#Activity")) in onto
    for cls in ("Rule", "Program", "Configuration", "Measurement"):
        assert (NFEX[cls], RDF.type, OWL.Class) in onto


@pytest.fixture(scope="module")
def owl_world(onto: rdflib.Graph, tmp_path_factory: pytest.TempPathFactory):  # type: ignore[no-untyped-def]
    owlready2 = pytest.importorskip("owlready2")
    path = tmp_path_factory.mktemp("owl") / "nfex.nt"
    path.write_text(onto.serialize(format="nt"))  # owlready2 reads N-Triples and RDF/XML, not Turtle
    world = owlready2.World()
    ontology = world.get_ontology(path.as_uri()).load()
    return world, ontology


def test_loads_in_owlready2(owl_world) -> None:  # type: ignore[no-untyped-def]
    world, _ = owl_world
    orb = world["https://w3id.org/nfex#ORB"]
    assert orb is not None
    assert "FeatureExtractor" in {c.name for c in orb.is_a}
    assert len(list(world.classes())) >= 20


@pytest.mark.java
def test_consistent_under_hermit(owl_world) -> None:  # type: ignore[no-untyped-def]
    if shutil.which("java") is None:
        pytest.skip("no Java runtime: owlready2's HermiT reasoner needs one")
    import owlready2

    world, ontology = owl_world
    try:
        with ontology:
            owlready2.sync_reasoner_hermit(world, infer_property_values=False, debug=0)
    except owlready2.OwlReadyInconsistentOntologyError:  # pragma: no cover - the assertion below explains
        pytest.fail("HermiT reports the ontology inconsistent")
    except subprocess.CalledProcessError as e:  # pragma: no cover
        pytest.fail(f"HermiT failed to run: {e}")
    assert not list(world.inconsistent_classes())


@pytest.mark.java
def test_hermit_catches_an_inconsistency(onto: rdflib.Graph, tmp_path: Path) -> None:
    """The consistency test above can fail: an operation in two disjoint classes is caught."""
    if shutil.which("java") is None:
        pytest.skip("no Java runtime: owlready2's HermiT reasoner needs one")
    import owlready2

    bad = rdflib.Graph() + onto
    bad.add((NFEX.ImagePyramid, RDF.type, NFEX.KeypointDetection))
    path = tmp_path / "bad.nt"
    path.write_text(bad.serialize(format="nt"))
    world = owlready2.World()
    ontology = world.get_ontology(path.as_uri()).load()
    with pytest.raises(owlready2.OwlReadyInconsistentOntologyError):
        with ontology:
            owlready2.sync_reasoner_hermit(world, infer_property_values=False, debug=0)
