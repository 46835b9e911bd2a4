"""One stream's verification: the pair judge that every driver of the verification stage holds.

A stream (a service session, ``nfex evaluate``'s VO loop through ``AdvisorChooser``, a replay) verifies its frame
pairs with one ``PairJudge``, which holds everything the verdicts depend on:

- **the policy in force** for the frame being judged (``Policy``: checks compiled from the graph), with the
  frame's proposals and their expected ms, set by ``begin`` from the frame's selection;
- **the motion prior** (R_p, d_p): the estimate of the last pair it accepted whose median inlier parallax is at
  least ``STILL_PX`` (a step that translated); a fallback keeps it;
- **the budget window** (``budget.BudgetWindow``) where the client gave a budget: an escalation is offered only
  while the frame's expected ms stays within the per-frame cap and the mean over the window within the budget;
  otherwise the pair is decided on the tries made (``judge.judge`` with nothing remaining);
- whether the last final verdict **held α*** (accepted the first proposal), which lets a session reuse its
  decision (advisor/reuse.py).

After each try ``judge`` answers ``judge.judge``'s verdict under that state; a final verdict (accept or fall
back) updates the prior and closes the pair. The service's session state is this object
(service/sessions.py); the VO calls it through ``Proposals.judge``.
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
from nfex_slam.pairs import ACCEPT, NEXT, STILL_PX, PairEvidence, Prior, Verdict

from ..errors import NfexError
from ..evidence.cost import BudgetTerms
from ..rules.types import NO_POLICY, Policy
from .budget import BudgetWindow
from .judge import judge


class _Costed(Protocol):
    @property
    def expected_ms(self) -> float | None: ...


class Proposal(Protocol):
    """A candidate to try on the pair (``advisor.CandidateScore``)."""

    @property
    def extractor(self) -> str: ...

    @property
    def params(self) -> Mapping[str, Any]: ...

    @property
    def evidence(self) -> _Costed: ...


class Proposed(Protocol):
    """What a frame's answer gives the judge (``advisor.Selection``)."""

    @property
    def verification(self) -> Policy: ...

    @property
    def proposals(self) -> Sequence[Proposal]: ...

    @property
    def budget(self) -> Mapping[str, Any] | None: ...

    @property
    def reused(self) -> int: ...


class NoPairToJudge(NfexError):
    status = 409
    type = "no-pair-to-judge"
    title = "No frame pair awaits a verdict"
    exit_code = 2


@dataclass(frozen=True)
class _Pair:
    """The pair awaiting a verdict: the frame's policy, its proposals and the expected ms of each try."""

    policy: Policy
    proposals: tuple[Any, ...]
    costs: tuple[float, ...]


def given_budget(budget: Mapping[str, Any] | None) -> float | None:
    """The budget the client gave (ms), None without one; an agent's default budget shapes the candidates but opens
    no window."""
    return float(budget["ms"]) if budget is not None and budget.get("source") == "given" else None


class PairJudge:
    """A stream's verification state and its verdicts (module docstring)."""

    def __init__(self, terms: BudgetTerms | None = None) -> None:
        self.terms = terms or BudgetTerms()  # the graph's nfex:budgetWindow and nfex:verificationCap
        self.prior: Prior | None = None
        self.held = True  # the last final verdict accepted the first proposal (or there was none)
        self.window: BudgetWindow | None = None
        self._pair: _Pair | None = None
        self._frame_ms = 0.0  # the expected ms of the budgeted frame in progress (its tries so far)

    @property
    def pending(self) -> tuple[Any, ...] | None:
        """The proposals of the pair awaiting a verdict; None when none does."""
        return self._pair.proposals if self._pair is not None else None

    @property
    def policy(self) -> Policy:
        return self._pair.policy if self._pair is not None else NO_POLICY

    def begin(self, selection: Proposed) -> None:
        """The next frame's answer: its policy and proposals judge the pair (previous frame, this one). A new decision
        has not been judged yet (``held``). Under a given budget the last budgeted frame's expected ms is closed
        into the window (opened on the first)."""
        if not selection.reused:
            self.held = True
        policy, proposals = selection.verification, tuple(selection.proposals)
        budget_ms = given_budget(selection.budget) if policy.active else None
        costs: tuple[float, ...] = ()
        if budget_ms is not None:
            if self.window is None:
                self.window = BudgetWindow(budget_ms, self.terms.window, self.terms.verification_cap)
            else:
                self.window.budget_ms = budget_ms
                self.window.close(self._frame_ms)
            costs = tuple(BudgetWindow.try_cost(k, c.evidence.expected_ms) for k, c in enumerate(proposals))
            self._frame_ms = costs[0] if costs and math.isfinite(costs[0]) else 0.0
        self._pair = _Pair(policy, proposals, costs)

    def open(self, policy: Policy, proposals: Sequence[Any]) -> None:
        """A pair to judge under ``policy`` with ``proposals`` to try, without a budget (the verification learner's
        replay of the sweeps' pairs, sweeps/verification.py)."""
        self._pair = _Pair(policy, tuple(proposals), ())

    def judge(self, tried: Sequence[PairEvidence], remaining: int | None = None) -> Verdict:
        """The verdict after ``tried`` (the pair's estimates so far, in proposal order); ``remaining``: proposals not
        yet tried (default: those of ``begin`` past ``tried``). NoPairToJudge when no pair awaits one."""
        pair = self._pair
        if pair is None:
            raise NoPairToJudge("no frame pair awaits a verdict: the next frame's proposals come first (a pair is judged once)")
        n = len(tried)
        left = max(0, len(pair.proposals) - n if remaining is None else remaining)
        v = judge(pair.policy, tried, self.prior, left)
        if pair.costs:
            window = self.window
            assert window is not None
            if v.action == NEXT and not window.allows(sum(pair.costs[:n]), pair.costs[n] if n < len(pair.costs) else math.inf):
                v = judge(pair.policy, tried, self.prior, 0)  # the next candidate does not fit: decide on what was tried
            self._frame_ms = sum(c for c in pair.costs[: n + (v.action == NEXT)] if math.isfinite(c))
        if v.action != NEXT:
            self._close(tried, v)
        return v

    def __call__(self, tried: list[PairEvidence], remaining: int) -> Verdict:
        """The VO's judge (``nfex_slam.vo.Proposals.judge``)."""
        return self.judge(tried, remaining)

    def _close(self, tried: Sequence[PairEvidence], v: Verdict) -> None:
        self._pair = None
        self.held = v.action == ACCEPT and v.accepted == 0
        if v.action == ACCEPT and v.accepted is not None:
            e = tried[v.accepted]
            if e.parallax_px >= STILL_PX and e.estimated:
                self.prior = Prior(e.matrix(), np.asarray(e.direction, dtype=float))
