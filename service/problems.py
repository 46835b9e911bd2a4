"""Every error as RFC 9457 problem+json, rendered in one place."""
from __future__ import annotations

import logging
import math
from typing import Any

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from starlette.exceptions import HTTPException as StarletteHTTPException

from nfex_core.errors import PROBLEM_BASE, NfexError

from .methods import allowed
from .schemas.problems import PROBLEM_JSON

log = logging.getLogger("nfex.service")


def problem(status: int, type_: str, title: str, detail: str, **extra: object) -> JSONResponse:
    body = {"type": PROBLEM_BASE + type_, "title": title, "status": status, "detail": detail, **extra}
    return render(body, status)


def printable(value: Any, depth: int = 0) -> Any:
    """``value`` with every string writable as UTF-8 (a lone surrogate becomes U+FFFD) and non-finite numbers
    as null: a problem echoes what the client sent, and echoing it must not fail."""
    if isinstance(value, str):
        return value.encode("utf-8", "replace").decode("utf-8")
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if depth > 20:
        return None
    if isinstance(value, dict):
        return {printable(str(k)): printable(v, depth + 1) for k, v in value.items()}
    if isinstance(value, list | tuple | set | frozenset):
        return [printable(v, depth + 1) for v in value]
    if value is None or isinstance(value, bool | int):
        return value
    return printable(str(value))


def render(body: dict[str, Any], status: int, headers: dict[str, str] | None = None) -> JSONResponse:
    """The problem+json response for ``body``; it cannot fail on what the body echoes."""
    try:
        return JSONResponse(printable(body), status_code=status, media_type=PROBLEM_JSON, headers=headers)
    except Exception:  # the last resort: a fixed body that says where to look
        log.exception("rendering a problem failed")
        return JSONResponse({"type": PROBLEM_BASE + "internal-error", "title": "Internal error", "status": 500,
                             "detail": "the error could not be rendered; see the service log"}, status_code=500,
                            media_type=PROBLEM_JSON)


def install(app: FastAPI) -> None:
    @app.exception_handler(NfexError)
    async def _nfex(request: Request, exc: NfexError) -> JSONResponse:
        if exc.status >= 500:
            log.warning("%s %s: %s", request.method, request.url.path, exc.detail)
        return render(exc.problem(), exc.status, dict(getattr(exc, "headers", None) or {}))

    @app.exception_handler(RequestValidationError)
    async def _validation(request: Request, exc: RequestValidationError) -> JSONResponse:
        errors = [{"loc": list(e.get("loc", ())), "msg": e.get("msg", "")} for e in exc.errors()]
        first = errors[0] if errors else {"loc": [], "msg": "invalid request"}
        detail = f"{'.'.join(str(x) for x in first['loc'])}: {first['msg']}"
        return problem(422, "invalid-request", "Invalid request", detail, errors=errors)

    @app.exception_handler(StarletteHTTPException)
    async def _http(request: Request, exc: StarletteHTTPException) -> JSONResponse:
        titles = {404: "Not found", 405: "Method not allowed", 413: "Payload too large", 415: "Unsupported media type"}
        title = titles.get(exc.status_code, str(exc.detail))
        detail = str(exc.detail)
        if exc.status_code == 404 and detail == "Not Found":
            detail = f"no resource at {request.url.path}; GET /docs lists the API"
        elif exc.status_code == 405:
            detail = f"{request.method} is not allowed on {request.url.path}"
        resp = problem(exc.status_code, "http-" + str(exc.status_code), title, detail)
        for k, v in (exc.headers or {}).items():
            resp.headers[k] = v
        if exc.status_code == 405:  # every method of every route at this path, not the first route's
            resp.headers["Allow"] = ", ".join(allowed(request.app, request.scope))
        return resp

    @app.exception_handler(Exception)
    async def _internal(request: Request, exc: Exception) -> JSONResponse:
        log.exception("unhandled error on %s %s", request.method, request.url.path)
        return problem(500, "internal-error", "Internal error", f"{type(exc).__name__}; see the service log")
