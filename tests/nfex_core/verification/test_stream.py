"""A stream's pair judge (nfex_core/verification/stream.py): the motion prior it keeps, whether α* held, the pair
judged once, and the budget window's bound on escalations (a property over random streams)."""
from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from nfex_slam.pairs import ACCEPT, FALLBACK, NEXT, PairEvidence

from nfex_core.evidence.cost import BudgetTerms
from nfex_core.rules.types import AcceptRule, Citation, PairTest, Policy
from nfex_core.verification import NoPairToJudge, PairJudge, given_budget

CITE = Citation("urn:accept", "accept pair if agreement <= 2", "", "accept")
AGREE = Policy((AcceptRule((PairTest("agreement", "<=", 2.0),), (), CITE),), 3)
NEVER = Policy((AcceptRule((PairTest("inliers", ">=", 1e9),), (), CITE),), 3)  # always escalates


@dataclass(frozen=True)
class _Costs:
    expected_ms: float | None


@dataclass(frozen=True)
class _Candidate:
    extractor: str
    params: Mapping[str, Any]
    evidence: _Costs


@dataclass(frozen=True)
class _Selection:
    verification: Policy
    proposals: tuple[_Candidate, ...]
    budget: Mapping[str, Any] | None = None
    reused: int = 0


def _frame(policy: Policy, costs: list[float | None], budget_ms: float | None = None, reused: int = 0) -> _Selection:
    names = ("ORB", "SIFT", "AKAZE", "BRISK")
    budget = {"ms": budget_ms, "source": "given"} if budget_ms is not None else None
    return _Selection(policy, tuple(_Candidate(names[k], {}, _Costs(c)) for k, c in enumerate(costs)), budget, reused)


def _yaw(deg: float, extractor: str = "ORB", parallax: float = 8.0) -> PairEvidence:
    a = math.radians(deg)
    R = np.array([[math.cos(a), 0, math.sin(a)], [0, 1, 0], [-math.sin(a), 0, math.cos(a)]])
    return PairEvidence.of(extractor, {}, R, np.array([0.0, 0.0, -1.0]), parallax_px=parallax, inliers=100)


def test_an_accepted_translating_estimate_becomes_the_prior_and_a_fallback_keeps_it() -> None:
    pj = PairJudge()
    pj.begin(_frame(AGREE, [1.0, 1.0]))
    assert pj.judge([_yaw(1.0)]).action == NEXT  # nothing vouches for one estimate yet
    v = pj.judge([_yaw(1.0), _yaw(1.2, "SIFT")])
    assert v.action == ACCEPT and v.accepted == 0 and pj.held and pj.pending is None
    assert pj.prior is not None and np.allclose(pj.prior.R, _yaw(1.0).matrix())
    prior = pj.prior
    with pytest.raises(NoPairToJudge):
        pj.judge([_yaw(1.0)])  # a pair is judged once
    pj.begin(_frame(AGREE, [1.0, 1.0]))
    assert pj.judge([_yaw(40.0)]).action == NEXT
    assert pj.judge([_yaw(40.0), _yaw(90.0, "SIFT")]).action == FALLBACK
    assert pj.prior is prior and not pj.held  # the fallback kept the prior and rejected α*
    pj.begin(_frame(AGREE, [1.0, 1.0], reused=1))
    assert not pj.held  # a carried decision stays rejected until a verdict holds it
    pj.begin(_frame(AGREE, [1.0, 1.0]))
    assert pj.held  # a new decision: not judged yet


def test_a_still_pair_is_accepted_without_becoming_the_prior() -> None:
    pj = PairJudge()
    pj.begin(_frame(AGREE, [1.0, 1.0]))
    assert pj.judge([_yaw(1.0, parallax=0.1), _yaw(1.1, "SIFT", parallax=0.1)]).action == ACCEPT
    assert pj.prior is None


def test_only_a_budget_the_client_gave_opens_the_window() -> None:
    assert given_budget({"ms": 20.0, "source": "given"}) == 20.0
    assert given_budget({"ms": 20.0, "source": "agent default (drone)"}) is None and given_budget(None) is None
    pj = PairJudge(BudgetTerms(verification_cap=4.0, window=10))
    pj.begin(_frame(NEVER, [5.0, 60.0], budget_ms=20.0))
    assert pj.window is not None and pj.window.cap == 4.0
    # the second try costs 2 × 60 ms: over the per-frame cap of 80 ms, so the pair is decided on the first
    assert pj.judge([_yaw(1.0)]).action != NEXT


@settings(max_examples=150, deadline=None)
@given(
    budget=st.floats(2.0, 40.0),
    window=st.integers(1, 6),
    cap=st.floats(1.0, 5.0),
    frames=st.lists(st.lists(st.one_of(st.none(), st.floats(0.5, 60.0)), min_size=1, max_size=4), min_size=1, max_size=12),
)
def test_the_window_never_offers_an_escalation_it_cannot_pay_for(budget: float, window: int, cap: float,
                                                                  frames: list[list[float | None]]) -> None:
    """Invariant: every ``next`` under a budget leaves the frame's expected ms (tries so far plus the offered one,
    a later try at twice its cost) within cap·B and the mean over the window's last W − 1 frames and this one within
    B — recomputed here from the costs alone, not from the window's own record."""
    pj = PairJudge(BudgetTerms(verification_cap=cap, window=window))
    closed: list[float] = []
    spent = 0.0
    for k, costs in enumerate(frames):
        if k:
            closed.append(spent)
        pj.begin(_frame(NEVER, costs, budget_ms=budget))
        each = [math.inf if c is None else (c if j == 0 else 2 * c) for j, c in enumerate(costs)]
        spent = each[0] if math.isfinite(each[0]) else 0.0
        tried: list[PairEvidence] = []
        while True:
            tried.append(_yaw(1.0))
            v = pj.judge(tried)
            if v.action != NEXT:
                break
            frame = sum(each[: len(tried) + 1])
            last = closed[-(window - 1):] if window > 1 else []
            assert frame <= cap * budget + 1e-9
            assert (sum(last) + frame) / (len(last) + 1) <= budget + 1e-9
            spent = frame
        assert len(tried) <= len(costs)
