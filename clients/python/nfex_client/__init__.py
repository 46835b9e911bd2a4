"""nfex-client: a typed HTTP client for the nFEX service (sync ``NfexClient``, async ``AsyncNfexClient``).

Problem+json answers become exceptions (``nfex_client.errors``); ``extractor_from_selection`` builds the
OpenCV extractor a selection names.

>>> from nfex_client import NfexClient, extractor_from_selection          # doctest: +SKIP
>>> with NfexClient("http://127.0.0.1:8000") as nfex:                     # doctest: +SKIP
...     sel = nfex.select({"agent": "car", "light": "dark"}, frame=image)
...     orb = extractor_from_selection(sel)
"""
from __future__ import annotations

from .client import AsyncNfexClient, NfexClient
from .errors import (
    BadRequest,
    Conflict,
    Forbidden,
    NfexClientError,
    NotFound,
    PayloadTooLarge,
    PreconditionFailed,
    ServiceUnavailable,
    TooManyRequests,
    Unauthorized,
    Unprocessable,
    UnsupportedMediaType,
)
from .opencv import GridSpread, extractor_from_selection, matcher_from_selection, spread_keypoints
from .schema import Selection, SessionSelection, WriteResult

__all__ = [
    "AsyncNfexClient", "NfexClient", "Selection", "SessionSelection", "WriteResult", "extractor_from_selection",
    "matcher_from_selection", "GridSpread", "spread_keypoints",
    "NfexClientError", "BadRequest", "Unauthorized", "Forbidden", "NotFound", "Conflict", "PreconditionFailed",
    "PayloadTooLarge", "UnsupportedMediaType", "Unprocessable", "TooManyRequests", "ServiceUnavailable",
]
__version__ = "0.1.0"
