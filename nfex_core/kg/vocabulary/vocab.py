"""A typed view of the graph's vocabulary: extractors, parameters, condition dimensions, metrics.

Everything that accepts a name from a user — the HTTP API, the CLI, the DSL, the registry — checks it
here, so an unknown name is rejected with the names the graph knows, and adding a value to the
ontology extends every interface without code. Built once per graph version
(``KnowledgeGraph.vocabulary()``).
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

from rdflib.term import URIRef

from ...errors import UnknownName
from ..rdf.terms import py
from ..storage.backends import GraphReader
from .specs import (
    ConditionValueSpec,
    DimensionSpec,
    ExtractorSpec,
    MetricSpec,
    NormRuleSpec,
    ParameterSpec,
    Value,
)

__all__ = ["ConditionValueSpec", "DimensionSpec", "ExtractorSpec", "MetricSpec", "NormRuleSpec", "ParameterSpec", "Value",
           "Vocabulary"]  # the value types live in specs.py; callers import them from here


@dataclass(frozen=True)
class Vocabulary:
    version: int
    extractors: Mapping[str, ExtractorSpec]
    dimensions: Mapping[str, DimensionSpec]
    metrics: Mapping[str, MetricSpec]
    by_iri: Mapping[URIRef, object] = field(default_factory=dict)

    def extractor(self, name: str) -> ExtractorSpec:
        try:
            return self.extractors[name]
        except KeyError:
            raise UnknownName("extractor", name, self.extractors) from None

    def dimension(self, name: str) -> DimensionSpec:
        try:
            return self.dimensions[name]
        except KeyError:
            raise UnknownName("condition dimension", name, self.dimensions) from None

    def metric(self, name: str) -> MetricSpec:
        try:
            return self.metrics[name]
        except KeyError:
            raise UnknownName("metric", name, self.metrics) from None

    def condition_value(self, dimension: str, value: str) -> ConditionValueSpec:
        return self.dimension(dimension).value(value)

    def check_context(self, context: Mapping[str, str | None]) -> dict[str, str]:
        """Validate a client's context (dimension → value); unknown names raise with what is allowed."""
        out: dict[str, str] = {}
        for dim, value in context.items():
            if value is None:
                continue
            spec = self.dimension(dim)
            out[dim] = spec.value(str(value)).name
        return out

    @classmethod
    def load(cls, kg: GraphReader) -> Vocabulary:
        version = kg.version
        params: dict[str, dict[str, ParameterSpec]] = {}
        prow = kg.select(
            """SELECT ?p ?x ?xname ?name ?dt ?role ?default ?min ?max ?tunable ?scales ?grid ?label ?comment ?input WHERE {
                ?p a nfex:Parameter ; nfex:parameterOf ?x ; nfex:opencvName ?name ; nfex:datatype ?dt ;
                   nfex:role/nfex:token ?role ; nfex:defaultValue ?default .
                ?x nfex:token ?xname .
                OPTIONAL { ?p nfex:minValue ?min } OPTIONAL { ?p nfex:maxValue ?max }
                OPTIONAL { ?p nfex:tunable ?tunable } OPTIONAL { ?p nfex:scalesWithResolution ?scales }
                OPTIONAL { ?p nfex:gridRole/nfex:token ?grid } OPTIONAL { ?p nfex:scalesInput ?input }
                OPTIONAL { ?p rdfs:label ?label } OPTIONAL { ?p rdfs:comment ?comment }
            }"""
        ).rows
        allowed: dict[URIRef, list[Value]] = {}
        for r in kg.select("SELECT ?p ?a WHERE { ?p a nfex:Parameter ; nfex:allowedValue ?a }").rows:
            allowed.setdefault(r["p"], []).append(py(r["a"]))  # type: ignore[arg-type]
        for r in prow:
            dt = str(r["dt"]).rsplit("#", 1)[-1]
            spec = ParameterSpec(
                iri=r["p"],  # type: ignore[arg-type]
                extractor=str(r["xname"]),
                name=str(r["name"]),
                datatype=dt,
                role=str(r["role"]),
                default=_typed(r["default"], dt),
                min=_typed(r["min"], dt) if "min" in r else None,
                max=_typed(r["max"], dt) if "max" in r else None,
                allowed=tuple(sorted(_typed_value(a, dt) for a in allowed[r["p"]])) if r["p"] in allowed else None,  # type: ignore[index]
                tunable=bool(py(r["tunable"])) if "tunable" in r else False,
                scales_with_resolution=bool(py(r["scales"])) if "scales" in r else False,
                grid_role=str(r["grid"]) if "grid" in r else None,
                scales_input=bool(py(r["input"])) if "input" in r else False,
                label=str(r.get("label", "")),
                comment=str(r.get("comment", "")),
            )
            params.setdefault(spec.extractor, {})[spec.name] = spec

        norm_rules: dict[str, list[NormRuleSpec]] = {}
        for r in kg.select(
            """SELECT ?xname ?pname ?norm (GROUP_CONCAT(STR(?v); separator=" ") AS ?vals) WHERE {
                ?x nfex:token ?xname ; nfex:matchNormRule ?r .
                ?r nfex:normParameter/nfex:opencvName ?pname ; nfex:matchNorm ?norm ; nfex:whenValue ?v .
            } GROUP BY ?xname ?pname ?norm"""
        ).rows:
            when = tuple(sorted(_parse_number(v) for v in str(r["vals"]).split()))  # GROUP_CONCAT's order is the store's
            norm_rules.setdefault(str(r["xname"]), []).append(NormRuleSpec(str(r["pname"]), when, str(r["norm"])))

        ops: dict[str, list[str]] = {}
        for r in kg.select("SELECT ?xname ?op WHERE { ?x a nfex:FeatureExtractor ; nfex:token ?xname ; nfex:performs ?op }").rows:
            ops.setdefault(str(r["xname"]), []).append(str(r["op"]).rsplit("#", 1)[-1])

        extractors: dict[str, ExtractorSpec] = {}
        for r in kg.select(
            """SELECT ?x ?name ?ctor ?norm ?kind ?label ?comment ?backend ?matcher ?dsize WHERE {
                ?x a nfex:FeatureExtractor ; nfex:token ?name ; nfex:matchNorm ?norm .
                OPTIONAL { ?x nfex:opencvConstructor ?ctor }
                OPTIONAL { ?x nfex:descriptorKind ?kind } OPTIONAL { ?x rdfs:label ?label } OPTIONAL { ?x rdfs:comment ?comment }
                OPTIONAL { ?x nfex:backend/nfex:token ?backend } OPTIONAL { ?x nfex:matcher/nfex:token ?matcher }
                OPTIONAL { ?x nfex:descriptorSize ?dsize }
            } ORDER BY ?name"""
        ).rows:
            name = str(r["name"])
            kind = "real" if str(r.get("kind", "")).endswith("RealDescriptor") else "binary"
            extractors[name] = ExtractorSpec(
                iri=r["x"],  # type: ignore[arg-type]
                name=name,
                label=str(r.get("label", name)),
                constructor=str(r.get("ctor", "")),
                norm=str(r["norm"]),
                descriptor_kind=kind,
                parameters=dict(sorted(params.get(name, {}).items())),
                norm_rules=tuple(norm_rules.get(name, [])),
                operations=tuple(sorted(ops.get(name, []))),
                comment=str(r.get("comment", "")),
                backend=str(r.get("backend", "opencv")),
                matcher=str(r.get("matcher", "ratio")),
                descriptor_size=int(py(r["dsize"])) if "dsize" in r else None,
            )

        values: dict[str, dict[str, ConditionValueSpec]] = {}
        for r in kg.select(
            """SELECT ?v ?dname ?name ?label ?ord WHERE {
                ?v a nfex:ConditionValue ; nfex:inDimension/nfex:token ?dname ; nfex:token ?name .
                OPTIONAL { ?v rdfs:label ?label } OPTIONAL { ?v nfex:ordinal ?ord }
            } ORDER BY ?dname ?ord ?name"""
        ).rows:
            value = ConditionValueSpec(
                iri=r["v"],  # type: ignore[arg-type]
                dimension=str(r["dname"]),
                name=str(r["name"]),
                label=str(r.get("label", "")),
                ordinal=int(py(r["ord"])) if "ord" in r else None,
            )
            values.setdefault(value.dimension, {})[value.name] = value
        dimensions: dict[str, DimensionSpec] = {}
        for r in kg.select(
            """SELECT ?d ?name ?label ?est WHERE {
                ?d a nfex:ConditionDimension ; nfex:token ?name .
                OPTIONAL { ?d rdfs:label ?label } OPTIONAL { ?d nfex:estimable ?est }
            }"""
        ).rows:
            name = str(r["name"])
            dimensions[name] = DimensionSpec(
                iri=r["d"],  # type: ignore[arg-type]
                name=name,
                label=str(r.get("label", name)),
                estimable=bool(py(r["est"])) if "est" in r else False,
                values=values.get(name, {}),
            )
        order = ["agent", "motion", "scene", "light", "reflectance", "texture"]
        dimensions = dict(sorted(dimensions.items(), key=lambda kv: (order.index(kv[0]) if kv[0] in order else 99, kv[0])))

        metrics: dict[str, MetricSpec] = {}
        for r in kg.select(
            """SELECT ?m ?name ?symbol ?label ?temporal ?hib ?formula WHERE {
                ?m a nfex:QualityMetric ; nfex:token ?name ; nfex:symbol ?symbol ; nfex:temporal ?temporal .
                OPTIONAL { ?m rdfs:label ?label } OPTIONAL { ?m nfex:higherIsBetter ?hib } OPTIONAL { ?m nfex:formula ?formula }
            } ORDER BY ?symbol"""
        ).rows:
            name = str(r["name"])
            metrics[name] = MetricSpec(
                iri=r["m"],  # type: ignore[arg-type]
                name=name,
                symbol=str(r["symbol"]),
                label=str(r.get("label", name)),
                temporal=bool(py(r["temporal"])),
                higher_is_better=bool(py(r["hib"])) if "hib" in r else True,
                formula=str(r.get("formula", "")),
            )
        by_iri: dict[URIRef, object] = {}
        for x in extractors.values():
            by_iri[x.iri] = x
            for p in x.parameters.values():
                by_iri[p.iri] = p
        for d in dimensions.values():
            by_iri[d.iri] = d
            for v in d.values.values():
                by_iri[v.iri] = v
        for m in metrics.values():
            by_iri[m.iri] = m
        return cls(version=version, extractors=extractors, dimensions=dimensions, metrics=metrics, by_iri=by_iri)



def _parse_number(text: str) -> Value:
    try:
        return int(text)
    except ValueError:
        return float(text)


def _typed_value(v: Value, dt: str) -> Value:
    if dt == "integer":
        return int(v)
    if dt == "double":
        return float(v)
    return bool(v)


def _typed(term: object, dt: str) -> Value:
    return _typed_value(py(term), dt)
