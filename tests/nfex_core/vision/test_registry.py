"""Contract test over every extractor the graph registers, and extractors as data (issue 3, part 1)."""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
import rdflib
from nfex_slam.datasets.synthetic import make_sequence
from nfex_slam.features import Features

from nfex_core.errors import ParameterError, UnknownName
from nfex_core.kg import KnowledgeGraph
from nfex_core.kg.vocabulary.vocab import Vocabulary
from nfex_core.vision.registry import ExtractorRegistry

ONTOLOGY = [Path(__file__).resolve().parents[3] / "ontology" / f for f in ("extractors.ttl", "learned.ttl")]
NFEX = rdflib.Namespace("https://w3id.org/nfex#")


def _ontology_extractors(backend: rdflib.URIRef | None = None) -> list[str]:
    g = rdflib.Graph()
    for path in ONTOLOGY:
        g.parse(path)
    return sorted(str(t) for x in g.subjects(rdflib.RDF.type, NFEX.FeatureExtractor) for t in g.objects(x, NFEX.token)
                  if backend is None or (x, NFEX.backend, backend) in g)


EXTRACTORS = _ontology_extractors()
OPENCV_EXTRACTORS = _ontology_extractors(NFEX.OpenCVBackend)  # those a Selection's ``opencv`` recipe can build


def test_the_seeded_graph_registers_the_four_extractors(registry: ExtractorRegistry) -> None:
    assert registry.names == EXTRACTORS
    assert {"ORB", "SIFT", "AKAZE", "BRISK", "XFEAT"} <= set(registry.names)


@pytest.fixture(scope="module")
def runnable(vocab: Vocabulary) -> set[str]:
    """The extractors whose backend runs here (XFeat needs the `learned` extra, which `make test` installs)."""
    from nfex_core.vision.backends import unavailable

    return set(vocab.extractors) - set(unavailable(vocab.extractors))


def _need(name: str, runnable: set[str]) -> None:
    if name not in runnable:
        pytest.skip(f"{name}'s backend cannot run here (pip install -e '.[learned]')")


def check_contract(feats: Features, image: np.ndarray, spec_kind: str) -> None:
    n = len(feats)
    assert feats.xy.shape == (n, 2) and feats.xy.dtype == np.float32
    for arr, dtype in ((feats.size, np.float32), (feats.angle, np.float32), (feats.response, np.float32), (feats.octave, np.int32)):
        assert arr.shape == (n,) and arr.dtype == dtype
    assert feats.descriptors.ndim == 2 and feats.descriptors.shape[0] == n
    assert feats.descriptors.dtype == (np.uint8 if spec_kind == "binary" else np.float32)
    assert feats.descriptors.flags["C_CONTIGUOUS"]
    assert feats.image_shape == image.shape[:2]
    assert feats.norm == int(getattr(cv2, feats.norm_name))
    h, w = image.shape[:2]
    assert np.all(feats.xy[:, 0] >= 0) and np.all(feats.xy[:, 0] < w)
    assert np.all(feats.xy[:, 1] >= 0) and np.all(feats.xy[:, 1] < h)
    assert np.all(np.isfinite(feats.xy)) and np.all(feats.size > 0)


@pytest.mark.parametrize("name", EXTRACTORS)
def test_contract_on_a_real_frame(name: str, registry: ExtractorRegistry, euroc_pair: list[np.ndarray],
                                  runnable: set[str]) -> None:
    _need(name, runnable)
    image = euroc_pair[0]
    spec = registry.spec(name)
    feats = registry.extract(name, image)
    assert len(feats) > 50, f"{name} found only {len(feats)} features on a textured EuRoC frame"
    check_contract(feats, image, spec.descriptor_kind)
    assert feats.descriptors.shape[1] == registry.descriptor_size(name)
    assert feats.norm_name == spec.norm_for(registry.resolve(name))


@pytest.mark.parametrize("name", EXTRACTORS)
def test_contract_on_a_synthetic_frame(name: str, registry: ExtractorRegistry, runnable: set[str]) -> None:
    """The same contract on the generator's textured planes: it never depends on the data folder."""
    _need(name, runnable)
    image = make_sequence(1, 640, 480)[0].image
    feats = registry.extract(name, image)
    assert len(feats) > 50, f"{name} found only {len(feats)} features on a synthetic textured frame"
    check_contract(feats, image, registry.spec(name).descriptor_kind)
    assert feats.descriptors.shape[1] == registry.descriptor_size(name)


@pytest.mark.parametrize("name", EXTRACTORS)
def test_same_input_gives_the_same_output(name: str, vocab: Vocabulary, euroc_pair: list[np.ndarray],
                                          runnable: set[str]) -> None:
    _need(name, runnable)
    image = euroc_pair[1]
    a = ExtractorRegistry.from_vocabulary(vocab).extract(name, image)
    b = ExtractorRegistry.from_vocabulary(vocab).extract(name, image.copy())  # a fresh detector too
    c = ExtractorRegistry.from_vocabulary(vocab).extract(name, cv2.cvtColor(image, cv2.COLOR_GRAY2BGR))
    for other in (b, c):
        assert len(a) == len(other)
        np.testing.assert_array_equal(a.xy, other.xy)
        np.testing.assert_array_equal(a.descriptors, other.descriptors)
        np.testing.assert_array_equal(a.response, other.response)


@pytest.mark.parametrize("name", EXTRACTORS)
@pytest.mark.parametrize("shape", [(480, 752), (64, 64), (376, 1241, 3)])
def test_black_image_gives_zero_features_without_error(name: str, shape: tuple[int, ...], registry: ExtractorRegistry,
                                                       runnable: set[str]) -> None:
    _need(name, runnable)
    image = np.zeros(shape, np.uint8)
    feats = registry.extract(name, image)
    assert len(feats) == 0
    check_contract(feats, image, registry.spec(name).descriptor_kind)
    assert feats.descriptors.shape == (0, registry.descriptor_size(name))


@pytest.mark.parametrize("name", EXTRACTORS)
def test_out_of_range_parameters_name_the_parameter_and_its_range(name: str, registry: ExtractorRegistry) -> None:
    spec = registry.spec(name)
    checked = 0
    for p in spec.parameters.values():
        if p.allowed is not None:
            bad = max(p.allowed) + 1  # type: ignore[operator]
        elif p.max is not None and p.datatype != "boolean":
            bad = p.max + 1  # type: ignore[operator]
        else:
            continue
        with pytest.raises(ParameterError) as err:
            registry.extract(name, np.zeros((32, 32), np.uint8), {p.name: bad})
        text = str(err.value)
        assert f"{name}.{p.name}" in text and repr(bad) in text and p.range_text() in text
        checked += 1
    assert checked >= 3
    with pytest.raises(UnknownName) as unknown:
        registry.resolve(name, {"no_such_parameter": 1})
    assert f"{name}.no_such_parameter" in str(unknown.value)
    assert all(f"{name}.{p}" in str(unknown.value) for p in spec.parameters)


def test_wrong_types_are_rejected(registry: ExtractorRegistry) -> None:
    with pytest.raises(ParameterError, match=r"ORB.nfeatures = 1.5 is not an integer; allowed: \[1, 20000\]"):
        registry.create("ORB", {"nfeatures": 1.5})
    with pytest.raises(ParameterError, match="SIFT.enable_precise_upscale"):
        registry.create("SIFT", {"enable_precise_upscale": 3})


def test_parameters_reach_opencv(registry: ExtractorRegistry, euroc_pair: list[np.ndarray]) -> None:
    assert len(registry.extract("ORB", euroc_pair[0], {"nfeatures": 100})) <= 100
    assert registry.extract("ORB", euroc_pair[0], {"WTA_K": 3}).norm_name == "NORM_HAMMING2"
    few = registry.extract("BRISK", euroc_pair[0], {"thresh": 120})
    many = registry.extract("BRISK", euroc_pair[0], {"thresh": 15})
    assert len(few) < len(many)


KAZE_TTL = """
@prefix nfex: <https://w3id.org/nfex#> . @prefix rdfs: <http://www.w3.org/2000/01/rdf-schema#> .
@prefix owl: <http://www.w3.org/2002/07/owl#> . @prefix xsd: <http://www.w3.org/2001/XMLSchema#> .
nfex:KAZE a owl:NamedIndividual, nfex:FeatureExtractor ; rdfs:label "KAZE"@en ;
    rdfs:comment "KAZE (Alcantarilla et al. 2012): nonlinear scale space, float descriptors."@en ;
    nfex:token "KAZE" ; nfex:opencvConstructor "xfeatures2d.KAZE_create" ;
    nfex:descriptorKind nfex:RealDescriptor ; nfex:matchNorm "NORM_L2" ;
    nfex:performs nfex:NonlinearScaleSpace, nfex:HessianDeterminant .
nfex:KAZE_threshold a owl:NamedIndividual, nfex:Parameter ; rdfs:label "KAZE threshold"@en ;
    rdfs:comment "Detector response threshold."@en ; nfex:parameterOf nfex:KAZE ; nfex:opencvName "threshold" ;
    nfex:role nfex:ST ; nfex:datatype xsd:double ; nfex:defaultValue "0.001"^^xsd:double ;
    nfex:minValue "1e-05"^^xsd:double ; nfex:maxValue "0.05"^^xsd:double ; nfex:tunable true .
nfex:KAZE_nOctaves a owl:NamedIndividual, nfex:Parameter ; rdfs:label "KAZE nOctaves"@en ;
    rdfs:comment "Maximum octave evolution."@en ; nfex:parameterOf nfex:KAZE ; nfex:opencvName "nOctaves" ;
    nfex:role nfex:NL ; nfex:datatype xsd:integer ; nfex:defaultValue "4"^^xsd:integer ;
    nfex:minValue "1"^^xsd:integer ; nfex:maxValue "8"^^xsd:integer ; nfex:tunable true .
nfex:KAZE_extended a owl:NamedIndividual, nfex:Parameter ; rdfs:label "KAZE extended"@en ;
    rdfs:comment "128-element instead of 64-element descriptors."@en ; nfex:parameterOf nfex:KAZE ;
    nfex:opencvName "extended" ; nfex:role nfex:OtherRole ; nfex:datatype xsd:boolean ;
    nfex:defaultValue false ; nfex:tunable false .
"""


def test_adding_an_extractor_is_data(kg: KnowledgeGraph, euroc_pair: list[np.ndarray]) -> None:
    """KAZE, which no Python names, becomes extractable from one checked transaction of Turtle."""
    assert "KAZE" not in ExtractorRegistry.from_vocabulary(kg.vocabulary()).names
    kg.add(rdflib.Graph().parse(data=KAZE_TTL, format="turtle"), author="test", message="add KAZE")
    registry = ExtractorRegistry.from_vocabulary(kg.vocabulary())
    assert "KAZE" in registry.names
    image = cv2.resize(euroc_pair[0], (376, 240), interpolation=cv2.INTER_AREA)  # KAZE is slow at full size
    feats = registry.extract("KAZE", image)
    assert len(feats) > 20
    check_contract(feats, image, "real")
    assert feats.descriptors.shape[1] == 64 and feats.norm_name == "NORM_L2"
    assert registry.extract("KAZE", image, {"extended": True}).descriptors.shape[1] == 128
    assert len(registry.extract("KAZE", image, {"threshold": 0.01})) < len(feats)
    with pytest.raises(ParameterError, match=r"KAZE.nOctaves = 9 is outside its range \[1, 8\]"):
        registry.extract("KAZE", image, {"nOctaves": 9})
    assert len(registry.extract("KAZE", np.zeros((64, 64), np.uint8))) == 0


@pytest.mark.parametrize("name", OPENCV_EXTRACTORS)
def test_the_opencv_recipe_a_selection_carries_builds_the_registrys_detector(
    registry: ExtractorRegistry, vocab: Vocabulary, name: str
) -> None:
    """ExtractorSpec.opencv (a Selection's ``opencv``) gives a client everything to build α with Θ′ itself:
    the constructor's arguments (grid settings out, NF oversampled) and the grid spread to apply."""
    spec = vocab.extractor(name)
    recipe = spec.opencv({})
    assert recipe["args"] == registry.constructor_args(name) and recipe["norm"] == registry.norm(name)[1]
    target = cv2
    for part in recipe["constructor"].split("."):
        target = getattr(target, part)
    assert type(target(**recipe["args"])) is type(registry.create(name))
    if name == "ORB_GRID":
        assert recipe["grid"] == {"cell_size": 48, "keep": 500} and recipe["args"]["nfeatures"] == 1500
        assert "gridCellSize" not in recipe["args"] and "gridOversample" not in recipe["args"]
    else:
        assert recipe["grid"] is None and recipe["args"] == spec.defaults()


LEARNED_TTL = """
@prefix nfex: <https://w3id.org/nfex#> . @prefix rdfs: <http://www.w3.org/2000/01/rdf-schema#> .
@prefix owl: <http://www.w3.org/2002/07/owl#> . @prefix xsd: <http://www.w3.org/2001/XMLSchema#> .
nfex:SuperPointBackend a owl:NamedIndividual, nfex:ExtractorBackend, nfex:LearnedModelBackend ;
    rdfs:label "SuperPoint"@en ; nfex:token "superpoint" .
nfex:SUPERPOINT a owl:NamedIndividual, nfex:FeatureExtractor ; rdfs:label "SuperPoint"@en ;
    nfex:token "SUPERPOINT" ; nfex:backend nfex:SuperPointBackend ; nfex:descriptorSize 256 ;
    nfex:descriptorKind nfex:RealDescriptor ; nfex:matchNorm "NORM_L2" ; nfex:matcher nfex:MutualRatioMatcher ;
    nfex:performs nfex:LearnedKeypointHeatmap, nfex:LearnedDenseDescriptor .
"""


def test_a_backend_kind_without_code_is_pruned_and_named(kg: KnowledgeGraph) -> None:
    """A learned model the graph describes but no backend module implements: the registry's error and
    the rule that prunes it both list the backend kinds that exist."""
    from nfex_core.rules.engine import BACKEND_RULE, RuleEngine

    kg.add(rdflib.Graph().parse(data=LEARNED_TTL, format="turtle"), author="test", message="add SuperPoint")
    registry = ExtractorRegistry.from_vocabulary(kg.vocabulary())
    with pytest.raises(UnknownName, match="unknown extractor backend 'superpoint'; known: opencv, xfeat"):
        registry.extract("SUPERPOINT", np.zeros((64, 64), np.uint8))
    decision = RuleEngine(kg).table().decide({})
    assert "SUPERPOINT" not in decision.candidates
    [cite] = decision.pruned["SUPERPOINT"]
    assert cite.rule == BACKEND_RULE and "known: opencv, xfeat" in cite.reason


@pytest.mark.parametrize(
    ("change", "says"),
    [
        (LEARNED_TTL.replace("nfex:descriptorSize 256 ;", ""), "declares its nfex:descriptorSize"),
        (LEARNED_TTL.replace("nfex:descriptorSize 256 ;", 'nfex:descriptorSize 256 ; nfex:opencvConstructor "ORB_create" ;'),
         "names no OpenCV constructor"),
        (KAZE_TTL.replace('nfex:opencvConstructor "xfeatures2d.KAZE_create" ;', ""), "names no nfex:opencvConstructor"),
        (LEARNED_TTL.replace("nfex:matcher nfex:MutualRatioMatcher", "nfex:matcher nfex:SuperGlue") +
         'nfex:SuperGlue a nfex:Matcher ; nfex:token "superglue" .', "ratio, mutual-ratio"),
    ],
)
def test_shapes_check_backends_and_matchers(kg: KnowledgeGraph, change: str, says: str) -> None:
    from nfex_core.errors import ValidationFailed

    before = kg.version
    with pytest.raises(ValidationFailed, match=says):
        kg.add(rdflib.Graph().parse(data=change, format="turtle"), author="test", message="bad extractor")
    assert kg.version == before
