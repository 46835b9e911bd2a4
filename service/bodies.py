"""Reading a request body: its media type, its text, and JSON held to RFC 8259 before any handler reads it.

Python's ``json`` (and so FastAPI's body parsing) reads more than JSON: ``NaN``, ``Infinity``, numbers that
overflow to infinity, integers of thousands of digits, nesting deep enough to exhaust the interpreter's
recursion, and ``\\ud800``-style escapes that decode to lone surrogates, which no UTF-8 encoder can write back
(a store, a log line, a problem+json body that echoes them). ``strict_json`` refuses all of these with a 400
that names where it found them; ``JsonBodyGuard`` applies it to every JSON request body before routing, and
the multipart ``context`` part goes through it in service/frames.py.
"""
from __future__ import annotations

import json
import math
from typing import TYPE_CHECKING, Any

from fastapi import Request

from nfex_core.errors import BadInput, NfexError

if TYPE_CHECKING:
    from .observability import ASGIApp, Message, Receive, Scope, Send

MAX_INT_DIGITS = 30


def media_type(content_type: str | None) -> str:
    """``type/subtype`` of a Content-Type header, lower case, without parameters ('' when absent)."""
    return (content_type or "").split(";")[0].strip().lower()


async def utf8_text(request: Request, what: str) -> str:
    """The body as text; a body that is not UTF-8 is a 400 naming ``what`` it should have been."""
    try:
        return (await request.body()).decode("utf-8")
    except UnicodeDecodeError as e:
        raise BadInput(f"{what} is not UTF-8: {e}") from e


class NotJson(BadInput):
    """JSON that Python would read but RFC 8259 does not allow, or that no handler can hold."""


class Malformed(NotJson):
    """Not JSON at all: the route that reads the body answers it as it always does."""


def _constant(name: str) -> float:
    raise NotJson(f"{name} is not a JSON number (RFC 8259); send a finite number or null")


def _float(text: str) -> float:
    value = float(text)
    if not math.isfinite(value):
        raise NotJson(f"the number {text[:40]} overflows a double; send a finite number")
    return value


def _int(text: str) -> int:
    if len(text.lstrip("-")) > MAX_INT_DIGITS:
        raise NotJson(f"an integer of {len(text.lstrip('-'))} digits; the limit is {MAX_INT_DIGITS}")
    return int(text)


def strict_json(data: str | bytes, what: str = "the body") -> Any:
    """``data`` parsed as RFC 8259 JSON, or NotJson (400) saying what was wrong and where."""
    try:
        value = json.loads(data, parse_constant=_constant, parse_float=_float, parse_int=_int)
    except NotJson as e:
        raise NotJson(f"{what}: {e.detail}") from None
    except RecursionError:
        raise NotJson(f"{what} is nested too deeply to read") from None
    except (json.JSONDecodeError, UnicodeDecodeError) as e:
        raise Malformed(f"{what} is not valid JSON: {e}") from None
    _no_surrogates(value, what)
    return value


def _no_surrogates(value: Any, what: str) -> None:
    stack: list[tuple[Any, str]] = [(value, "")]
    while stack:
        item, path = stack.pop()
        if isinstance(item, str):
            _check_text(item, f"{what}{path}")
        elif isinstance(item, dict):
            for k, v in item.items():
                _check_text(k, f"a key in {what}{path}")
                stack.append((v, f"{path}.{_printable(k)}"))
        elif isinstance(item, list):
            stack.extend((v, f"{path}[{i}]") for i, v in enumerate(item))


def _check_text(text: str, where: str) -> None:
    try:
        text.encode("utf-8")
    except UnicodeEncodeError:
        raise NotJson(f"{where} holds a lone surrogate (an unpaired \\ud800–\\udfff escape), which is no character") from None


def _printable(text: str) -> str:
    return text.encode("utf-8", "replace").decode("utf-8")[:60]


def is_json(content_type: str | None) -> bool:
    media = media_type(content_type)
    return media == "application/json" or media.endswith("+json")


class JsonBodyGuard:
    """Refuse, before routing, a JSON request body that ``strict_json`` refuses (400 problem+json); pass the
    rest on unchanged."""

    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        headers = dict(scope.get("headers") or [])
        if not is_json(headers.get(b"content-type", b"").decode("latin-1")):
            await self.app(scope, receive, send)
            return
        from .security import send_problem

        chunks: list[bytes] = []
        try:
            while True:
                message = await receive()  # the outer middleware's: over the size limit or stalled, it raises
                if message["type"] != "http.request":
                    break
                chunks.append(message.get("body", b""))
                if not message.get("more_body", False):
                    break
            body = b"".join(chunks)
            if body.strip():
                strict_json(body)
        except Malformed:
            pass  # the route's own reading answers it (a 400, or a 415 for a body that is not of its type)
        except NfexError as e:
            await send_problem(send, e, [(b"connection", b"close")] if e.status in (408, 413) else None)
            return
        replayed = False

        async def replay() -> Message:
            nonlocal replayed
            if not replayed:
                replayed = True
                return {"type": "http.request", "body": body, "more_body": False}
            return await receive()

        await self.app(scope, replay, send)
