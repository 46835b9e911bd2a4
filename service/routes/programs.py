"""DSL programs (``nfex:Program`` and their statements). Listing and removal read the graph; creating
or replacing one compiles its text with ``nfex_core.rules.dsl``, imported lazily — a build without
the DSL answers 501 for PUT and keeps serving everything else."""
from __future__ import annotations

import importlib
from typing import Any

from fastapi import APIRouter, Request, Response
from fastapi.concurrency import run_in_threadpool
from rdflib.term import URIRef

from nfex_core.errors import BadInput, NotFound
from nfex_core.kg import ChangeSet, KnowledgeGraph

from ..deps import EditorDep, IfMatchDep, KGDep
from ..editing import check_name, describe, replace, triples_of
from ..frames import NotImplementedFeature
from ..images import UnsupportedMediaType
from ..schemas import PROBLEM_RESPONSES, WriteResult

router = APIRouter(prefix="/v1/programs", tags=["editing: programs"], responses=PROBLEM_RESPONSES)
PROGRAM_EXAMPLE = "prune SIFT when agent is car and motion is fast because \"too slow\"\nadjust ORB.nfeatures by 1.5 when light is dark\n"


def _programs(kg: KnowledgeGraph, name: str | None = None) -> list[dict[str, Any]]:
    rows = kg.select(
        """SELECT ?p ?label ?file (COUNT(?s) AS ?n) WHERE {
            ?p a nfex:Program ; rdfs:label ?label . OPTIONAL { ?p nfex:sourceFile ?file }
            OPTIONAL { ?s nfex:inProgram ?p }
        } GROUP BY ?p ?label ?file ORDER BY ?label"""
    ).rows
    out = [{"name": str(r["label"]), "iri": str(r["p"]), "source": str(r["file"]) if "file" in r else None,
            "statements": int(r["n"].toPython())} for r in rows]  # type: ignore[union-attr]
    return [p for p in out if name is None or p["name"] == name]


def _program_triples(kg: KnowledgeGraph, iri: URIRef) -> set[Any]:
    statements = {r["s"] for r in kg.select(f"SELECT ?s WHERE {{ ?s nfex:inProgram <{iri}> }}").rows}
    atoms = {r["a"] for r in kg.select(f"SELECT ?a WHERE {{ ?s nfex:inProgram <{iri}> ; nfex:hasCondition ?a }}").rows}
    return describe(kg, {iri} | statements | atoms)  # type: ignore[arg-type]


def _compiler() -> Any:
    """The DSL's compile function, or 501 when this build lacks the DSL."""
    try:
        dsl = importlib.import_module("nfex_core.rules.dsl")
    except ModuleNotFoundError as e:
        if e.name and "nfex_core.rules.dsl".startswith(e.name):
            raise NotImplementedFeature("the rules DSL (nfex_core.rules.dsl) is not part of this build") from e
        raise
    fn = getattr(dsl, "compile_program", None)
    if fn is None:
        raise NotImplementedFeature("nfex_core.rules.dsl has no compile_program(text, kg, name) in this build")
    return fn


@router.get("", summary="Every DSL program in the graph")
def list_programs(kg: KGDep) -> dict[str, Any]:
    return {"graph_version": kg.version, "programs": _programs(kg)}


@router.get("/{name}", summary="One program and its statements")
def get_program(name: str, kg: KGDep) -> dict[str, Any]:
    found = _programs(kg, name)
    if not found:
        raise NotFound(f"no program {name!r}; GET /v1/programs lists them")
    return found[0]


@router.put(
    "/{name}",
    summary="Create or replace a program from DSL text (text/plain)",
    openapi_extra={"requestBody": {"required": True, "content": {"text/plain": {"schema": {"type": "string"}, "example": PROGRAM_EXAMPLE}}}},
)
async def put_program(name: str, request: Request, kg: KGDep, token: EditorDep, expected: IfMatchDep) -> Response:
    check_name("program", name)
    media = request.headers.get("content-type", "").split(";")[0].strip().lower()
    if media not in ("text/plain", "text/x-nfex"):
        raise UnsupportedMediaType(f"send the program as text/plain, not {media or 'nothing'!r}")
    try:
        text = (await request.body()).decode("utf-8")
    except UnicodeDecodeError as e:
        raise BadInput(f"the program is not UTF-8: {e}") from e
    compile_program = _compiler()
    graph = await run_in_threadpool(compile_program, text, kg, name)
    new = triples_of(graph)
    existing = _programs(kg, name)
    old = _program_triples(kg, URIRef(existing[0]["iri"])) if existing else set()
    result = await run_in_threadpool(kg.commit, replace(kg, old, new), author=token.name, message=f"PUT program {name}", expected_version=expected)
    return WriteResult.of(result).response(status=200 if existing else 201)


@router.delete("/{name}", summary="Remove a program and its statements")
def delete_program(name: str, kg: KGDep, token: EditorDep, expected: IfMatchDep) -> Response:
    found = _programs(kg, name)
    if not found:
        raise NotFound(f"no program {name!r}")
    change = ChangeSet.removing(_program_triples(kg, URIRef(found[0]["iri"])))
    result = kg.commit(change, author=token.name, message=f"DELETE program {name}", expected_version=expected)
    return WriteResult.of(result, iri=found[0]["iri"]).response()
