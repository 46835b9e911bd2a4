"""``/v1/feedback``: what a client measured with a selection becomes a report in the graph (reporter
token); it steers selections once corroborated by ``nfex:minSources`` reporters or accepted by an editor."""
from __future__ import annotations

import asyncio
import re
from typing import Annotated, Any

from fastapi import APIRouter, Header, Path, Query
from fastapi.responses import JSONResponse

from nfex_core.errors import NotFound
from nfex_core.evidence import TrustPolicy, admit, read_observations
from nfex_core.feedback import Feedback, acceptance_graph
from nfex_core.kg.namespaces import NFEX

from ..deps import EditorDep, IfMatchDep, KGDep, ReporterDep, ReportsDep, SessionsDep
from ..schemas import PROBLEM_RESPONSES, FeedbackRequest, ReportList, WriteResult

router = APIRouter(prefix="/v1", tags=["feedback"], responses=PROBLEM_RESPONSES)
REPORT_ID = re.compile(r"^measurement_[0-9a-f]{32}$")


@router.post(
    "/feedback",
    status_code=201,
    summary="Report what a selection achieved (ATE/RPE over a window, tracking loss, inliers) — reporter token",
    description="Stored as a SHACL-checked nfex:Measurement with PROV provenance, attributed to the token's "
    "holder (prov:wasAttributedTo). It is a *report*: it steers selections (measured rules, measured Θ′, "
    "measured accuracy, cost model) once nfex:minSources distinct reporters reported the same configuration "
    "under the same conditions, or an editor accepted it (POST /v1/feedback/{id}/accept). Needs the reporter role. "
    "Reports arriving together are committed as one graph version (group commit); each is answered once its batch "
    "is committed, with its own IRI. A selection may answer from the previous version until the new one is "
    "compiled (`versions.stale_ms`); `POST /v1/select?consistency=latest` waits for it.",
    response_model=WriteResult,
    responses=PROBLEM_RESPONSES,
)
async def feedback(body: FeedbackRequest, writer: ReportsDep, sessions: SessionsDep, token: ReporterDep,
                   idempotency_key: Annotated[str | None, Header(
                       alias="Idempotency-Key", max_length=200, pattern=r"^[\x21-\x7e]+$",
                       description="The client's key for this report: a retry with the same key (after a lost answer) is "
                                   "answered 200 with the stored report instead of storing it twice")] = None) -> JSONResponse:
    context = {k: v for k, v in body.context.items() if v is not None}
    client = body.client
    if body.session_id:
        session = sessions.get(body.session_id)
        context = {**session.context, **context}
        client = client or session.client
    fb = Feedback(**{**body.model_dump(exclude={"session_id", "context", "client"}), "context": context,
                     "client": client, "session": body.session_id, "reporter": token.name, "key": idempotency_key})
    # committed with the reports that arrived with it (nfex_core.feedback.ReportWriter), awaited on the event loop: a
    # report holds no thread while its batch forms and commits, so a fleet is not capped by the thread pool's size
    written = await asyncio.wrap_future(writer.submit(fb))
    replayed = idempotency_key is not None and not written.result.changed
    return WriteResult.of(written.result, iri=str(written.iri)).response(status=200 if replayed else 201)


@router.get("/feedback", summary="Client reports and whether each steers selections yet (and why, or why not)",
            response_model=ReportList)
def reports(kg: KGDep, status: str | None = Query(None, pattern="^(admitted|quarantined)$"),
            limit: int = Query(100, ge=1, le=10000)) -> JSONResponse:
    observations = [o for o in read_observations(kg) if o.reporter is not None]
    policy = TrustPolicy.load(kg)
    admission = admit(observations, policy)
    items: list[dict[str, Any]] = []
    for o in sorted(observations, key=lambda o: o.iri):
        admitted = o.iri in admission.admitted
        if status is not None and (status == "admitted") != admitted:
            continue
        items.append({"id": o.iri.rsplit("#", 1)[-1], "iri": o.iri, "extractor": o.extractor, "configuration": o.configuration,
                      "conditions": {d: v for d, v in sorted(o.conditions)}, "reporter": o.reporter, "ate_m": o.ate,
                      "status": "admitted" if admitted else "quarantined",
                      "because": admission.admitted.get(o.iri) or admission.quarantined.get(o.iri)})
        if len(items) >= limit:
            break
    return JSONResponse({"min_sources": policy.min_sources, "reports": items}, headers={"ETag": f'"{kg.version}"'})


@router.post("/feedback/{report_id}/accept", summary="Admit a report as evidence before it is corroborated (editor)",
             response_model=WriteResult)
def accept(kg: KGDep, token: EditorDep, expected: IfMatchDep,
           report_id: str = Path(..., max_length=64, description="The report's id: measurement_<32 hex digits>")) -> JSONResponse:
    if not REPORT_ID.match(report_id):
        raise NotFound(f"no report {report_id!r}; ids look like measurement_<32 hex digits> (GET /v1/feedback)")
    iri = NFEX[report_id]
    if not kg.ask(f"ASK {{ <{iri}> a nfex:Measurement ; prov:wasAttributedTo ?who }}"):
        raise NotFound(f"no report {report_id!r} (GET /v1/feedback lists them)")
    result = kg.add(acceptance_graph(iri, token.name), author=token.name, message=f"accept report {report_id}",
                    expected_version=expected)
    return WriteResult.of(result, iri=str(iri)).response()
