"""Liveness and readiness."""
from __future__ import annotations

from fastapi import APIRouter

from ..deps import KGDep

router = APIRouter(tags=["operations"])


@router.get("/healthz", summary="The process is up")
def healthz() -> dict[str, str]:
    return {"status": "ok"}


@router.get("/readyz", summary="The graph is loaded and answers")
def readyz(kg: KGDep) -> dict[str, object]:
    return {"status": "ready", "graph_version": kg.version, "store": kg.location}
