"""HEAD and OPTIONS on every resource, and a true ``Allow`` header (RFC 9110 §9.3.2, §9.3.7, §10.2.1).

FastAPI routes answer only the methods they declare, and a path served by several routes (``GET`` and
``POST /sparql``) answered 405 with the first route's methods alone. Here:

- ``allowed(app, scope)`` is every method some route accepts at the request's path, plus ``HEAD`` where
  ``GET`` is and ``OPTIONS`` everywhere; the 405 handler (service/problems.py) sends it as ``Allow``;
- ``OPTIONS`` on a known path is 204 with that ``Allow`` (a CORS middleware, if one is installed outside
  this one, answers preflight requests before they get here);
- ``HEAD`` runs the ``GET`` route and sends its status and headers (Content-Length included) without the body.
"""
from __future__ import annotations

import re
import weakref
from collections.abc import Iterable
from typing import Any

import fastapi.routing
from starlette.routing import compile_path, get_route_path
from starlette.types import ASGIApp, Message, Receive, Scope, Send

ORDER = ("GET", "HEAD", "POST", "PUT", "PATCH", "DELETE", "OPTIONS")
_TABLES: weakref.WeakKeyDictionary[Any, list[tuple[re.Pattern[str], frozenset[str]]]] = weakref.WeakKeyDictionary()


def _flat_routes(app: Any) -> Iterable[Any]:
    """The app's routes, included routers flattened (FastAPI ≥ 0.160 nests them; its iterator unnests)."""
    unnest = getattr(fastapi.routing, "iter_route_contexts", None)
    return unnest(app.routes) if unnest is not None else app.routes


def _table(app: Any) -> list[tuple[re.Pattern[str], frozenset[str]]]:
    """(path regex, methods) per route, built once per app; a mount (static files) serves GET and HEAD."""
    table = _TABLES.get(app)
    if table is None:
        table = []
        for route in _flat_routes(app):
            path, methods = getattr(route, "path", None), getattr(route, "methods", None)
            if not path:
                continue
            if methods:
                table.append((compile_path(path)[0], frozenset(methods)))
            else:
                table.append((compile_path(path.rstrip("/") + "/{rest:path}")[0], frozenset({"GET", "HEAD"})))
        _TABLES[app] = table
    return table


def declared(app: ASGIApp, scope: Scope) -> set[str]:
    """The methods the routes at ``scope``'s path declare."""
    path = get_route_path(scope)
    return {m for regex, methods in _table(app) if regex.match(path) for m in methods}


def allowed(app: ASGIApp, scope: Scope) -> list[str]:
    """``declared`` plus HEAD where GET is and OPTIONS; empty for a path no route serves."""
    methods = declared(app, scope)
    if not methods:
        return []
    methods.add("OPTIONS")
    if "GET" in methods:
        methods.add("HEAD")
    return sorted(methods, key=lambda m: ORDER.index(m) if m in ORDER else len(ORDER))


class MethodsMiddleware:
    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http" or scope["method"] not in ("HEAD", "OPTIONS"):
            await self.app(scope, receive, send)
            return
        app = scope["app"]
        methods = declared(app, scope)
        if not methods or scope["method"] in methods:
            await self.app(scope, receive, send)  # 404, or a route that handles the method itself
            return
        if scope["method"] == "OPTIONS":
            allow = ", ".join(allowed(app, scope)).encode()
            await send({"type": "http.response.start", "status": 204, "headers": [(b"allow", allow)]})
            await send({"type": "http.response.body", "body": b""})
            return
        if "GET" not in methods:
            await self.app(scope, receive, send)  # 405 with Allow
            return
        inner = dict(scope, method="GET")

        async def headers_only(message: Message) -> None:
            if message["type"] == "http.response.body":
                message = {**message, "body": b""}
            await send(message)

        try:
            await self.app(inner, receive, headers_only)
        finally:
            if "route" in inner:
                scope["route"] = inner["route"]  # for the access log and metrics outside
