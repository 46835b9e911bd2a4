"""Dependencies shared by the routers (FastAPI ``Annotated`` aliases)."""
from __future__ import annotations

import re
from collections.abc import Iterator
from typing import Annotated

from fastapi import Depends, Header, Request

from nfex_core.advisor import Advisor
from nfex_core.errors import BadInput
from nfex_core.feedback import ReportWriter
from nfex_core.kg import KnowledgeGraph

from .config import Settings, Token
from .security import require
from .sessions import SessionStore


# Dependencies that only read app.state or a header are ``async``: FastAPI runs a plain ``def`` dependency in
# its thread pool, a thread hop per dependency per request that a busy service's selects paid for nothing.
async def get_kg(request: Request) -> KnowledgeGraph:
    return request.app.state.kg


async def get_advisor(request: Request) -> Advisor:
    return request.app.state.advisor


async def get_settings(request: Request) -> Settings:
    return request.app.state.settings


async def get_reports(request: Request) -> ReportWriter:
    return request.app.state.reports


async def get_sessions(request: Request) -> SessionStore:
    return request.app.state.sessions


_ETAG = re.compile(r'^\s*(?:W/)?"?(\d{1,18})"?\s*$')  # a graph version, not a number of thousands of digits


async def expected_version(if_match: Annotated[str | None, Header(alias="If-Match")] = None) -> int | None:
    """``If-Match: "N"`` pins a write to graph version N (412 if the head moved); ``*`` or absent: any."""
    if if_match is None or if_match.strip() == "*":
        return None
    m = _ETAG.match(if_match)
    if m is None:
        raise BadInput(f'If-Match must be a graph version ETag like "12", not {if_match[:40]!r}')
    return int(m.group(1))


def editor_write(request: Request, token: Annotated[Token, Depends(require("editor", "this write"))]) -> Iterator[Token]:
    """The editor's token for a write; once the write succeeded, and before it is answered, the advisor compiles
    the new head, so the editor's next selection reads the write (read-your-writes for the rare edits; a
    stream of feedback reports does not wait: docs/service.md, "Consistency")."""
    yield token
    request.app.state.advisor.sync()


KGDep = Annotated[KnowledgeGraph, Depends(get_kg)]
AdvisorDep = Annotated[Advisor, Depends(get_advisor)]
SettingsDep = Annotated[Settings, Depends(get_settings)]
ReportsDep = Annotated[ReportWriter, Depends(get_reports)]
SessionsDep = Annotated[SessionStore, Depends(get_sessions)]
ReporterDep = Annotated[Token, Depends(require("reporter", "reporting feedback"))]
EditorDep = Annotated[Token, Depends(editor_write, scope="function")]
IfMatchDep = Annotated[int | None, Depends(expected_version)]
