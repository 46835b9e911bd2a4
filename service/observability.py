"""Structured (JSON) logs, Prometheus metrics and the request-size limit, as plain ASGI middleware."""
from __future__ import annotations

import asyncio
import json
import logging
import sys
import time
from collections.abc import Awaitable, Callable, MutableMapping
from typing import Any

from prometheus_client import CollectorRegistry, Counter, Gauge, Histogram

from nfex_core.errors import NfexError

from .images import PayloadTooLarge
from .problems import PROBLEM_JSON

Scope = MutableMapping[str, Any]
Message = MutableMapping[str, Any]
Receive = Callable[[], Awaitable[Message]]
Send = Callable[[Message], Awaitable[None]]
ASGIApp = Callable[[Scope, Receive, Send], Awaitable[None]]
log = logging.getLogger("nfex.access")


class JsonFormatter(logging.Formatter):
    def format(self, record: logging.LogRecord) -> str:
        doc: dict[str, Any] = {
            "time": self.formatTime(record, "%Y-%m-%dT%H:%M:%S") + f".{int(record.msecs):03d}Z",
            "level": record.levelname.lower(),
            "logger": record.name,
            "message": record.getMessage(),
        }
        doc.update(getattr(record, "fields", {}))
        if record.exc_info:
            doc["exception"] = self.formatException(record.exc_info)
        return json.dumps(doc, default=str)


def setup_logging(level: str, as_json: bool) -> None:
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(JsonFormatter() if as_json else logging.Formatter("%(asctime)s %(levelname)s %(name)s %(message)s"))
    logging.Formatter.converter = time.gmtime
    for name in ("nfex", "uvicorn", "uvicorn.error"):
        lg = logging.getLogger(name)
        lg.handlers = [handler]
        lg.propagate = False
        lg.setLevel(level.upper())
    logging.getLogger("uvicorn.access").disabled = True  # the middleware logs each request once, as JSON


class Metrics:
    def __init__(self) -> None:
        self.registry = CollectorRegistry()
        self.requests = Counter("nfex_http_requests_total", "HTTP requests", ["method", "route", "status"], registry=self.registry)
        self.latency = Histogram(
            "nfex_http_request_seconds", "HTTP request latency", ["method", "route"], registry=self.registry,
            buckets=(0.0005, 0.001, 0.002, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1, 2.5, 5, 10),
        )
        self.sparql_queries = Counter("nfex_sparql_queries_total", "SPARQL queries answered", ["form"], registry=self.registry)
        self.sessions = Gauge("nfex_sessions", "Open sessions", registry=self.registry)
        self.session_bytes = Gauge("nfex_session_state_bytes", "Memory held by sessions' previous frames", registry=self.registry)
        self.graph_version = Gauge("nfex_graph_version", "Graph version at head", registry=self.registry)


class BodyTimeout(NfexError):
    status = 408
    type = "body-timeout"
    title = "Request body timeout"
    exit_code = 2


class ServiceMiddleware:
    """Per request: refuse bodies over ``max_body_bytes`` (413) and bodies that stall longer than ``body_timeout_s``
    between parts (408), count and time it, log one JSON line."""

    def __init__(self, app: ASGIApp, *, metrics: Metrics, max_body_bytes: int, body_timeout_s: float = 30.0) -> None:
        self.app = app
        self.metrics = metrics
        self.max_body_bytes = max_body_bytes
        self.body_timeout_s = body_timeout_s

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        t0 = time.perf_counter()
        status = {"code": 500}
        limit = self.max_body_bytes
        headers = dict(scope.get("headers") or [])
        length = headers.get(b"content-length")

        async def send_wrapper(message: Message) -> None:
            if message["type"] == "http.response.start":
                status["code"] = message["status"]
            await send(message)

        async def reject() -> None:
            too_large = PayloadTooLarge(f"the request body exceeds the limit of {limit} bytes", limit=limit)
            body = json.dumps(too_large.problem()).encode()
            await send_wrapper({"type": "http.response.start", "status": too_large.status,
                                "headers": [(b"content-type", PROBLEM_JSON.encode()), (b"content-length", str(len(body)).encode()),
                                            (b"connection", b"close")]})
            await send({"type": "http.response.body", "body": body})

        try:
            if length is not None and (not length.isdigit() or int(length) > limit):
                await reject()
                return
            seen = {"n": 0, "done": 0}

            async def limited_receive() -> Message:
                if seen["done"]:  # the body is in: what comes now is a disconnect, whenever it comes
                    return await receive()
                try:  # a client that stalls mid-body holds a connection and a handler: not longer than this
                    message = await asyncio.wait_for(receive(), self.body_timeout_s)
                except TimeoutError:
                    raise BodyTimeout(f"the request body stalled: nothing arrived for {self.body_timeout_s:g} s",
                                      limit_s=self.body_timeout_s) from None
                if message["type"] == "http.request":
                    seen["done"] = int(not message.get("more_body", False))
                    seen["n"] += len(message.get("body", b""))
                    if seen["n"] > limit:
                        raise PayloadTooLarge(f"the request body exceeds the limit of {limit} bytes", limit=limit)
                return message

            await self.app(scope, limited_receive, send_wrapper)
        finally:
            elapsed = time.perf_counter() - t0
            route = scope.get("route")
            name = getattr(route, "path", None) or "unmatched"
            method = scope.get("method", "")
            self.metrics.requests.labels(method, name, str(status["code"])).inc()
            self.metrics.latency.labels(method, name).observe(elapsed)
            if log.isEnabledFor(logging.INFO):
                client = scope.get("client") or ("", 0)
                log.info("request", extra={"fields": {
                    "method": method, "path": scope.get("path"), "route": name, "status": status["code"],
                    "ms": round(elapsed * 1000, 3), "client": client[0]}})
