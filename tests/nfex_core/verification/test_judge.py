"""Verification of frame pairs (nfex_core/verification/judge.py): signals, accept, escalate, fall back — on synthetic pairs."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from nfex_slam.motion import rotation_deg
from nfex_slam.pairs import ACCEPT, FALLBACK, NEXT, PairEvidence, Prior

from nfex_core.rules.types import AcceptRule, Citation, PairTest, Policy
from nfex_core.verification import judge, signals

CAR = Citation("urn:accept-car", "accept pair if heading_change <= 4 and rotation_change <= 1.5", "learned", "accept")
AGREE = Citation("urn:agree", "accept pair if agreement <= 2", "learned", "accept")
ESC = Citation("urn:esc", "escalate at most 2", "prior", "escalate")
POLICY = Policy(
    (AcceptRule((PairTest("heading_change", "<=", 4.0), PairTest("rotation_change", "<=", 1.5)), (), CAR),
     AcceptRule((PairTest("agreement", "<=", 2.0),), (), AGREE)),
    2, ESC,
)
FORWARD = Prior(np.eye(3), np.array([0.0, 0.0, 1.0]))  # the car drove straight ahead


def _yaw(deg: float) -> np.ndarray:
    a = math.radians(deg)
    return np.array([[math.cos(a), 0, math.sin(a)], [0, 1, 0], [-math.sin(a), 0, math.cos(a)]])


def _pair(x: str, yaw_deg: float, heading_deg: float, *, rejected: str = "", inliers: int = 100) -> PairEvidence:
    """An estimate that yaws by ``yaw_deg`` and moves in a direction ``heading_deg`` off straight ahead."""
    R = _yaw(yaw_deg)
    d = _yaw(heading_deg) @ np.array([0.0, 0.0, 1.0])
    t = -R @ d  # d = −Rᵀt
    return PairEvidence.of(x, {}, R, t, inliers=inliers, matches=inliers * 2, keypoints=500, rejected=rejected)


def test_signals_against_the_prior_and_the_other_candidates() -> None:
    tried = [_pair("ORB", 10.0, 30.0), _pair("SIFT", 0.5, 1.0)]
    s = signals(tried, 1, FORWARD)
    assert s["rotation"] == pytest.approx(0.5, abs=1e-6)
    assert s["rotation_change"] == pytest.approx(0.5, abs=1e-6)
    assert s["heading_change"] == pytest.approx(1.0, abs=1e-6)
    assert s["agreement"] == pytest.approx(9.5 + 29.0, abs=1e-4)
    # without a prior and alone on the pair, those signals are undefined
    alone = signals(tried[:1], 0, None)
    assert alone["rotation_change"] is None and alone["heading_change"] is None and alone["agreement"] is None
    assert alone["inliers"] == 100


def test_a_pair_consistent_with_the_motion_is_accepted_at_once() -> None:
    v = judge(POLICY, [_pair("ORB", 0.3, 1.0)], FORWARD, remaining=2)
    assert v.action == ACCEPT and v.accepted == 0 and v.because == CAR


def test_a_pair_that_disagrees_with_the_motion_escalates_then_two_that_agree_are_accepted() -> None:
    cheap = _pair("ORB", 12.0, 60.0)  # a turn the car cannot have made
    assert judge(POLICY, [cheap], FORWARD, remaining=2).action == NEXT
    # the second candidate also departs from the prior (a real turn begins), but agrees with... nobody yet
    second = _pair("SIFT", 3.0, 8.0)
    v = judge(POLICY, [cheap, second], FORWARD, remaining=1)
    assert v.action == NEXT
    third = _pair("XFEAT", 3.2, 8.5)
    v = judge(POLICY, [cheap, second, third], FORWARD, remaining=0)
    assert v.action == ACCEPT and v.accepted == 1 and v.because == AGREE  # the first of the agreeing two, in order


def test_the_pair_falls_back_when_the_tries_are_spent() -> None:
    tried = [_pair("ORB", 12.0, 60.0), _pair("SIFT", 40.0, 120.0), _pair("XFEAT", 80.0, 10.0)]
    v = judge(POLICY, tried, FORWARD, remaining=5)  # 1 + 2 tries spent: no fourth
    assert v.action == FALLBACK and v.accepted is None and "motion prior" in v.reason
    # and when the proposals run out first
    assert judge(POLICY, tried[:1], FORWARD, remaining=0).action == FALLBACK


def test_without_a_policy_the_first_estimate_that_passed_the_checks_is_taken() -> None:
    assert judge(Policy(), [_pair("ORB", 12.0, 60.0)], FORWARD, 3).action == ACCEPT
    assert judge(Policy(), [_pair("ORB", 0.1, 0.1, rejected="check: rotation")], FORWARD, 3).action == FALLBACK


angles = st.floats(0.0, 30.0)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(angles, angles, st.booleans()), min_size=1, max_size=4), st.integers(0, 3))
def test_a_candidate_rejected_by_its_checks_is_never_accepted(tries, remaining) -> None:  # type: ignore[no-untyped-def]
    tried = [_pair(f"X{i}", y, h, rejected="check: rotation" if bad else "") for i, (y, h, bad) in enumerate(tries)]
    v = judge(POLICY, tried, FORWARD, remaining)
    if v.action == ACCEPT:
        assert v.accepted is not None and not tried[v.accepted].rejected
        assert tried[v.accepted].estimated
    # a rejected candidate's estimate does not vouch for another: agreement only among estimates that passed
    for i in range(len(tried)):
        s = signals(tried, i, FORWARD)
        if s["agreement"] is not None:
            assert any(o.estimated for j, o in enumerate(tried) if j != i)
    assert v.action in (ACCEPT, NEXT, FALLBACK)
    assert len(tried) < POLICY.max_tries or v.action != NEXT


def test_pair_evidence_round_trips_its_rotation() -> None:
    R = _yaw(7.0)
    e = PairEvidence.of("ORB", {}, R, np.array([0.0, 0.0, -1.0]))
    assert rotation_deg(e.matrix().T @ R) < 1e-6


def test_the_budget_window_allows_an_expensive_try_only_where_the_mean_and_the_cap_hold() -> None:
    from nfex_core.verification import BudgetWindow

    w = BudgetWindow(20.0, window=10, cap=4.0)
    assert BudgetWindow.try_cost(0, 5.0) == 5.0 and BudgetWindow.try_cost(1, 5.0) == 10.0  # a switch re-extracts k-1
    assert not w.allows(5.0, BudgetWindow.try_cost(1, 60.0))  # 125 ms: over the per-frame cap of 80
    assert w.allows(5.0, BudgetWindow.try_cost(1, 7.0))  # 19 ms: within everything
    for _ in range(9):
        w.close(5.0)  # nine cheap frames leave room in the mean: (45 + 5 + 70) / 10 = 12 ms
    assert w.allows(5.0, BudgetWindow.try_cost(1, 35.0))
    for _ in range(9):
        w.close(19.0)  # nine frames near the budget leave none: (171 + 5 + 14) / 10 = 19 ms … + 70 → 24 ms
    assert w.allows(5.0, BudgetWindow.try_cost(1, 7.0)) and not w.allows(5.0, BudgetWindow.try_cost(1, 35.0))
    assert not w.allows(5.0, BudgetWindow.try_cost(1, None))  # unknown cost: never on a budget


def test_the_shacl_shape_admits_exactly_the_signals_the_verifier_computes() -> None:
    """rules/shapes/dsl.ttl lists the pair signals for editors who write triples directly; it must not drift from
    the list the parser checks and ``signals`` computes."""
    import rdflib
    from rdflib.collection import Collection
    from rdflib.namespace import SH

    from nfex_core.config import Settings
    from nfex_core.kg.rdf.namespaces import NFEX
    from nfex_core.rules.types import PAIR_SIGNALS

    g = rdflib.Graph().parse(Settings.from_env().rules_dir / "shapes" / "dsl.ttl")
    [prop] = [p for p in g.objects(NFEX.PairTestShape, SH.property) if g.value(p, SH.path) == NFEX.signal]
    assert {str(v) for v in Collection(g, g.value(prop, SH["in"]))} == set(PAIR_SIGNALS)
    computed = signals([_pair("ORB", 1.0, 1.0)], 0, FORWARD)
    assert set(computed) == set(PAIR_SIGNALS)
