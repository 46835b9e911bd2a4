"""Extractors and their parameters as REST resources. Reads are open; writes need an editor token.

``PUT /v1/extractors/{name}`` takes Turtle (or N-Triples, JSON-LD, RDF/XML) describing the extractor
``nfex:{name}`` and its parameters, and replaces their description as one SHACL-checked transaction.
``PATCH …/parameters/{param}`` changes a parameter's default, range, tunability or label (JSON).
"""
from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Request, Response
from fastapi.concurrency import run_in_threadpool
from rdflib.namespace import RDFS
from rdflib.term import Literal

from nfex_core.errors import BadInput
from nfex_core.kg import ChangeSet, graph_triples
from nfex_core.kg.namespaces import NFEX
from nfex_core.kg.terms import is_skolem

from ..deps import EditorDep, IfMatchDep, KGDep
from ..editing import check_name, describe, rdf_body, replace, subjects_of, turtle
from ..schemas import (
    PROBLEM_RESPONSES,
    Extractor,
    ExtractorList,
    Parameter,
    ParameterPatch,
    WriteResult,
    problems,
)

router = APIRouter(prefix="/v1/extractors", tags=["editing: extractors"], responses=PROBLEM_RESPONSES)
EXTRACTOR_TTL = """@prefix nfex: <https://w3id.org/nfex#> .
nfex:ORB2 a nfex:FeatureExtractor ; nfex:token "ORB2" ; nfex:opencvConstructor "ORB_create" ;
    nfex:matchNorm "NORM_HAMMING" ; nfex:descriptorKind nfex:BinaryDescriptor ; nfex:performs nfex:SteeredBRIEF ."""


def _spec_dict(x: Any) -> dict[str, Any]:
    return {
        "name": x.name,
        "iri": str(x.iri),
        "label": x.label,
        "constructor": x.constructor,
        "norm": x.norm,
        "descriptor_kind": x.descriptor_kind,
        "operations": list(x.operations),
        "parameters": {p.name: _param_dict(p) for p in x.parameters.values()},
    }


def _param_dict(p: Any) -> dict[str, Any]:
    return {"iri": str(p.iri), "role": p.role, "datatype": p.datatype, "default": p.default, "min": p.min,
            "max": p.max, "allowed": list(p.allowed) if p.allowed is not None else None, "tunable": p.tunable,
            "label": p.label}


@router.get("", summary="Every extractor the graph knows", response_model=ExtractorList)
def list_extractors(kg: KGDep) -> dict[str, Any]:
    v = kg.vocabulary()
    return {"graph_version": v.version, "extractors": [_spec_dict(x) for x in v.extractors.values()]}


@router.get("/{name}", summary="One extractor (JSON, or its RDF description with Accept: text/turtle)", response_model=Extractor,
            responses={200: {"content": {"text/turtle": {"schema": {"type": "string"}}}}})
def get_extractor(name: str, kg: KGDep, request: Request) -> Any:
    spec = kg.vocabulary().extractor(name)
    if "text/turtle" in request.headers.get("accept", ""):
        roots = {spec.iri} | {p.iri for p in spec.parameters.values()}
        return Response(turtle(describe(kg, roots)), media_type="text/turtle")
    return _spec_dict(spec)


@router.put(
    "/{name}",
    summary="Create or replace an extractor (and its parameters) from RDF",
    response_model=WriteResult,
    responses={**{201: {"model": WriteResult, "description": "Created"}}, **problems(409, 412, 415)},
    openapi_extra={"requestBody": {"required": True, "content": {"text/turtle": {"schema": {"type": "string"}, "example": EXTRACTOR_TTL}}}},
)
async def put_extractor(name: str, request: Request, kg: KGDep, token: EditorDep, expected: IfMatchDep) -> Response:
    check_name("extractor", name)
    body = await rdf_body(request)
    new = graph_triples(body)
    vocab = kg.vocabulary()
    iri = vocab.extractors[name].iri if name in vocab.extractors else NFEX[name]
    params = {s for s, p, o in new if p == NFEX.parameterOf and o == iri}
    stray = {s for s, _, _ in new if s != iri and s not in params and not is_skolem(s)}
    if not any(s == iri for s, _, _ in new):
        raise BadInput(f"the body does not describe {iri}")
    if stray:
        raise BadInput(f"the body may only describe {iri} and its parameters; it also describes {sorted(map(str, stray))[:5]}")
    existing_params = subjects_of(kg, NFEX.parameterOf, iri)
    old = await run_in_threadpool(describe, kg, {iri} | existing_params)
    change = replace(kg, old, new)
    result = await run_in_threadpool(kg.commit, change, author=token.name, message=f"PUT extractor {name}", expected_version=expected)
    return WriteResult.of(result, iri=str(iri)).response(status=201 if name not in vocab.extractors else 200)


@router.delete("/{name}", summary="Remove an extractor and its parameters (refused while configurations use it)",
               response_model=WriteResult, responses=problems(409, 412))
def delete_extractor(name: str, kg: KGDep, token: EditorDep, expected: IfMatchDep) -> Response:
    spec = kg.vocabulary().extractor(name)
    roots = {spec.iri} | subjects_of(kg, NFEX.parameterOf, spec.iri)
    change = ChangeSet.removing(describe(kg, roots))
    result = kg.commit(change, author=token.name, message=f"DELETE extractor {name}", expected_version=expected)
    return WriteResult.of(result, iri=str(spec.iri)).response()


@router.get("/{name}/parameters/{param}", summary="One parameter", response_model=Parameter)
def get_parameter(name: str, param: str, kg: KGDep) -> dict[str, Any]:
    return _param_dict(kg.vocabulary().extractor(name).parameter(param))


@router.patch("/{name}/parameters/{param}", summary="Change a parameter's default, range, tunability or label",
              response_model=WriteResult, responses=problems(409, 412))
def patch_parameter(name: str, param: str, body: ParameterPatch, kg: KGDep, token: EditorDep, expected: IfMatchDep) -> Response:
    spec = kg.vocabulary().extractor(name).parameter(param)
    fields = body.model_dump(exclude_unset=True)
    if not fields:
        raise BadInput("nothing to change: give default, min, max, tunable, label or comment")
    preds = {"default": NFEX.defaultValue, "min": NFEX.minValue, "max": NFEX.maxValue, "tunable": NFEX.tunable,
             "label": RDFS.label, "comment": RDFS.comment}
    old = describe(kg, {spec.iri})
    removed = {t for t in old if t[1] in {preds[f] for f in fields}}
    added = set()
    for f, value in fields.items():
        if value is None:
            continue
        if f in ("default", "min", "max"):
            lit = spec.literal(spec.coerce(value))
        elif f == "tunable":
            lit = Literal(bool(value))
        else:
            lit = Literal(str(value))
        added.add((spec.iri, preds[f], lit))
    change = ChangeSet.of(added=added, removed=removed)
    result = kg.commit(change, author=token.name, message=f"PATCH parameter {spec.qualified}", expected_version=expected)
    return WriteResult.of(result, iri=str(spec.iri)).response()

