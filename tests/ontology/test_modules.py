"""Each ontology module is an ontology of its own, as Protégé opens it: it names itself, its version and
licence, imports the modules whose terms it uses, and the XML catalog resolves every import offline."""
from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
import rdflib
from rdflib.namespace import DCTERMS, OWL, RDF, RDFS

import nfex_core
from nfex_core.kg.namespaces import NFEX

ONTOLOGY = Path(__file__).resolve().parents[2] / "ontology"
MODULES = sorted(p.stem for p in ONTOLOGY.glob("*.ttl"))
BASE = "https://w3id.org/nfex"
DECLARING = {OWL.Class, OWL.ObjectProperty, OWL.DatatypeProperty, OWL.AnnotationProperty, OWL.NamedIndividual, RDFS.Datatype}


def module_iri(name: str) -> str:
    return BASE if name == "nfex" else f"{BASE}/{name}"


def catalog() -> dict[str, Path]:
    """IRI → file, as catalog-v001.xml maps them (Protégé's OASIS XML catalog)."""
    root = ET.parse(ONTOLOGY / "catalog-v001.xml").getroot()
    ns = {"c": "urn:oasis:names:tc:entity:xmlns:xml:catalog"}
    return {e.attrib["name"]: ONTOLOGY / e.attrib["uri"] for e in root.findall("c:uri", ns)}


def parse(name: str) -> rdflib.Graph:
    return rdflib.Graph().parse(ONTOLOGY / f"{name}.ttl")


def closure(name: str) -> list[str]:
    """The module and everything it imports, transitively, each resolved through the catalog."""
    files = catalog()
    seen: list[str] = []
    todo = [module_iri(name)]
    while todo:
        iri = todo.pop()
        if iri in seen:
            continue
        assert iri in files, f"{iri} is imported but the catalog does not map it"
        seen.append(iri)
        todo += [str(o) for o in rdflib.Graph().parse(files[iri]).objects(rdflib.URIRef(iri), OWL.imports)]
    return seen


@pytest.mark.parametrize("name", MODULES)
def test_each_module_names_itself_its_version_and_licence(name: str) -> None:
    g = parse(name)
    iri = rdflib.URIRef(module_iri(name))
    assert list(g.subjects(RDF.type, OWL.Ontology)) == [iri]
    version = nfex_core.__version__
    assert g.value(iri, OWL.versionIRI) == rdflib.URIRef(f"{BASE}/{version}" + ("" if name == "nfex" else f"/{name}"))
    assert str(g.value(iri, OWL.versionInfo)) == version
    assert g.value(iri, DCTERMS.license) == rdflib.URIRef("https://www.apache.org/licenses/LICENSE-2.0")
    assert g.value(iri, RDFS.label) is not None


def test_the_catalog_maps_every_module_and_version_to_its_file() -> None:
    files = catalog()
    for name in MODULES:
        g = parse(name)
        iri = rdflib.URIRef(module_iri(name))
        for key in (iri, g.value(iri, OWL.versionIRI)):
            assert files.get(str(key)) == ONTOLOGY / f"{name}.ttl", key
    assert all(p.is_file() for p in files.values())


@pytest.mark.parametrize("name", MODULES)
def test_every_term_a_module_uses_is_declared_in_what_it_imports(name: str) -> None:
    """What Protégé needs to open the module alone without undeclared entities (OWL 2 DL's typing)."""
    files = catalog()
    merged = rdflib.Graph()
    for iri in closure(name):
        merged.parse(files[iri])
    declared = {s for s, o in merged.subject_objects(RDF.type) if o in DECLARING or str(o).startswith(str(NFEX))}
    used = {t for triple in parse(name) for t in triple if isinstance(t, rdflib.URIRef) and str(t).startswith(str(NFEX))}
    # IRIs of rules defined by rules/pruning/*.rq (seeded beside the ontology) stand as plain individuals
    missing = sorted(str(t) for t in used - declared if not str(t).startswith(str(NFEX) + "rule_"))
    assert missing == []


@pytest.mark.parametrize("name", MODULES)
def test_each_module_loads_alone_in_owlready2_through_the_catalog(name: str, tmp_path: Path) -> None:
    owlready2 = pytest.importorskip("owlready2")
    # owlready2 reads no Turtle and no catalog: lay the catalog's files out where it looks (onto_path, by the
    # IRI's last segment), as N-Triples, and forbid it the network
    for iri, path in catalog().items():
        (tmp_path / (iri.rsplit("/", 1)[-1] + ".nt")).write_text(rdflib.Graph().parse(path).serialize(format="nt"))
    saved = list(owlready2.onto_path)
    owlready2.onto_path[:] = [str(tmp_path)]
    try:
        world = owlready2.World()
        onto = world.get_ontology(module_iri(name)).load(only_local=True)
        assert {o.base_iri.rstrip("#/") for o in onto.imported_ontologies} == set(closure(name)[1:]) & {
            str(o) for o in parse(name).objects(rdflib.URIRef(module_iri(name)), OWL.imports)}
        assert len(list(world.classes())) >= 10  # nfex.ttl's TBox came along through the imports
    finally:
        owlready2.onto_path[:] = saved


@pytest.mark.parametrize("name", MODULES)
def test_each_module_with_its_imports_is_owl2_dl(name: str) -> None:
    """OWL 2 DL profile, as pyowl2-profiles checks it (structural checks over the RDF; the OWL API's profile
    checker is Java-only)."""
    profiles = pytest.importorskip("pyowl2_profiles")
    import pyoxigraph as ox

    store = ox.Store()
    for iri in closure(name):
        store.load(catalog()[iri].read_bytes(), format=ox.RdfFormat.TURTLE)
    dl = profiles.detect_profiles(store, graph_iri=None)["dl"]
    assert dl["in_profile"], (dl["total_violations"], dl["sample_violations"][:5])
