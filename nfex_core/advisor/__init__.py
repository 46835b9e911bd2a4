"""The advisor: one object that turns a frame and a context into a Selection (α*, Θ′ and why).

The flow's stages, in order (``pipeline.STAGES``): ``conditions`` → ``symbolic`` → ``params`` → ``budget`` →
``scoring`` → ``verification`` → ``answer``; ``advisor.Advisor`` runs them (``pipeline.PIPELINE``), ``selection``
holds what it answers.
"""
from __future__ import annotations

from .advisor import Advisor
from .scoring import FrameState
from .selection import CandidateEvidence, CandidateScore, ContextEntry, PrunedCandidate, Selection

__all__ = ["Advisor", "CandidateEvidence", "CandidateScore", "ContextEntry", "FrameState", "PrunedCandidate", "Selection"]
