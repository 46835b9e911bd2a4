"""Frame streams: a session remembers the previous frame so temporal metrics and motion work."""
from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Request, Response
from fastapi.concurrency import run_in_threadpool

from ..deps import AdvisorDep, SessionsDep, SettingsDep
from ..frames import read_select
from ..schemas import PROBLEM_RESPONSES, Session, SessionCreate, SessionSelection, problems

router = APIRouter(prefix="/v1/sessions", tags=["sessions"])


@router.post("", status_code=201, summary="Open a frame stream", response_model=Session, responses={**PROBLEM_RESPONSES, **problems(429)})
def create_session(body: SessionCreate, sessions: SessionsDep, advisor: AdvisorDep) -> dict[str, Any]:
    context = advisor.snapshot().vocab.check_context(body.context)
    s = sessions.create(context, body.client)
    return s.as_dict(sessions.ttl_s, sessions.clock())


@router.get("/{session_id}", summary="A stream's state", response_model=Session, responses=PROBLEM_RESPONSES)
def get_session(session_id: str, sessions: SessionsDep) -> dict[str, Any]:
    return sessions.get(session_id).as_dict(sessions.ttl_s, sessions.clock())


@router.post(
    "/{session_id}/frames",
    summary="The next frame of a stream (multipart frame + optional context that overrides the session's)",
    response_model=SessionSelection,
    response_model_exclude_unset=True,
    responses={**PROBLEM_RESPONSES, **problems(413, 415, 501)},
    openapi_extra={"requestBody": {"required": True, "content": {"multipart/form-data": {"schema": {"type": "object", "properties": {
        "frame": {"type": "string", "format": "binary"}, "context": {"type": "string"}}}}}}},
)
async def post_frame(session_id: str, request: Request, sessions: SessionsDep, advisor: AdvisorDep, settings: SettingsDep) -> dict[str, Any]:
    session = sessions.get(session_id)
    override, frame = await read_select(request, settings, frame_required=True)
    context: dict[str, str | None] = {**session.context, **override}

    def work() -> dict[str, Any]:
        with session.lock:  # frames of one stream in order: each needs the state the last one left
            selection = advisor.select(context, frame, session.state)
            temporal = session.state is not None
            sessions.keep(session, selection.state)
            out = selection.as_dict()
            out["session"] = {"id": session.id, "frame": session.frames, "temporal": temporal}
            return out

    return await run_in_threadpool(work)


@router.delete("/{session_id}", status_code=204, summary="Close a stream", responses=PROBLEM_RESPONSES)
def delete_session(session_id: str, sessions: SessionsDep) -> Response:
    sessions.delete(session_id)
    return Response(status_code=204)
