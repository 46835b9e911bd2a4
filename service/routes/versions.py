"""Graph versions: list, one version's change set, the net diff between two, rollback (editor).

Every response that reads the graph's state carries ``ETag: "N"`` (N = head version); a write sent
with ``If-Match: "N"`` applies only if N is still the head, else 412 — the editor re-reads and retries.
"""
from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Query, Response

from nfex_core.kg import ChangeSet
from nfex_core.kg.rdf.terms import triple_n3

from ..deps import EditorDep, IfMatchDep, KGDep
from ..schemas import (
    PROBLEM_RESPONSES,
    Diff,
    Head,
    RollbackIn,
    VersionChanges,
    VersionList,
    WriteResult,
    problems,
)

router = APIRouter(prefix="/v1/graph", tags=["editing: versions"], responses=PROBLEM_RESPONSES)
MAX_TRIPLES = 5000


def _change(change: ChangeSet) -> dict[str, Any]:
    added = sorted(triple_n3(t) for t in change.added)
    removed = sorted(triple_n3(t) for t in change.removed)
    return {"added": added[:MAX_TRIPLES], "removed": removed[:MAX_TRIPLES], "added_count": len(added),
            "removed_count": len(removed), "truncated": len(added) > MAX_TRIPLES or len(removed) > MAX_TRIPLES}


@router.get("", summary="The head version (also as ETag)", response_model=Head)
def head(kg: KGDep, response: Response) -> dict[str, Any]:
    v = kg.version
    response.headers["ETag"] = f'"{v}"'
    return {"version": v, "store": kg.location, "triples": kg.triple_count()}


@router.get("/versions", summary="Versions, newest first", response_model=VersionList)
def versions(kg: KGDep, response: Response, limit: int = Query(100, ge=1, le=10000)) -> dict[str, Any]:
    items = [v.as_dict() for v in kg.versions(limit)]
    response.headers["ETag"] = f'"{kg.version}"'
    return {"versions": items}


@router.get("/versions/{number}", summary="One version and the change set it committed", response_model=VersionChanges)
def version(number: int, kg: KGDep) -> dict[str, Any]:
    info = kg.version_info(number)
    return {**info.as_dict(), **_change(kg.changes(number))}


@router.get("/diff", summary="The net change from one version to another (default: to the head)", response_model=Diff)
def diff(kg: KGDep, since: int = Query(..., ge=0), until: int | None = Query(None, ge=0)) -> dict[str, Any]:
    return {"since": since, "until": until if until is not None else kg.version, **_change(kg.diff(since, until))}


@router.post("/rollback", summary="Restore an earlier version's knowledge as a new version (history kept)",
             response_model=WriteResult, responses=problems(409, 412))
def rollback(body: RollbackIn, kg: KGDep, token: EditorDep, expected: IfMatchDep) -> Response:
    result = kg.rollback(body.to, author=token.name, expected_version=expected)
    return WriteResult.of(result).response()
