"""Who may do what: bearer tokens with roles, tokens kept out of URLs, and CORS for reads only.

Roles are ordered, each including the ones before it (docs/service.md, "Roles"):

| role       | may                                                                       |
|------------|---------------------------------------------------------------------------|
| (none)     | read: select, sessions, SPARQL queries, the vocabulary, versions, health   |
| `reader`   | the same (a named token for clients that should be told apart in logs)     |
| `reporter` | + report feedback (``POST /v1/feedback``), attributed to the token's name  |
| `editor`   | + every write: SPARQL Update, REST edits, programs, rollback, accepting reports |

``NFEX_TOKENS="name:token:role,…"`` (service/config.py). A request's token is compared with every
configured token in constant time (HMAC-compare of SHA-256 digests, all tokens compared, so neither
the position nor the length of a match leaks). A token in the query string is refused before routing
(RFC 6750 §2.3's ``access_token``, or any configured secret as a query value): URLs end up in proxy logs
and browser history, so the answer also says to rotate it.
"""
from __future__ import annotations

import hashlib
import hmac
import json
from collections.abc import Awaitable, Callable, Iterable
from typing import Annotated, Any
from urllib.parse import parse_qsl

from fastapi import Depends, Request
from fastapi.security import HTTPAuthorizationCredentials, HTTPBearer

from nfex_core.errors import BadInput, NfexError

from .config import ROLES, Token
from .observability import ASGIApp, Message, Receive, Scope, Send
from .problems import PROBLEM_JSON, printable


class Unauthorized(NfexError):
    status = 401
    type = "unauthorized"
    title = "Unauthorized"
    exit_code = 2
    headers = {"WWW-Authenticate": 'Bearer realm="nfex"'}


class Forbidden(NfexError):
    status = 403
    type = "forbidden"
    title = "Forbidden"
    exit_code = 2


class TokenInUrl(BadInput):
    type = "token-in-url"
    title = "Token in the URL"


def _digest(secret: str) -> bytes:
    return hashlib.sha256(secret.encode("utf-8", "surrogatepass")).digest()


class TokenBook:
    """The configured tokens, looked up in constant time."""

    def __init__(self, tokens: Iterable[Token]) -> None:
        self._entries = [(_digest(t.secret), t) for t in tokens]

    def __len__(self) -> int:
        return len(self._entries)

    def find(self, given: str) -> Token | None:
        probe = _digest(given)
        found = None
        for digest, token in self._entries:  # no early exit: every entry is compared
            if hmac.compare_digest(digest, probe):
                found = token
        return found

    def any_secret_in(self, values: Iterable[str]) -> bool:
        return any(self.find(v) is not None for v in values)


def rank(role: str) -> int:
    return ROLES.index(role)


# The OpenAPI security scheme (HTTP bearer, RFC 6750): a route whose dependencies reach it lists it in its
# ``security``; auto_error is off so that a missing or malformed header is our own 401 problem+json.
SCHEME = HTTPBearer(
    scheme_name="bearer", auto_error=False,
    description="A token from NFEX_TOKENS (name:token:role). Reads are open; feedback needs the reporter role, "
                "every other write the editor role.",
)


def token_of(request: Request) -> tuple[bool, Token | None]:
    """(whether ``Authorization`` is a well-formed ``Bearer <token>``, the valid token it names or None)."""
    scheme, _space, given = (request.headers.get("authorization") or "").strip().partition(" ")
    if scheme.lower() != "bearer" or not given.strip():
        return False, None
    book: TokenBook = request.app.state.tokens
    return True, book.find(given.strip())


async def bearer(request: Request, _: Annotated[HTTPAuthorizationCredentials | None, Depends(SCHEME)]) -> Token | None:
    """The token behind ``Authorization: Bearer <token>``; None without the header; 401 when it is not valid."""
    if not request.headers.get("authorization"):
        return None
    well_formed, found = token_of(request)
    if not well_formed:
        raise Unauthorized("the Authorization header must be 'Bearer <token>'")
    if found is None:
        raise Unauthorized("the bearer token is not valid")
    return found


def require(role: str, what: str) -> Callable[..., Awaitable[Token]]:
    """A dependency that returns the request's token when it has ``role`` or a higher one."""

    async def dependency(token: Annotated[Token | None, Depends(bearer)]) -> Token:
        if token is None:
            raise Unauthorized(f"{what} needs 'Authorization: Bearer <token>' with the {role} role (NFEX_TOKENS)")
        if rank(token.role) < rank(role):
            raise Forbidden(f"{token.name} has role {token.role!r}; {what} needs {role!r} or higher")
        return token

    dependency.__name__ = f"require_{role}"
    return dependency


def _problem_body(error: NfexError) -> bytes:
    return json.dumps(printable(error.problem())).encode()


async def send_problem(send: Send, error: NfexError, headers: list[tuple[bytes, bytes]] | None = None) -> None:
    body = _problem_body(error)
    await send({"type": "http.response.start", "status": error.status,
                "headers": [(b"content-type", PROBLEM_JSON.encode()), (b"content-length", str(len(body)).encode()),
                            *(headers or [])]})
    await send({"type": "http.response.body", "body": body})


class TokenInUrlGuard:
    """Refuse, before routing, a request that carries a token in its query string."""

    def __init__(self, app: ASGIApp, *, tokens: Callable[[], TokenBook | None]) -> None:
        self.app = app
        self.tokens = tokens

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] == "http" and scope.get("query_string"):
            pairs = parse_qsl(scope["query_string"].decode("latin-1"), keep_blank_values=True)
            book = self.tokens()
            if any(k.lower() == "access_token" for k, _ in pairs) or (book is not None and book.any_secret_in(v for _, v in pairs)):
                await send_problem(send, TokenInUrl(
                    "tokens go in the 'Authorization: Bearer <token>' header, never in the URL (it ends up in logs and "
                    "browser history); treat this token as exposed and have it rotated"))
                return
        await self.app(scope, receive, send)


READ_POSTS = ("/v1/select", "/sparql")
READ_METHODS = ("GET", "HEAD")


def is_read(method: str, path: str) -> bool:
    """Reads change nothing: every GET/HEAD, and the POST forms of selection and SPARQL queries."""
    return method in READ_METHODS or (method == "POST" and path in READ_POSTS)


class ReadOnlyCORS:
    """CORS (Fetch standard) for browser tools on the configured origins, on read endpoints only.

    A preflight (``OPTIONS`` with ``Origin`` and ``Access-Control-Request-Method``) for a read is answered
    here (204); for a write it is refused here (403, saying why), and writes never get CORS headers, so a
    page on another origin can never send one with a token."""

    def __init__(self, app: ASGIApp, *, origins: tuple[str, ...], max_age_s: int = 600) -> None:
        self.app = app
        self.origins = origins
        self.max_age_s = max_age_s

    def _allowed(self, origin: str | None) -> str | None:
        if origin is None or not self.origins:
            return None
        if "*" in self.origins:
            return "*"
        return origin if origin in self.origins else None

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        headers = {k.decode("latin-1").lower(): v.decode("latin-1") for k, v in scope.get("headers") or []}
        allow = self._allowed(headers.get("origin"))
        path, method = scope.get("path", ""), scope.get("method", "")
        if allow and method == "OPTIONS" and "access-control-request-method" in headers:
            wanted = headers["access-control-request-method"].upper()
            if is_read(wanted, path):
                methods = ", ".join(m for m in ("GET", "HEAD", "POST") if is_read(m, path))
                await send({"type": "http.response.start", "status": 204, "headers": [
                    (b"access-control-allow-origin", allow.encode()), (b"vary", b"Origin"),
                    (b"access-control-allow-methods", methods.encode()),
                    (b"access-control-allow-headers", b"Content-Type, Accept"),
                    (b"access-control-max-age", str(self.max_age_s).encode())]})
                await send({"type": "http.response.body", "body": b""})
                return
        if method == "OPTIONS" and "origin" in headers and "access-control-request-method" in headers \
                and not is_read(headers["access-control-request-method"].upper(), path):
            await send_problem(send, Forbidden(
                f"cross-origin {headers['access-control-request-method'].upper()} {path} is not allowed: CORS covers reads "
                "only (GET, HEAD, POST /v1/select, POST /sparql); send writes from a server or the same origin"))
            return
        if not allow or not is_read(method, path):
            await self.app(scope, receive, send)
            return

        async def with_cors(message: Message) -> None:
            if message["type"] == "http.response.start":
                message = {**message, "headers": [*message.get("headers", []), (b"access-control-allow-origin", allow.encode()),
                                                  (b"vary", b"Origin"), (b"access-control-expose-headers", b"ETag, X-Query-Ms")]}
            await send(message)

        await self.app(scope, receive, with_cors)


def problem_headers(exc: Any) -> dict[str, str]:
    """Headers an error asks for (``WWW-Authenticate`` on a 401)."""
    return dict(getattr(exc, "headers", None) or {})
