"""Dependencies shared by the routers (FastAPI ``Annotated`` aliases)."""
from __future__ import annotations

import hmac
import re
from typing import Annotated

from fastapi import Depends, Header, Request
from fastapi.security import HTTPAuthorizationCredentials, HTTPBearer

from nfex_core.advisor import Advisor
from nfex_core.errors import BadInput, NfexError
from nfex_core.kg import KnowledgeGraph

from .config import Settings, Token
from .sessions import SessionStore


class Unauthorized(NfexError):
    status = 401
    type = "unauthorized"
    title = "Unauthorized"
    exit_code = 2
    headers = {"WWW-Authenticate": 'Bearer realm="nfex"'}  # RFC 6750 §3


class Forbidden(NfexError):
    status = 403
    type = "forbidden"
    title = "Forbidden"
    exit_code = 2


def get_kg(request: Request) -> KnowledgeGraph:
    return request.app.state.kg


def get_advisor(request: Request) -> Advisor:
    return request.app.state.advisor


def get_settings(request: Request) -> Settings:
    return request.app.state.settings


def get_sessions(request: Request) -> SessionStore:
    return request.app.state.sessions


# The OpenAPI security scheme (HTTP bearer, RFC 6750): a route that depends on it lists it in its
# ``security``; auto_error is off so that a missing or non-bearer header is our own 401 problem+json.
bearer = HTTPBearer(
    scheme_name="bearer", auto_error=False,
    description="A token from NFEX_TOKENS (name:token:role). Reads are open; writes need a token with the editor role.",
)


def editor(request: Request, credentials: Annotated[HTTPAuthorizationCredentials | None, Depends(bearer)]) -> Token:
    """The editor behind ``Authorization: Bearer <token>``; 401 without a valid token, 403 without the role."""
    tokens: dict[str, Token] = request.app.state.tokens
    if credentials is None:
        raise Unauthorized("this write needs 'Authorization: Bearer <token>' with the editor role (NFEX_TOKENS)")
    given = credentials.credentials.strip()
    found = None
    for secret, token in tokens.items():
        if hmac.compare_digest(secret.encode(), given.encode()):
            found = token
    if found is None:
        raise Unauthorized("the bearer token is not valid")
    if found.role != "editor":
        raise Forbidden(f"{found.name} has role {found.role!r}; writes need 'editor'")
    return found


_ETAG = re.compile(r'^\s*(?:W/)?"?(\d+)"?\s*$')


def expected_version(if_match: Annotated[str | None, Header(alias="If-Match")] = None) -> int | None:
    """``If-Match: "N"`` pins a write to graph version N (412 if the head moved); ``*`` or absent: any."""
    if if_match is None or if_match.strip() == "*":
        return None
    m = _ETAG.match(if_match)
    if m is None:
        raise BadInput(f'If-Match must be a graph version ETag like "12", not {if_match!r}')
    return int(m.group(1))


KGDep = Annotated[KnowledgeGraph, Depends(get_kg)]
AdvisorDep = Annotated[Advisor, Depends(get_advisor)]
SettingsDep = Annotated[Settings, Depends(get_settings)]
SessionsDep = Annotated[SessionStore, Depends(get_sessions)]
EditorDep = Annotated[Token, Depends(editor)]
IfMatchDep = Annotated[int | None, Depends(expected_version)]
