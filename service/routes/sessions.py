"""Frame streams: a session remembers the previous frame so temporal metrics and motion work, and judges each
frame pair's estimates with its pair judge (the verification stage: the frame's proposals, then ``/verdict``)."""
from __future__ import annotations

from typing import Any

import numpy as np
from fastapi import APIRouter, Request, Response
from fastapi.concurrency import run_in_threadpool
from nfex_slam.pairs import NEXT, PairEvidence

from nfex_core.errors import BadInput
from nfex_core.verification import NoPairToJudge, PairJudge

from ..deps import AdvisorDep, SessionsDep, SettingsDep
from ..frames import read_select
from ..schemas import PROBLEM_RESPONSES, Session, SessionCreate, SessionSelection, problems
from ..schemas.requests import TriedCandidate, VerdictRequest
from ..schemas.selection import Verdict
from ..security import token_of

router = APIRouter(prefix="/v1/sessions", tags=["sessions"])


@router.post("", status_code=201, summary="Open a frame stream", response_model=Session, responses={**PROBLEM_RESPONSES, **problems(429)})
def create_session(body: SessionCreate, sessions: SessionsDep, advisor: AdvisorDep, request: Request) -> dict[str, Any]:
    snap = advisor.snapshot()
    context = snap.vocab.check_context(body.context)
    s = sessions.create(context, body.client, _owner(request), PairJudge(snap.table.budget_terms))
    return s.as_dict(sessions.ttl_s, sessions.clock())


def _owner(request: Request) -> str:
    """Who opens a session, for the per-client limit: a valid token's name, else the client's address. Read
    here, not as a dependency: opening a session needs no token (the OpenAPI document says so)."""
    _, token = token_of(request)
    return f"token {token.name}" if token is not None else f"address {request.client.host if request.client else '?'}"


@router.get("/{session_id}", summary="A stream's state", response_model=Session, responses=PROBLEM_RESPONSES)
def get_session(session_id: str, sessions: SessionsDep) -> dict[str, Any]:
    return sessions.get(session_id).as_dict(sessions.ttl_s, sessions.clock())


@router.post(
    "/{session_id}/frames",
    summary="The next frame of a stream (multipart frame + optional context that overrides the session's)",
    response_model=SessionSelection,
    response_model_exclude_unset=True,
    responses={**PROBLEM_RESPONSES, **problems(413, 415)},
    openapi_extra={"requestBody": {"required": True, "content": {"multipart/form-data": {"schema": {"type": "object", "properties": {
        "frame": {"type": "string", "format": "binary"}, "context": {"type": "string"}}}}}}},
)
async def post_frame(session_id: str, request: Request, sessions: SessionsDep, advisor: AdvisorDep, settings: SettingsDep) -> dict[str, Any]:
    session = sessions.get(session_id)
    override, frame = await read_select(request, settings, frame_required=True)
    context: dict[str, str | None] = {**session.context, **override}

    def work() -> dict[str, Any]:
        with session.lock:  # frames of one stream in order: each needs the state the last one left
            selection = advisor.select(context, frame, session.state, session=True, verdict_held=session.verification.held)
            temporal = session.state is not None
            sessions.keep(session, selection.state)
            session.verification.begin(selection)
            out = selection.as_dict()
            out["session"] = {"id": session.id, "frame": session.frames, "temporal": temporal,
                              "reused": selection.reused > 0}
            return out

    return await run_in_threadpool(work)


@router.post(
    "/{session_id}/verdict",
    summary="Judge the frame pair: the estimates of the proposals tried so far → accept, the next candidate, or fall back",
    response_model=Verdict,
    response_model_exclude_unset=True,
    responses={**PROBLEM_RESPONSES, **problems(409)},
)
def post_verdict(session_id: str, body: VerdictRequest, sessions: SessionsDep) -> dict[str, Any]:
    """The verification stage over HTTP: the session's pair judge (nfex_core/verification/; docs/service.md,
    "Verified selection")."""
    session = sessions.get(session_id)
    with session.lock:
        pending = session.verification.pending
        if pending is None:
            raise NoPairToJudge(f"session {session_id} has no frame pair awaiting a verdict: POST the next frame to "
                                f"/v1/sessions/{session_id}/frames first (a pair is judged once)")
        tried = [_evidence(i, t) for i, t in enumerate(body.tried)]
        verdict = session.verification.judge(tried)
        out = verdict.as_dict()
        out["tries"] = len(tried)
        if verdict.action == NEXT:
            nxt = pending[len(tried)]
            out["next"] = {"extractor": nxt.extractor, "params": nxt.params}
        return out


def _evidence(i: int, t: TriedCandidate) -> PairEvidence:
    """A reported estimate, checked: R a rotation, t a non-zero 3-vector (or both null: lost)."""
    if t.R is None and t.t is None:
        return PairEvidence(t.extractor, dict(t.params), keypoints=t.keypoints, matches=t.matches, inliers=t.inliers,
                            parallax_px=t.parallax_px, extraction_ms=t.extraction_ms, rejected=t.rejected or "lost")
    R = np.asarray(t.R, dtype=float) if t.R is not None else None
    v = np.asarray(t.t, dtype=float) if t.t is not None else None
    if R is None or v is None or R.shape != (3, 3) or v.shape != (3,):
        raise BadInput(f"tried[{i}]: R must be a 3×3 matrix and t a 3-vector (or both null for a lost pair)")
    if not np.allclose(R @ R.T, np.eye(3), atol=1e-3) or abs(float(np.linalg.det(R)) - 1.0) > 1e-3:
        raise BadInput(f"tried[{i}]: R is not a rotation (RᵀR must be I and det R = 1, within 1e-3)")
    n = float(np.linalg.norm(v))
    if not np.isfinite(n) or n == 0:
        raise BadInput(f"tried[{i}]: t must be a finite, non-zero vector")
    return PairEvidence.of(t.extractor, t.params, R, v / n, keypoints=t.keypoints, matches=t.matches, inliers=t.inliers,
                           parallax_px=t.parallax_px, extraction_ms=t.extraction_ms, rejected=t.rejected)


@router.delete("/{session_id}", status_code=204, summary="Close a stream", responses=PROBLEM_RESPONSES)
def delete_session(session_id: str, sessions: SessionsDep) -> Response:
    sessions.delete(session_id)
    return Response(status_code=204)
