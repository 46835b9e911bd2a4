"""Condition dimensions and their values. Adding a value extends the API at once: the vocabulary,
the rule table and the 422 "allowed values" are all read from the graph."""
from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Response
from rdflib.namespace import RDF, RDFS
from rdflib.term import Literal

from nfex_core.kg import ChangeSet
from nfex_core.kg.identity import condition_value_iri
from nfex_core.kg.namespaces import NFEX

from ..deps import EditorDep, IfMatchDep, KGDep
from ..editing import check_name, describe
from ..schemas import PROBLEM_RESPONSES, Conditions, ConditionValueIn, WriteResult, problems

router = APIRouter(prefix="/v1/conditions", tags=["editing: conditions"], responses=PROBLEM_RESPONSES)


@router.get("", summary="Condition dimensions and their values", response_model=Conditions)
def list_conditions(kg: KGDep) -> dict[str, Any]:
    v = kg.vocabulary()
    return {
        "graph_version": v.version,
        "dimensions": {
            d.name: {"iri": str(d.iri), "estimable": d.estimable,
                     "values": {x.name: {"iri": str(x.iri), "label": x.label} for x in d.values.values()}}
            for d in v.dimensions.values()
        },
    }


@router.post("/{dimension}/values", status_code=201, summary="Add a condition value to a dimension", response_model=WriteResult,
             responses={200: {"model": WriteResult, "description": "The value was already there"}, **problems(409, 412)})
def add_value(dimension: str, body: ConditionValueIn, kg: KGDep, token: EditorDep, expected: IfMatchDep) -> Response:
    dim = kg.vocabulary().dimension(dimension)
    check_name("condition value", body.name)  # IRI-safe; the graph's shapes decide what a token may be
    iri = condition_value_iri(dim.name, body.name)
    added = {(iri, RDF.type, NFEX.ConditionValue), (iri, NFEX.inDimension, dim.iri), (iri, NFEX.token, Literal(body.name)),
             (iri, RDFS.label, Literal(body.label or body.name, lang="en"))}
    if body.comment:
        added.add((iri, RDFS.comment, Literal(body.comment, lang="en")))
    result = kg.commit(ChangeSet.adding(added), author=token.name, message=f"add {dim.name} = {body.name}", expected_version=expected)
    return WriteResult.of(result, iri=str(iri)).response(status=201 if result.changed else 200)


@router.delete("/{dimension}/values/{value}", summary="Remove a condition value (refused while measurements use it)",
               response_model=WriteResult, responses=problems(409, 412))
def delete_value(dimension: str, value: str, kg: KGDep, token: EditorDep, expected: IfMatchDep) -> Response:
    spec = kg.vocabulary().condition_value(dimension, value)
    change = ChangeSet.removing(describe(kg, {spec.iri}))
    result = kg.commit(change, author=token.name, message=f"remove {dimension} = {value}", expected_version=expected)
    return WriteResult.of(result, iri=str(spec.iri)).response()
