"""The advisor: one object that turns a frame and a context into a Selection (α*, Θ′ and why)."""
from __future__ import annotations

from .advisor import Advisor, FrameState
from .selection import CandidateScore, ContextEntry, PrunedCandidate, Selection

__all__ = ["Advisor", "CandidateScore", "ContextEntry", "FrameState", "PrunedCandidate", "Selection"]
