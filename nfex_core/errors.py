"""One exception hierarchy for nFEX.

Each kind knows its HTTP status, a short ``type`` slug (rendered as an RFC 9457 problem type
``https://w3id.org/nfex/problems/<slug>``) and the CLI exit code, so the service renders every error
in one handler and the CLI prints one line and exits with the kind's code. Exit codes follow
pySHACL's convention: 1 = the data does not conform, 2 = bad input, 3 = internal error. The roots
(NfexError, BadInput, ParseError, UnknownName, ParameterError, DataMissing) live in ``nfex_slam.errors``, with
the dataset loaders and the VO that raise them; the kinds of the graph and the service are here.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from nfex_slam.errors import (  # the roots of the hierarchy, shared with the SLAM front end
    PROBLEM_BASE,
    BadInput,
    DataMissing,
    NfexError,
    ParameterError,
    ParseError,
    UnknownName,
)

__all__ = [
    "PROBLEM_BASE", "BadInput", "Conflict", "DataMissing", "ModelUnavailable", "NfexError", "NoCandidate", "NotFound",
    "ParameterError", "ParseError", "PreconditionFailed", "Problem", "QueryLimitExceeded", "StoreUnavailable",
    "UnknownName", "ValidationFailed", "ValidationResult",
]


@dataclass(frozen=True)
class ValidationResult:
    """One SHACL result: the offending node, the shape and the message."""

    focus_node: str
    source_shape: str
    message: str
    path: str | None = None
    value: str | None = None
    severity: str = "Violation"

    def line(self) -> str:
        where = f" (path {self.path})" if self.path else ""
        return f"{self.focus_node}{where}: {self.message} [shape {self.source_shape}]"


class ValidationFailed(NfexError):
    """A write was rejected by SHACL; the graph is unchanged. Carries the report."""

    status = 422
    type = "shacl-violation"
    title = "The change violates the graph's shapes"
    exit_code = 1

    def __init__(self, results: Sequence[ValidationResult], report_text: str = "", **extra: Any) -> None:
        self.results = list(results)
        self.report_text = report_text
        first = self.results[0].line() if self.results else "validation failed"
        more = f" (and {len(self.results) - 1} more)" if len(self.results) > 1 else ""
        super().__init__(
            first + more,
            violations=[r.__dict__ for r in self.results],
            **extra,
        )


class NoCandidate(NfexError):
    """The rules in force prune every extractor for this context; the pruned list says why."""

    status = 422
    type = "no-candidate"
    title = "No candidate extractor"
    exit_code = 1


class NotFound(NfexError):
    status = 404
    type = "not-found"
    title = "Not found"
    exit_code = 4


class Conflict(NfexError):
    """Another writer committed first (optimistic concurrency on the graph version)."""

    status = 409
    type = "version-conflict"
    title = "Version conflict"
    exit_code = 5


class PreconditionFailed(Conflict):
    """``If-Match`` named a graph version that is no longer the head."""

    status = 412
    type = "precondition-failed"
    title = "Precondition failed"


class StoreUnavailable(NfexError):
    """The store cannot be opened or reached (a folder held by another process, a server down)."""

    status = 503
    type = "store-unavailable"
    title = "Store unavailable"
    exit_code = 6


class QueryLimitExceeded(NfexError):
    """A SPARQL query ran past its time limit or result-size limit."""

    status = 503
    type = "query-limit"
    title = "Query limit exceeded"
    exit_code = 7


class ModelUnavailable(BadInput):
    """A learned extractor cannot run here: its extra is not installed, its weights file is missing, or
    exporting it failed. ``setting`` names what to change (an ``NFEX_*`` variable or the extra)."""

    status = 422
    type = "model-unavailable"
    title = "Learned model unavailable"

    def __init__(self, detail: str, *, setting: str, **extra: Any) -> None:
        super().__init__(detail, setting=setting, **extra)
        self.setting = setting


@dataclass
class Problem:
    """A structured error usable outside exceptions (e.g. collected while checking a program)."""

    detail: str
    line: int | None = None
    column: int | None = None
    extra: dict[str, Any] = field(default_factory=dict)
