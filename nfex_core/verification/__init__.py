"""The verification stage: per frame pair, accept a candidate's estimate, try the next one, or fall back to the
motion prior (DESIGN.md's flow, after scoring).

- ``judge``: the signals of a pair's estimates and the verdict under a policy (the formulas);
- ``budget``: the budget window that bounds escalations under a client's budget;
- ``stream``: ``PairJudge``, one stream's verification state — the policy in force, the motion prior, the budget
  window — which the service's sessions, ``nfex evaluate`` (and through it the VO), and the verification learner
  all judge with.
"""
from __future__ import annotations

from .budget import BudgetWindow
from .judge import LOST_PAIR_DEG, judge, signals
from .stream import NoPairToJudge, PairJudge, given_budget

__all__ = ["LOST_PAIR_DEG", "BudgetWindow", "NoPairToJudge", "PairJudge", "given_budget", "judge", "signals"]
