"""``POST /v1/feedback``: what a client measured with a selection becomes a Measurement in the graph."""
from __future__ import annotations

from datetime import UTC, datetime

from fastapi import APIRouter
from fastapi.responses import JSONResponse

from nfex_core.feedback import Feedback, feedback_run_iri, measurement_graph

from ..deps import KGDep, SessionsDep
from ..schemas import PROBLEM_RESPONSES, FeedbackRequest, WriteResult

router = APIRouter(prefix="/v1", tags=["feedback"])


@router.post(
    "/feedback",
    status_code=201,
    summary="Report what a selection achieved (ATE/RPE over a window, tracking loss, inliers)",
    description="Stored as a SHACL-checked nfex:Measurement with PROV provenance; the measurement-based "
    "pruning rules count it from this commit on. Open to every client (no token): feedback is data, "
    "not an edit of the rules.",
    responses=PROBLEM_RESPONSES,
)
def feedback(body: FeedbackRequest, kg: KGDep, sessions: SessionsDep) -> JSONResponse:
    context = {k: v for k, v in body.context.items() if v is not None}
    client = body.client
    if body.session_id:
        session = sessions.get(body.session_id)
        context = {**session.context, **context}
        client = client or session.client
    fb = Feedback(**{**body.model_dump(exclude={"session_id", "context", "client"}), "context": context,
                     "client": client, "session": body.session_id})
    vocab = kg.vocabulary()
    now = datetime.now(UTC)
    run_exists = kg.ask(f"ASK {{ <{feedback_run_iri(fb, now)}> a nfex:Run }}")
    graph, iri = measurement_graph(vocab, fb, run_exists=run_exists, now=now)
    result = kg.add(graph, author=f"feedback:{client or 'anonymous'}", message=f"feedback: {fb.extractor} on {fb.sequence}")
    return WriteResult.of(result, iri=str(iri)).response(status=201)
