"""A frame pair as a verifier sees it: what each candidate's estimate showed, the motion prior, and the verdict.

The VO (``nfex_slam.vo``) tries a frame's proposals in order; after each try a judge — the service's
``POST /v1/sessions/{id}/verdict``, or a ``nfex_core.verification.PairJudge`` in process — answers a Verdict:
accept a try, try the next proposal, or fall back to the motion prior, which the judge keeps. These types are the
VO's side of that conversation; the policy and the signals are the service's (nfex_core/verification/judge.py has
the formulas).
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from .motion import motion_direction


class Cited(Protocol):
    """The statement a verdict cites (nfex_core.rules.types.Citation)."""

    def as_dict(self) -> dict[str, Any]: ...


ACCEPT, NEXT, FALLBACK = "accept", "next", "fallback"
STILL_PX = 0.5  # px: a step whose median inlier parallax is below this did not translate (vo.VOParams default)


@dataclass
class PairEvidence:
    """What one candidate's estimate of a frame pair showed (a client reports these over HTTP)."""

    extractor: str
    params: dict[str, Any] = field(default_factory=dict)
    keypoints: int = 0
    matches: int = 0
    inliers: int = 0
    parallax_px: float = 0.0
    extraction_ms: float = 0.0
    rotation: tuple[float, float, float] | None = None  # rotation vector (rad) of R; None: no estimate
    direction: tuple[float, float, float] | None = None  # unit direction of motion d = −Rᵀt
    rejected: str = ""  # why the front-end checks or the geometry lost it ("" if they did not)

    @property
    def estimated(self) -> bool:
        return self.rotation is not None and self.direction is not None and not self.rejected

    def matrix(self) -> np.ndarray:
        import cv2

        R, _ = cv2.Rodrigues(np.asarray(self.rotation, dtype=float).reshape(3, 1))
        return np.asarray(R, dtype=float)

    @classmethod
    def of(cls, extractor: str, params: Mapping[str, Any], R: np.ndarray | None, t: np.ndarray | None,
           **measured: Any) -> PairEvidence:
        """From an estimate (R, unit t) as the VO makes it (None: the pair was lost)."""
        rotation = direction = None
        if R is not None and t is not None:
            import cv2

            v, _ = cv2.Rodrigues(np.asarray(R, dtype=float))
            rotation = (float(v[0, 0]), float(v[1, 0]), float(v[2, 0]))
            d = motion_direction(R, t)
            direction = (float(d[0]), float(d[1]), float(d[2]))
        return cls(extractor, dict(params), rotation=rotation, direction=direction, **measured)


@dataclass(frozen=True)
class Prior:
    """The motion so far: the last accepted step that translated, (R_p, d_p)."""

    R: np.ndarray
    direction: np.ndarray


@dataclass(frozen=True)
class Verdict:
    """The decision after the tries so far. ``action``: accept | next | fallback; ``accepted``: the index
    of the accepted try; ``because``: the accept statement that held (or why the pair fell back)."""

    action: str
    accepted: int | None = None
    because: Cited | None = None
    reason: str = ""
    shown: tuple[dict[str, float | None], ...] = ()  # each try's signals

    def as_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {"action": self.action, "reason": self.reason}
        if self.accepted is not None:
            out["accepted"] = self.accepted
        if self.because is not None:
            out["because"] = self.because.as_dict()
        out["signals"] = [{k: (round(v, 4) if v is not None else None) for k, v in s.items()} for s in self.shown]
        return out
