"""DSL programs (``nfex:Program`` and their statements), through ``nfex_core.rules.dsl.programs``.

PUT parses, checks (names against the graph; errors carry line and column) and compiles the text, then
replaces the program's statements as one SHACL-checked transaction (docs/dsl.md).
"""
from __future__ import annotations

import threading
from typing import Any

from fastapi import APIRouter, Request, Response
from fastapi.concurrency import run_in_threadpool

from nfex_core.errors import NotFound, QueryLimitExceeded
from nfex_core.rules.dsl import programs as programs_dsl

from ..bodies import media_type, utf8_text
from ..deps import EditorDep, IfMatchDep, KGDep
from ..editing import check_name
from ..images import UnsupportedMediaType
from ..schemas import PROBLEM_RESPONSES, Program, ProgramList, WriteResult, problems

router = APIRouter(prefix="/v1/programs", tags=["editing: programs"], responses=PROBLEM_RESPONSES)
PROGRAM_EXAMPLE = 'adjust ORB.nfeatures by 1.5 when light is dark because "dark frames have fewer corners"\n'
TEXT_BODY = {"requestBody": {"required": True, "content": {"text/plain": {"schema": {"type": "string"}, "example": PROGRAM_EXAMPLE}}}}
PREVIEW_LIMIT = 500  # contexts listed in a preview (the counts cover all)
_previews = threading.Semaphore(1)  # a preview compiles the rule table twice: one at a time per process


def _info(p: Any) -> dict[str, Any]:
    return {"name": p.name, "iri": p.iri, "statements": p.statements, "source": p.source}


@router.get("", summary="Every DSL program in the graph", response_model=ProgramList)
def list_programs(kg: KGDep) -> dict[str, Any]:
    return {"graph_version": kg.version, "programs": [_info(p) for p in programs_dsl.programs(kg)]}


@router.get("/{name}", summary="One program: its statements as DSL text, read back from the graph", response_model=Program)
def get_program(name: str, kg: KGDep) -> dict[str, Any]:
    dsl = programs_dsl
    found = [p for p in dsl.programs(kg) if p.name == name]
    if not found:
        raise NotFound(f"no program {name!r}; GET /v1/programs lists them")
    from nfex_core.rules.dsl import render

    return {**_info(found[0]), "text": render(dsl.show(kg, name))}


async def _program_text(request: Request) -> str:
    media = media_type(request.headers.get("content-type"))
    if media not in ("text/plain", "text/x-nfex"):
        raise UnsupportedMediaType(f"send the program as text/plain, not {media or 'nothing'!r}")
    return await utf8_text(request, "the program")


def _problem(e: Any) -> dict[str, Any]:
    return {k: v for k, v in e.problem().items() if k != "problems"}


@router.post("/{name}/check", summary="Check DSL text against the graph without applying it: every problem with line and column",
             openapi_extra=TEXT_BODY)
async def check_program(name: str, request: Request, kg: KGDep) -> dict[str, Any]:
    """200 with ``valid`` and ``problems`` (each an RFC 9457 problem with ``line``, ``column`` and, for an
    unknown name, the ``allowed`` names): a check that finds problems has still succeeded."""
    check_name("program", name)
    text = await _program_text(request)
    program, found = await run_in_threadpool(programs_dsl.check_text, text, kg.vocabulary(), name=name)
    return {"name": name, "valid": not found, "statements": len(program.statements) if program is not None else None,
            "problems": [_problem(e) for e in found]}


@router.post("/{name}/preview", summary="What applying DSL text would change in the decisions (contexts whose α or Θ′ change); nothing is written",
             openapi_extra=TEXT_BODY)
async def preview_program(name: str, request: Request, kg: KGDep) -> dict[str, Any]:
    check_name("program", name)
    text = await _program_text(request)
    dsl = programs_dsl
    if not _previews.acquire(blocking=False):
        raise QueryLimitExceeded("another preview is being computed; retry in a few seconds", limit="concurrency")

    def work() -> dict[str, Any]:
        from nfex_core.advisor.impact import impact

        try:
            _, graph = dsl.compile_text(text, kg.vocabulary(), name=name, source=f"api:{name}")
            return {"name": name, **impact(kg, dsl.change_of(kg, graph, name)).as_dict(limit=PREVIEW_LIMIT)}
        finally:
            _previews.release()

    return await run_in_threadpool(work)


@router.put(
    "/{name}",
    summary="Create or replace a program from DSL text (text/plain)",
    response_model=WriteResult,
    responses={**{201: {"model": WriteResult, "description": "Created"}}, **problems(409, 412, 415)},
    openapi_extra={"requestBody": {"required": True, "content": {"text/plain": {"schema": {"type": "string"}, "example": PROGRAM_EXAMPLE}}}},
)
async def put_program(name: str, request: Request, kg: KGDep, token: EditorDep, expected: IfMatchDep) -> Response:
    check_name("program", name)
    text = await _program_text(request)
    dsl = programs_dsl

    def work() -> tuple[bool, Any]:
        existed = any(p.name == name for p in dsl.programs(kg))
        _, graph = dsl.compile_text(text, kg.vocabulary(), name=name, source=f"api:{name}")
        return existed, dsl.apply(kg, graph, name, author=token.name, message=f"PUT program {name}", expected_version=expected)

    existed, result = await run_in_threadpool(work)
    return WriteResult.of(result).response(status=200 if existed else 201)


@router.delete("/{name}", summary="Remove a program and its statements", response_model=WriteResult, responses=problems(409, 412))
def delete_program(name: str, kg: KGDep, token: EditorDep, expected: IfMatchDep) -> Response:
    dsl = programs_dsl
    if not any(p.name == name for p in dsl.programs(kg)):
        raise NotFound(f"no program {name!r}")
    if expected is not None and expected != kg.version:
        from nfex_core.errors import PreconditionFailed

        raise PreconditionFailed(f"the graph is at version {kg.version}, not {expected}; re-read and retry", current_version=kg.version)
    result = dsl.remove(kg, name, author=token.name, message=f"DELETE program {name}")
    return WriteResult.of(result).response()
