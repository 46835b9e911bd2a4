"""The errors of the SLAM front end, the roots of nFEX's one exception hierarchy (nfex_core.errors extends it).

Each kind knows its HTTP status, a short ``type`` slug (rendered as an RFC 9457 problem type
``https://w3id.org/nfex/problems/<slug>``) and the CLI exit code, so the service renders every error
in one handler and a command line prints one line and exits with the kind's code. Exit codes follow
pySHACL's convention: 1 = the data does not conform, 2 = bad input, 3 = internal error. They live here,
with the dataset loaders and the VO that raise them, so that this package installs without the server.
"""
from __future__ import annotations

from collections.abc import Iterable
from typing import Any, ClassVar

PROBLEM_BASE = "https://w3id.org/nfex/problems/"


class NfexError(Exception):
    """Base of every error nFEX raises on purpose."""

    status: ClassVar[int] = 500
    type: ClassVar[str] = "internal-error"
    title: ClassVar[str] = "Internal error"
    exit_code: ClassVar[int] = 3

    def __init__(self, detail: str, **extra: Any) -> None:
        super().__init__(detail)
        self.detail = detail
        self.extra = extra

    def problem(self) -> dict[str, Any]:
        """The RFC 9457 problem document for this error."""
        doc: dict[str, Any] = {
            "type": PROBLEM_BASE + self.type,
            "title": self.title,
            "status": self.status,
            "detail": self.detail,
        }
        doc.update(self.extra)
        return doc


class BadInput(NfexError):
    """The request or the command line is malformed."""

    status = 400
    type = "bad-input"
    title = "Bad input"
    exit_code = 2


class ParseError(BadInput):
    """A text (Turtle, SPARQL, a DSL program) does not parse; carries line and column where known."""

    type = "parse-error"
    title = "Parse error"

    def __init__(self, detail: str, *, line: int | None = None, column: int | None = None, **extra: Any):
        if line is not None:
            extra["line"] = line
        if column is not None:
            extra["column"] = column
        super().__init__(detail, **extra)
        self.line = line
        self.column = column


class UnknownName(BadInput):
    """A name (extractor, parameter, condition value, metric) the graph does not know."""

    status = 422
    type = "unknown-name"
    title = "Unknown name"

    def __init__(self, kind: str, name: str, known: Iterable[str], *, where: str | None = None, **extra: Any):
        self.kind = kind
        self.name = name
        self.known = sorted(known)
        prefix = f"{where}: " if where else ""
        detail = f"{prefix}unknown {kind} {name!r}; known: {', '.join(self.known) or '(none)'}"
        super().__init__(detail, kind=kind, name=name, allowed=self.known, **extra)


class ParameterError(BadInput):
    """A parameter value outside its range, of the wrong type, or not allowed."""

    status = 422
    type = "invalid-parameter"
    title = "Invalid parameter"


class DataMissing(BadInput):
    """A dataset folder lacks a file it needs."""

    status = 404
    type = "data-missing"
    title = "Data missing"
