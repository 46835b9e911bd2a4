"""SPARQL pruning rules as REST resources (``nfex:SparqlRule``; rules/pruning/*.rq are seeded as these).

A rule is checked before it is stored: it must parse and select ``?extractor`` and ``?reason``
(nfex_core.rules.pruning.check_rule); the graph's shapes then check it like any write.
"""
from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Response
from fastapi.concurrency import run_in_threadpool
from rdflib.namespace import RDF, RDFS
from rdflib.term import Literal, URIRef

from nfex_core.errors import NotFound
from nfex_core.kg import ChangeSet, identity
from nfex_core.kg.namespaces import NFEX
from nfex_core.kg.sparql_query import with_prefixes
from nfex_core.rules.pruning import check_rule

from ..deps import EditorDep, IfMatchDep, KGDep
from ..editing import check_name, describe, replace
from ..schemas import PROBLEM_RESPONSES, Rule, RuleIn, RuleList, WriteResult, problems

router = APIRouter(prefix="/v1/rules", tags=["editing: rules"], responses=PROBLEM_RESPONSES)


def rule_iri(rule_id: str) -> URIRef:
    check_name("rule", rule_id)
    return identity.rule_iri(rule_id)


def _rules(kg: Any, iri: URIRef | None = None) -> list[dict[str, Any]]:
    where = f"VALUES ?r {{ <{iri}> }}" if iri is not None else ""
    rows = kg.select(
        f"""SELECT ?r ?label ?comment ?query ?enabled ?source WHERE {{ {where}
            ?r a nfex:SparqlRule ; rdfs:label ?label ; nfex:query ?query .
            OPTIONAL {{ ?r rdfs:comment ?comment }} OPTIONAL {{ ?r nfex:enabled ?enabled }} OPTIONAL {{ ?r nfex:sourceFile ?source }}
        }} ORDER BY ?r"""
    ).rows
    out = []
    for r in rows:
        local = str(r["r"]).rsplit("#", 1)[-1]
        out.append({
            "id": local.removeprefix("rule_"),
            "iri": str(r["r"]),
            "label": str(r["label"]),
            "comment": str(r["comment"]) if "comment" in r else None,
            "enabled": bool(r["enabled"].toPython()) if "enabled" in r else True,
            "source": str(r["source"]) if "source" in r else None,
            "query": str(r["query"]),
        })
    return out


@router.get("", summary="Every SPARQL pruning rule", response_model=RuleList)
def list_rules(kg: KGDep) -> dict[str, Any]:
    return {"graph_version": kg.version, "rules": _rules(kg)}


@router.get("/{rule_id}", summary="One rule", response_model=Rule)
def get_rule(rule_id: str, kg: KGDep) -> dict[str, Any]:
    found = _rules(kg, rule_iri(rule_id))
    if not found:
        raise NotFound(f"no rule {rule_id!r}; GET /v1/rules lists them")
    return found[0]


@router.put("/{rule_id}", summary="Create or replace a rule (checked: parses, selects ?extractor ?reason)", response_model=WriteResult,
            responses={**{201: {"model": WriteResult, "description": "Created"}}, **problems(409, 412)})
async def put_rule(rule_id: str, body: RuleIn, kg: KGDep, token: EditorDep, expected: IfMatchDep) -> Response:
    iri = rule_iri(rule_id)
    query = with_prefixes(body.query)  # stored self-contained: the engine runs it as is
    # checked on the event loop's thread: a refusal's traceback holds pyoxigraph results, which must be
    # dropped on the thread that made them (a parse of an empty store: microseconds)
    check_rule(query, list(kg.vocabulary().dimensions))
    return await run_in_threadpool(_put_rule, kg, iri, rule_id, body, query, token.name, expected)


def _put_rule(kg: Any, iri: URIRef, rule_id: str, body: RuleIn, query: str, author: str, expected: int | None) -> Response:
    new = {(iri, RDF.type, NFEX.SparqlRule), (iri, RDFS.label, Literal(body.label)), (iri, NFEX.query, Literal(query)),
           (iri, NFEX.enabled, Literal(body.enabled))}
    if body.comment:
        new.add((iri, RDFS.comment, Literal(body.comment)))
    old = describe(kg, {iri})
    keep = {t for t in old if t[1] == NFEX.sourceFile}
    result = kg.commit(replace(kg, old, new | keep), author=author, message=f"PUT rule {rule_id}", expected_version=expected)
    return WriteResult.of(result, iri=str(iri)).response(status=201 if not old else 200)


@router.delete("/{rule_id}", summary="Remove a rule", response_model=WriteResult, responses=problems(409, 412))
def delete_rule(rule_id: str, kg: KGDep, token: EditorDep, expected: IfMatchDep) -> Response:
    iri = rule_iri(rule_id)
    old = describe(kg, {iri})
    if not old:
        raise NotFound(f"no rule {rule_id!r}")
    result = kg.commit(ChangeSet.removing(old), author=token.name, message=f"DELETE rule {rule_id}", expected_version=expected)
    return WriteResult.of(result, iri=str(iri)).response()
