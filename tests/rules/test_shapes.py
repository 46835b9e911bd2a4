"""Every SHACL shape in rules/shapes rejects a bad write and names the offending node and the shape.

Each case goes through a real transaction on a seeded store: the write must raise ValidationFailed,
name the node, and leave the graph exactly as it was (same version, same triples).
"""
from __future__ import annotations

import pytest

from nfex_core.errors import ValidationFailed
from nfex_core.kg import KnowledgeGraph, parse_rdf
from nfex_core.kg.storage.sparql_query import with_prefixes

PREFIXES = """
@prefix nfex: <https://w3id.org/nfex#> .
@prefix xsd:  <http://www.w3.org/2001/XMLSchema#> .
@prefix rdfs: <http://www.w3.org/2000/01/rdf-schema#> .
@prefix sosa: <http://www.w3.org/ns/sosa/> .
"""
N = "https://w3id.org/nfex#"

VALID_MEASUREMENT = """
nfex:seq a nfex:Sequence ; rdfs:label "seq" .
nfex:cfg a nfex:Configuration ; nfex:ofExtractor nfex:ORB .
"""

CASES = {
    # shape: (turtle, offending node, shape)
    "backend without a token": ("nfex:FOOB a nfex:ExtractorBackend .", "FOOB", "ExtractorBackendShape"),
    "matcher nFEX does not implement": ('nfex:FOOM a nfex:Matcher ; nfex:token "magic" .', "FOOM", "MatcherShape"),
    "extractor without constructor": (
        'nfex:FOO a nfex:FeatureExtractor ; nfex:token "FOO" ; nfex:matchNorm "NORM_HAMMING" ; '
        "nfex:descriptorKind nfex:BinaryDescriptor ; nfex:performs nfex:FASTHarris .",
        "FOO",
        "FeatureExtractorShape",
    ),
    "extractor with unknown norm": (
        'nfex:FOO a nfex:FeatureExtractor ; nfex:token "FOO" ; nfex:opencvConstructor "FOO_create" ; nfex:matchNorm "NORM_FANCY" ; '
        "nfex:descriptorKind nfex:BinaryDescriptor ; nfex:performs nfex:FASTHarris .",
        "FOO",
        "FeatureExtractorShape",
    ),
    "parameter default outside its range": (
        'nfex:ORB_extra a nfex:Parameter ; nfex:parameterOf nfex:ORB ; nfex:opencvName "extra" ; nfex:role nfex:OtherRole ; '
        'nfex:datatype xsd:integer ; nfex:defaultValue 5 ; nfex:minValue 0 ; nfex:maxValue 3 .',
        "ORB_extra",
        "ParameterShape",
    ),
    "parameter default of the wrong datatype": (
        'nfex:ORB_extra a nfex:Parameter ; nfex:parameterOf nfex:ORB ; nfex:opencvName "extra" ; nfex:role nfex:OtherRole ; '
        'nfex:datatype xsd:integer ; nfex:defaultValue "1.5"^^xsd:double .',
        "ORB_extra",
        "ParameterShape",
    ),
    "metric range whose least value exceeds its most": (
        "nfex:r1 a nfex:MetricRange ; nfex:rangeExtractor nfex:ORB ; nfex:rangeMetric nfex:texturedness ; "
        'nfex:rangeLow "0.6"^^xsd:double ; nfex:rangeHigh "0.4"^^xsd:double .',
        "r1",
        "MetricRangeShape",
    ),
    "metric range of no metric": (
        "nfex:r1 a nfex:MetricRange ; nfex:rangeExtractor nfex:ORB ; nfex:rangeMetric nfex:ORB ; "
        'nfex:rangeLow "0.1"^^xsd:double ; nfex:rangeHigh "0.4"^^xsd:double .',
        "r1",
        "MetricRangeShape",
    ),
    "parameter minimum above maximum": (
        'nfex:ORB_extra a nfex:Parameter ; nfex:parameterOf nfex:ORB ; nfex:opencvName "extra" ; nfex:role nfex:OtherRole ; '
        "nfex:datatype xsd:integer ; nfex:defaultValue 5 ; nfex:minValue 9 ; nfex:maxValue 3 .",
        "ORB_extra",
        "ParameterShape",
    ),
    "parameter default not among allowed values": (
        'nfex:ORB_extra a nfex:Parameter ; nfex:parameterOf nfex:ORB ; nfex:opencvName "extra" ; nfex:role nfex:OtherRole ; '
        "nfex:datatype xsd:integer ; nfex:defaultValue 5 ; nfex:allowedValue 1, 2 .",
        "ORB_extra",
        "ParameterShape",
    ),
    "two parameters of one extractor with one name": (
        'nfex:ORB_dup a nfex:Parameter ; nfex:parameterOf nfex:ORB ; nfex:opencvName "nfeatures" ; nfex:role nfex:NF ; '
        "nfex:datatype xsd:integer ; nfex:defaultValue 5 .",
        "ORB_dup",
        "ParameterShape",
    ),
    "parameter of two extractors": (
        'nfex:P2 a nfex:Parameter ; nfex:parameterOf nfex:ORB, nfex:SIFT ; nfex:opencvName "p2" ; nfex:role nfex:NF ; '
        "nfex:datatype xsd:integer ; nfex:defaultValue 5 .",
        "P2",
        "ParameterShape",
    ),
    "condition value in two dimensions": (
        'nfex:light_dim a nfex:ConditionValue ; nfex:inDimension nfex:light, nfex:texture ; nfex:token "dim" .',
        "light_dim",
        "ConditionValueShape",
    ),
    "condition value in no dimension": (
        'nfex:orphan a nfex:ConditionValue ; nfex:token "orphan" .',
        "orphan",
        "ConditionValueShape",
    ),
    "condition value token already taken in its dimension": (
        'nfex:light_dark2 a nfex:ConditionValue ; nfex:inDimension nfex:light ; nfex:token "dark" .',
        "light_dark2",
        "ConditionValueShape",
    ),
    "condition dimension with a malformed token": (
        'nfex:weather a nfex:ConditionDimension ; nfex:token "Weather Now" .',
        "weather",
        "ConditionDimensionShape",
    ),
    "metric without a symbol": (
        'nfex:sharpness a nfex:QualityMetric ; nfex:token "sharpness" ; nfex:temporal false .',
        "sharpness",
        "QualityMetricShape",
    ),
    "ORB configuration with scaleFactor 0.5": (
        "nfex:cfg a nfex:Configuration ; nfex:ofExtractor nfex:ORB ; nfex:hasSetting nfex:cfg_sf . "
        "nfex:cfg_sf a nfex:ParameterSetting ; nfex:parameter nfex:ORB_scaleFactor ; nfex:value 0.5 .",
        "cfg",
        "ConfigurationShape",
    ),
    "configuration of two extractors": (
        "nfex:cfg a nfex:Configuration ; nfex:ofExtractor nfex:ORB, nfex:SIFT .",
        "cfg",
        "ConfigurationShape",
    ),
    "configuration of no extractor": ("nfex:cfg a nfex:Configuration .", "cfg", "ConfigurationShape"),
    "configuration setting another extractor's parameter": (
        "nfex:cfg a nfex:Configuration ; nfex:ofExtractor nfex:ORB ; nfex:hasSetting nfex:cfg_s . "
        "nfex:cfg_s a nfex:ParameterSetting ; nfex:parameter nfex:SIFT_sigma ; nfex:value 1.6 .",
        "cfg",
        "ConfigurationShape",
    ),
    "configuration value of the wrong datatype": (
        "nfex:cfg a nfex:Configuration ; nfex:ofExtractor nfex:ORB ; nfex:hasSetting nfex:cfg_s . "
        'nfex:cfg_s a nfex:ParameterSetting ; nfex:parameter nfex:ORB_nfeatures ; nfex:value "1.5"^^xsd:double .',
        "cfg",
        "ConfigurationShape",
    ),
    "configuration value not allowed": (
        "nfex:cfg a nfex:Configuration ; nfex:ofExtractor nfex:ORB ; nfex:hasSetting nfex:cfg_s . "
        "nfex:cfg_s a nfex:ParameterSetting ; nfex:parameter nfex:ORB_WTA_K ; nfex:value 5 .",
        "cfg",
        "ConfigurationShape",
    ),
    "configuration setting one parameter twice": (
        "nfex:cfg a nfex:Configuration ; nfex:ofExtractor nfex:ORB ; nfex:hasSetting nfex:cfg_a, nfex:cfg_b . "
        "nfex:cfg_a a nfex:ParameterSetting ; nfex:parameter nfex:ORB_nfeatures ; nfex:value 100 . "
        "nfex:cfg_b a nfex:ParameterSetting ; nfex:parameter nfex:ORB_nfeatures ; nfex:value 200 .",
        "cfg",
        "ConfigurationShape",
    ),
    "parameter setting without a value": (
        "nfex:cfg a nfex:Configuration ; nfex:ofExtractor nfex:ORB ; nfex:hasSetting nfex:cfg_s . "
        "nfex:cfg_s a nfex:ParameterSetting ; nfex:parameter nfex:ORB_nfeatures .",
        "cfg_s",
        "ParameterSettingShape",
    ),
    "measurement with negative ATE": (
        VALID_MEASUREMENT + 'nfex:m1 a nfex:Measurement ; sosa:usedProcedure nfex:cfg ; nfex:sequence nfex:seq ; nfex:ateRmse "-0.5"^^xsd:double .',
        "m1",
        "MeasurementShape",
    ),
    "measurement with two configurations": (
        VALID_MEASUREMENT + "nfex:cfg2 a nfex:Configuration ; nfex:ofExtractor nfex:SIFT . "
        "nfex:m1 a nfex:Measurement ; sosa:usedProcedure nfex:cfg, nfex:cfg2 ; nfex:sequence nfex:seq .",
        "m1",
        "MeasurementShape",
    ),
    "measurement without a sequence": (
        VALID_MEASUREMENT + "nfex:m1 a nfex:Measurement ; sosa:usedProcedure nfex:cfg .",
        "m1",
        "MeasurementShape",
    ),
    "measurement under two values of one dimension": (
        VALID_MEASUREMENT + "nfex:m1 a nfex:Measurement ; sosa:usedProcedure nfex:cfg ; nfex:sequence nfex:seq ; "
        "nfex:underCondition nfex:light_dark, nfex:light_bright .",
        "m1",
        "MeasurementShape",
    ),
    "measurement window that ends before it starts": (
        VALID_MEASUREMENT + "nfex:m1 a nfex:Measurement ; sosa:usedProcedure nfex:cfg ; nfex:sequence nfex:seq ; "
        "nfex:windowStart 10 ; nfex:windowEnd 5 .",
        "m1",
        "MeasurementShape",
    ),
    "metric result without a metric": (
        VALID_MEASUREMENT + "nfex:m1 a nfex:Measurement ; sosa:usedProcedure nfex:cfg ; nfex:sequence nfex:seq ; nfex:hasMetricResult nfex:r1 . "
        'nfex:r1 a nfex:MetricResult ; nfex:value "0.5"^^xsd:double .',
        "r1",
        "MetricResultShape",
    ),
    "SPARQL rule without a label": (
        'nfex:rule1 a nfex:SparqlRule ; nfex:query "SELECT ?extractor ?reason WHERE {}" .',
        "rule1",
        "SparqlRuleShape",
    ),
    "rule threshold that is not a number": (
        'nfex:t1 a nfex:RuleThreshold ; rdfs:label "t" ; rdfs:comment "c" ; nfex:value "high" .',
        "t1",
        "RuleThresholdShape",
    ),
}


# DSL programs and statements (rules/shapes/dsl.ttl)
_STMT = 'rdfs:label "s" ; nfex:inProgram nfex:program_default ; '
CASES.update(
    {
        "program without a name": ("nfex:program_x a nfex:Program .", "program_x", "ProgramShape"),
        "statement in no program": ('nfex:s1 a nfex:PruneStatement ; rdfs:label "prune ORB" ; nfex:prunes nfex:ORB .', "s1", "StatementShape"),
        "prune statement naming no extractor": ("nfex:s1 a nfex:PruneStatement ; " + _STMT + "nfex:prunes nfex:light_dark .", "s1", "PruneStatementShape"),
        "adjust statement with factor 0": (
            "nfex:s1 a nfex:AdjustStatement ; " + _STMT + 'nfex:parameter nfex:ORB_nfeatures ; nfex:factor "0.0"^^xsd:double .',
            "s1",
            "AdjustStatementShape",
        ),
        "weight statement with a negative weight": (
            "nfex:s1 a nfex:WeightStatement ; " + _STMT + 'nfex:metric nfex:texturedness ; nfex:weight "-1.0"^^xsd:double .',
            "s1",
            "WeightStatementShape",
        ),
        "prefer statement without a bonus": ("nfex:s1 a nfex:PreferStatement ; " + _STMT + "nfex:prefers nfex:ORB .", "s1", "PreferStatementShape"),
        "require statement with an unknown comparator": (
            "nfex:s1 a nfex:RequireStatement ; " + _STMT + 'nfex:parameter nfex:ORB_nfeatures ; nfex:comparator "!=" ; nfex:bound 5 .',
            "s1",
            "RequireStatementShape",
        ),
        "accept statement without a pair test": ("nfex:s1 a nfex:AcceptStatement ; " + _STMT + ".", "s1", "AcceptStatementShape"),
        "pair test reading an unknown signal": (
            "nfex:s1 a nfex:AcceptStatement ; " + _STMT + "nfex:hasTest nfex:s1_test_1 . "
            'nfex:s1_test_1 a nfex:PairTest ; nfex:signal "luck" ; nfex:testComparator "<=" ; nfex:threshold "1.0"^^xsd:double .',
            "s1_test_1",
            "PairTestShape",
        ),
        "escalate statement allowing 9 more tries": (
            "nfex:s1 a nfex:EscalateStatement ; " + _STMT + "nfex:maxEscalations 9 .", "s1", "EscalateStatementShape",
        ),
        "condition atom with a value of another dimension": (
            "nfex:s1 a nfex:PruneStatement ; " + _STMT + "nfex:prunes nfex:ORB ; nfex:hasCondition nfex:s1_when_1 . "
            "nfex:s1_when_1 a nfex:ConditionAtom ; nfex:dimension nfex:light ; nfex:oneOf nfex:agent_car .",
            "s1_when_1",
            "ConditionAtomShape",
        ),
    }
)


def test_the_seeded_graph_conforms(kg: KnowledgeGraph) -> None:
    report = kg.validate()
    assert report.conforms, report.text


def test_every_shape_has_a_bad_example(kg: KnowledgeGraph) -> None:
    shapes = {str(s).rsplit("#", 1)[-1] for s in kg.shapes().graph.subjects() if str(s).startswith(N) and str(s).endswith("Shape")}
    covered = {shape for _, _, shape in CASES.values()} | {"CoreShape"}  # a removal: test_core_* below
    assert shapes == covered


@pytest.mark.parametrize("update,node", [
    ("DELETE WHERE { ?x a nfex:FeatureExtractor }", "FeatureExtractor"),
    ("DELETE WHERE { ?s ?p ?o }", "FeatureExtractor"),  # the shapes go too: the head's core shape still judges
    ("DELETE WHERE { ?x a nfex:QualityMetric ; ?p ?o }", "QualityMetric"),
    ("DELETE WHERE { nfex:CoreShape ?p ?o }", "CoreShape"),
    ("DELETE WHERE { nfex:CoreShape sh:targetNode nfex:FeatureExtractor . ?x a nfex:FeatureExtractor }", "FeatureExtractor"),
])
def test_core_shape_refuses_a_change_that_removes_the_ontologys_core(kg: KnowledgeGraph, update: str, node: str) -> None:
    before_version, before = kg.version, kg.triple_count()
    with pytest.raises(ValidationFailed) as e:
        kg.update(with_prefixes(update), author="test")
    assert any(r.source_shape == N + "CoreShape" and r.focus_node.endswith(node) for r in e.value.results), e.value.results
    assert kg.version == before_version and kg.triple_count() == before


def test_core_shape_lets_one_instance_go(kg: KnowledgeGraph) -> None:
    kg.update(with_prefixes("DELETE WHERE { nfex:RuleThresholdShape a sh:NodeShape }"), author="test")
    assert kg.ask("ASK { ?x a sh:NodeShape }") and not kg.ask("ASK { nfex:RuleThresholdShape a sh:NodeShape }")


@pytest.mark.parametrize("case", sorted(CASES))
def test_bad_write_is_rejected_naming_node_and_shape(kg: KnowledgeGraph, case: str) -> None:
    turtle, node, shape = CASES[case]
    before_version, before = kg.version, set(kg.data_graph())
    with pytest.raises(ValidationFailed) as e:
        kg.add(parse_rdf(PREFIXES + turtle), author="test")
    results = e.value.results
    assert any(r.focus_node == N + node and r.source_shape == N + shape for r in results), [r.line() for r in results]
    assert N + node in e.value.detail
    assert kg.version == before_version
    assert set(kg.data_graph()) == before


def test_a_valid_configuration_is_accepted(kg: KnowledgeGraph) -> None:
    g = parse_rdf(
        PREFIXES
        + "nfex:cfg a nfex:Configuration ; nfex:ofExtractor nfex:ORB ; nfex:hasSetting nfex:cfg_sf . "
        "nfex:cfg_sf a nfex:ParameterSetting ; nfex:parameter nfex:ORB_scaleFactor ; nfex:value 1.5 ."
    )
    result = kg.add(g, author="test")
    assert result.changed and result.version == 2


def test_narrowing_a_range_is_checked_against_existing_configurations(kg: KnowledgeGraph) -> None:
    """A change to a parameter re-validates the configurations that use it (walk back two edges)."""
    kg.add(
        parse_rdf(
            PREFIXES
            + "nfex:cfg a nfex:Configuration ; nfex:ofExtractor nfex:ORB ; nfex:hasSetting nfex:cfg_sf . "
            "nfex:cfg_sf a nfex:ParameterSetting ; nfex:parameter nfex:ORB_scaleFactor ; nfex:value 1.5 ."
        ),
        author="test",
    )
    update = """
        DELETE { nfex:ORB_scaleFactor nfex:maxValue ?m } INSERT { nfex:ORB_scaleFactor nfex:maxValue "1.3"^^xsd:double }
        WHERE { nfex:ORB_scaleFactor nfex:maxValue ?m }"""
    with pytest.raises(ValidationFailed) as e:
        kg.update("PREFIX nfex: <https://w3id.org/nfex#> PREFIX xsd: <http://www.w3.org/2001/XMLSchema#>" + update, author="test")
    assert any(r.focus_node == N + "cfg" for r in e.value.results)
