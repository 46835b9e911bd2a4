"""Liveness, readiness and Prometheus metrics."""
from __future__ import annotations

import sys
from typing import Any

from fastapi import APIRouter, Request
from fastapi.responses import JSONResponse, Response
from prometheus_client import CONTENT_TYPE_LATEST, generate_latest

from nfex_core.errors import StoreUnavailable
from nfex_core.vision.backends import status as backend_status

from ..deps import KGDep, SessionsDep
from ..schemas import Health, Ready, problems

router = APIRouter(tags=["operations"])


@router.get("/healthz", summary="The process is up", response_model=Health)
def healthz() -> dict[str, str]:
    return {"status": "ok"}


@router.get(
    "/readyz", summary="The graph is loaded, the rule table compiled; 503 until then", response_model=Ready,
    responses={503: {"description": "Starting, or the warm-up failed (status, detail)",
                     "content": {"application/json": {"schema": {"$ref": "#/components/schemas/Ready"}}}}},
)
def readyz(request: Request, kg: KGDep) -> JSONResponse:
    """Ready while selections can be answered: a store outage leaves a replica in rotation, answering from its
    snapshot, and says so (``writes: unavailable``); ``/readyz/writes`` is the signal for writes."""
    state = request.app.state
    snap = state.advisor.current_snapshot()
    body: dict[str, Any] = {
        "status": "ready" if state.ready.is_set() else "starting",
        "store": kg.location,
        "torch_loaded": "torch" in sys.modules,
    }
    try:
        body["graph_version"] = kg.version
    except StoreUnavailable as e:
        if snap is None:
            raise
        body.update(graph_version=snap.version, writes="unavailable",
                    detail=f"serving from the snapshot of graph version {snap.version}, writes unavailable: {e.detail}")
    if kg.shacl is not None:
        body["shacl_process"] = kg.shacl.status()
    if state.warmup_error is not None:
        body.update(status="failed", detail=state.warmup_error)
    if snap is not None:
        body["rule_table"] = {"version": snap.version, "rules": len(snap.table.rules), "contexts": len(snap.table.decisions),
                              "compile_ms": round(snap.table.compile_ms, 1), "kept": snap.table.kept_in is not None}
        # which backends can run here: a learned extractor without its extra is pruned, and this says why
        body["backends"] = backend_status(snap.vocab.extractors, kg.settings)
    return JSONResponse(body, status_code=200 if body["status"] == "ready" else 503)


@router.get(
    "/readyz/writes", summary="The store accepts writes: 503 while it cannot be reached", response_model=Health,
    responses=problems(503),
)
def readyz_writes(kg: KGDep) -> dict[str, str]:
    head = kg.version  # a read of the store's head; StoreUnavailable (503) when it cannot be reached
    return {"status": f"ok: the store answers at graph version {head}"}


@router.get("/metrics", summary="Prometheus metrics of this process", response_class=Response,
            responses={200: {"content": {"text/plain": {"schema": {"type": "string"}}}}})
def metrics(request: Request, kg: KGDep, sessions: SessionsDep) -> Response:
    m = request.app.state.metrics
    m.sessions.set(len(sessions))
    m.session_bytes.set(sessions.bytes_held)
    m.graph_version.set(kg.version)
    return Response(generate_latest(m.registry), media_type=CONTENT_TYPE_LATEST)
