"""RFC 9457 problem details in the OpenAPI document: the ``Problem`` schema and the error responses.

Every error the service answers is ``application/problem+json`` (service/problems.py renders them);
these describe them under that media type, referring to ``#/components/schemas/Problem``, which
service/openapi.py adds to the document.
"""
from __future__ import annotations

from typing import Any

from pydantic import BaseModel, ConfigDict, Field

PROBLEM_JSON = "application/problem+json"
PROBLEM_REF = "#/components/schemas/Problem"


class Problem(BaseModel):
    """RFC 9457 problem details; extra members (allowed, violations, limit, current_version…) depend on the type."""

    model_config = ConfigDict(extra="allow", title="Problem")

    type: str = Field(..., description="https://w3id.org/nfex/problems/<slug>")
    title: str
    status: int
    detail: str


WHAT = {
    400: "Bad input (syntax, malformed parameters)",
    401: "No or invalid bearer token",
    403: "The token's role may not do this",
    404: "Not found",
    405: "Method not allowed (see Allow)",
    406: "No acceptable media type for this result",
    409: "Other writers kept committing first; retry",
    412: "If-Match names a graph version that is no longer the head",
    413: "Body, frame or pixel count over the limit",
    415: "Unsupported media type",
    422: "Unknown names (with the allowed values), invalid values, or a SHACL violation (with the report)",
    429: "Too many sessions",
    500: "Internal error",
    503: "Store unavailable or a query limit exceeded",
}


def problem_response(status: int) -> dict[str, Any]:
    """One OpenAPI response object: ``status`` as problem+json."""
    return {"description": WHAT[status], "content": {PROBLEM_JSON: {"schema": {"$ref": PROBLEM_REF}}}}


def problems(*statuses: int) -> dict[int | str, dict[str, Any]]:
    """``responses=`` for a route: these statuses as problem+json."""
    return {s: problem_response(s) for s in statuses}


# what most routes can answer: their input refused, an unknown name, the store down
PROBLEM_RESPONSES = problems(400, 404, 422, 503)
