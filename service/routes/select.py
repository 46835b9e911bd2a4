"""``POST /v1/select``: a frame and/or a context in, the advisor's Selection out."""
from __future__ import annotations

from typing import Literal

from fastapi import APIRouter, Query, Request, Response
from fastapi.concurrency import run_in_threadpool

from ..deps import AdvisorDep, SettingsDep
from ..frames import keypoints_flag, keypoints_of, read_select
from ..schemas import CONTEXT_EXAMPLE, PROBLEM_RESPONSES, Selection, problems
from ..schemas.selection import answer_json

router = APIRouter(prefix="/v1", tags=["selection"])

SELECT_BODY = {
    "requestBody": {
        "required": True,
        "content": {
            "application/json": {
                "schema": {"$ref": "#/components/schemas/SelectRequest"},
                "example": {"context": CONTEXT_EXAMPLE},
            },
            "multipart/form-data": {
                "schema": {
                    "type": "object",
                    "properties": {
                        "frame": {"type": "string", "format": "binary", "description": "PNG or JPEG, grey or colour"},
                        "context": {"type": "string", "description": "JSON object: dimension → value", "example": '{"agent": "car"}'},
                    },
                }
            },
        },
    }
}


@router.post(
    "/select",
    summary="Which extractor to run, with which parameters, and why",
    description="Send the context alone as JSON, or a frame (multipart `frame`) with an optional `context` "
    "part. Unknown condition values are rejected (422) with the values the graph allows. With a frame, "
    "`?keypoints=true` adds the keypoints α* with Θ′ finds on it (for drawing; the workbench uses it). "
    "The answer comes from the last compiled graph version (`versions.graph`; `versions.stale_ms` says how long a "
    "newer one has waited for its compile); `?consistency=latest` waits for the head's compile instead (read-your-writes "
    "after your own feedback).",
    openapi_extra=SELECT_BODY,
    response_model=Selection,
    response_model_exclude_unset=True,  # members as_dict() leaves out stay out
    responses={**PROBLEM_RESPONSES, **problems(413, 415)},
)
async def select(request: Request, advisor: AdvisorDep, settings: SettingsDep,
                 consistency: Literal["snapshot", "latest"] = Query(
                     "snapshot", description="snapshot: the last compiled version answers at once; latest: wait "
                     "for the compile of the store's head version")) -> Response:
    context, frame = await read_select(request, settings)
    if frame is None and consistency == "snapshot" and advisor.is_fresh():  # microseconds: not worth a thread hop
        selection = advisor.select(context, None)
    else:
        selection = await run_in_threadpool(lambda: advisor.select(context, frame, consistency=consistency))
    out = selection.as_dict()
    if "keypoints" in request.query_params and keypoints_flag(request.query_params["keypoints"]):  # opt-in: off the hot path
        out["keypoints"] = await run_in_threadpool(keypoints_of, request.app.state.kg.vocabulary(), selection, frame)
    return Response(answer_json(out), media_type="application/json")  # unvalidated: service/schemas/selection.py
