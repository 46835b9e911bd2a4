"""The budget window of a verified stream: a budget B as a mean over W frames with a per-frame cap of C·B.

Under a budget a frame pair may escalate to candidates the budget alone would prune (``nfex:verificationCap``
budgets a frame), as long as the mean over the last ``nfex:budgetWindow`` frames stays within B. Costs are the
cost model's expected ms (``CandidateEvidence.expected_ms``), never the measured ones, so a run's choices do not
depend on how busy the machine is. The stream's pair judge (``stream.PairJudge``) holds one window.
"""
from __future__ import annotations

import math
from collections import deque


class BudgetWindow:
    """A budget B as a mean over W frames with a per-frame cap of C·B (``nfex:budgetWindow``,
    ``nfex:verificationCap``): a pair may try a further candidate when the frame's expected ms so far plus that
    try's stays within C·B and the mean over the last W − 1 frames and this one within B:

        allows(s, c)  ⇔  s + c ≤ C·B  and  (Σ spent + s + c) / (|spent| + 1) ≤ B

    A try other than the first costs twice its expected ms (the previous frame must be extracted with it too)."""

    def __init__(self, budget_ms: float, window: int, cap: float) -> None:
        self.budget_ms, self.window, self.cap = budget_ms, max(1, window), max(1.0, cap)
        self.spent: deque[float] = deque(maxlen=self.window - 1)

    @staticmethod
    def try_cost(k: int, expected_ms: float | None) -> float:
        """The expected ms of the k-th try (from 0) of a pair; inf where the cost is unknown (never affordable)."""
        if expected_ms is None or not math.isfinite(expected_ms):
            return math.inf
        return expected_ms if k == 0 else 2.0 * expected_ms

    def allows(self, so_far_ms: float, try_ms: float) -> bool:
        frame = so_far_ms + try_ms
        if not math.isfinite(frame) or frame > self.cap * self.budget_ms:
            return False
        return (sum(self.spent) + frame) / (len(self.spent) + 1) <= self.budget_ms

    def close(self, frame_ms: float) -> None:
        """A frame is done: it spent ``frame_ms`` (expected)."""
        if self.spent.maxlen:
            self.spent.append(frame_ms)
