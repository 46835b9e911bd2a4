"""RFC 9457 problem+json answers from the service, as exceptions."""
from __future__ import annotations

from typing import Any

import httpx


class NfexClientError(Exception):
    """Base of every error the client raises for a problem+json answer (or a non-JSON error answer)."""

    def __init__(self, status: int, problem: dict[str, Any]) -> None:
        self.status = status
        self.problem = problem
        self.type: str = str(problem.get("type", ""))
        self.title: str = str(problem.get("title", ""))
        self.detail: str = str(problem.get("detail", ""))
        super().__init__(f"{status} {self.title}: {self.detail}")

    @property
    def slug(self) -> str:
        return self.type.rsplit("/", 1)[-1]


class BadRequest(NfexClientError):
    """400: malformed input (JSON, SPARQL, Turtle…)."""


class Unauthorized(NfexClientError):
    """401: a write without a valid bearer token."""


class Forbidden(NfexClientError):
    """403: the token lacks the editor role."""


class NotFound(NfexClientError):
    pass


class NotAcceptable(NfexClientError):
    pass


class Conflict(NfexClientError):
    """409: other writers kept committing first; retry."""


class PreconditionFailed(Conflict):
    """412: If-Match named a graph version that is no longer the head (``current_version`` says which is)."""

    @property
    def current_version(self) -> int | None:
        v = self.problem.get("current_version")
        return int(v) if v is not None else None


class PayloadTooLarge(NfexClientError):
    pass


class UnsupportedMediaType(NfexClientError):
    pass


class Unprocessable(NfexClientError):
    """422: unknown names (``allowed`` lists the graph's values), SHACL violations (``violations``)…"""

    @property
    def allowed(self) -> list[str]:
        return list(self.problem.get("allowed", []))

    @property
    def violations(self) -> list[dict[str, Any]]:
        return list(self.problem.get("violations", []))


class TooManyRequests(NfexClientError):
    pass


class NotImplementedByService(NfexClientError):
    pass


class ServiceUnavailable(NfexClientError):
    """503: the store is unavailable, or a SPARQL query hit its time or size limit (``slug == 'query-limit'``)."""


class ServerError(NfexClientError):
    pass


BY_STATUS: dict[int, type[NfexClientError]] = {
    400: BadRequest, 401: Unauthorized, 403: Forbidden, 404: NotFound, 406: NotAcceptable, 409: Conflict,
    412: PreconditionFailed, 413: PayloadTooLarge, 415: UnsupportedMediaType, 422: Unprocessable,
    429: TooManyRequests, 501: NotImplementedByService, 503: ServiceUnavailable,
}


def raise_for_problem(response: httpx.Response) -> None:
    if response.status_code < 400:
        return
    try:
        problem = response.json()
        if not isinstance(problem, dict):
            raise ValueError
    except ValueError:
        problem = {"title": response.reason_phrase, "detail": response.text[:500], "status": response.status_code}
    cls = BY_STATUS.get(response.status_code, ServerError if response.status_code >= 500 else NfexClientError)
    raise cls(response.status_code, problem)
