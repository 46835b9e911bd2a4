"""The order the scoring stage lists candidates in: α* first, then the proposals a verifying client tries.

α* = argmax score; among equal scores the cheaper candidate wins — its expected extraction time under the
budget where one is in force, else its measured mean extraction time (unknown: last). The candidates
are listed best first: the order in which a verifying client (or the VO) tries them.
"""
from __future__ import annotations

import math

from ..rules.types import Decision
from .selection import CandidateScore


def cost_of(decision: Decision, c: CandidateScore) -> float:
    """The tie-break: the budget's expected time where known, else the measured mean extraction time."""
    if c.evidence.expected_ms is not None:
        return c.evidence.expected_ms
    e = decision.evidence.get(c.extractor)
    return e.extraction_ms if e is not None and e.extraction_ms is not None else math.inf


def ranked(decision: Decision, candidates: list[CandidateScore]) -> list[CandidateScore]:
    """``candidates`` best first: by score (unscored last), then by cost."""
    return sorted(candidates, key=lambda c: (-(c.score if c.score is not None else -math.inf), cost_of(decision, c)))
