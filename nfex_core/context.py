"""One dimension of a request's context E: its value, where it came from and how sure that is.

Shared by context estimation (``vision.context``, which fills what the client did not give from the
frame) and the advisor's answer (``advisor.selection.Selection.context``); it imports neither OpenCV
nor the advisor, so either side can use it.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class ContextEntry:
    dimension: str
    value: str | None
    source: str  # "given" | "estimated" | "unknown"
    confidence: float | None = None
    evidence: str | None = None  # what an estimate was based on

    def as_dict(self) -> dict[str, Any]:
        return {k: v for k, v in self.__dict__.items() if v is not None or k == "value"}
