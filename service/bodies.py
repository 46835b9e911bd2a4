"""Reading a request body: its media type and its text."""
from __future__ import annotations

from fastapi import Request

from nfex_core.errors import BadInput


def media_type(content_type: str | None) -> str:
    """``type/subtype`` of a Content-Type header, lower case, without parameters ('' when absent)."""
    return (content_type or "").split(";")[0].strip().lower()


async def utf8_text(request: Request, what: str) -> str:
    """The body as text; a body that is not UTF-8 is a 400 naming ``what`` it should have been."""
    try:
        return (await request.body()).decode("utf-8")
    except UnicodeDecodeError as e:
        raise BadInput(f"{what} is not UTF-8: {e}") from e
