"""Whether an extractor backend can run in this process (``vision.backends``), and if not, why."""
from __future__ import annotations

from dataclasses import dataclass

from ..errors import ModelUnavailable


@dataclass(frozen=True)
class Availability:
    """Whether a backend can run in this process; if not, why and what to change (``setting``)."""

    ok: bool
    detail: str
    setting: str = ""

    def require(self) -> None:
        if not self.ok:
            raise ModelUnavailable(self.detail, setting=self.setting)
