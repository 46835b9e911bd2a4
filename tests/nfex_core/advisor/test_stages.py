"""Each stage of the advisor's flow on its own (advisor/stages.py, run in order by advisor/pipeline.py): its input record built here, no store.

A two-extractor vocabulary (ORB with nfeatures and nlevels, SIFT with nfeatures), one condition dimension and a rule
table of hand-written decisions stand in for a compiled graph; the integration tests (test_advisor*.py, test_budget.py,
test_reuse.py) run the same stages through ``Advisor.select`` on the seeded graph.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from rdflib import URIRef

from nfex_core.advisor.budget import Budget
from nfex_core.advisor.params import theta
from nfex_core.advisor.pipeline import PIPELINE, STAGES
from nfex_core.advisor.reuse import Decided, ReuseTerms
from nfex_core.advisor.scoring import Scored, Scorer
from nfex_core.advisor.selection import UNSCORED, Scoring
from nfex_core.advisor.stages import (
    AnswerIn,
    BudgetIn,
    ConditionsIn,
    Memo,
    ParamsIn,
    ScoringIn,
    Settled,
    Symbolic,
    SymbolicIn,
    VerificationIn,
    answer,
    budget,
    conditions,
    params,
    scoring,
    symbolic,
    verification,
)
from nfex_core.errors import NoCandidate, UnknownName
from nfex_core.evidence.cost import BudgetTerms, CostModel, ExtractorCost
from nfex_core.kg.vocabulary.vocab import (
    ConditionValueSpec,
    DimensionSpec,
    ExtractorSpec,
    ParameterSpec,
    Vocabulary,
)
from nfex_core.neural.serve import NeuralStep
from nfex_core.rules.engine import RuleTable
from nfex_core.rules.types import AcceptRule, Citation, Decision, Evidence, Factor, Policy

N = "https://w3id.org/nfex#"
RELATIVE = N + "rule_relative"
SYMBOLIC = NeuralStep(None, False, False, {"used": "symbolic"})


def _param(x: str, name: str, role: str, default: int, low: int, high: int) -> ParameterSpec:
    return ParameterSpec(URIRef(f"{N}{x}_{name}"), x, name, "integer", role, default, low, high, tunable=True)


def _vocab() -> Vocabulary:
    orb = ExtractorSpec(URIRef(N + "ORB"), "ORB", "ORB", "ORB_create", "NORM_HAMMING", "binary", {
        "nfeatures": _param("ORB", "nfeatures", "NF", 1000, 100, 5000),
        "nlevels": _param("ORB", "nlevels", "NL", 8, 1, 12)})
    sift = ExtractorSpec(URIRef(N + "SIFT"), "SIFT", "SIFT", "SIFT_create", "NORM_L2", "real", {
        "nfeatures": _param("SIFT", "nfeatures", "NF", 1000, 100, 5000)})
    light = DimensionSpec(URIRef(N + "light"), "light", "light", False, {
        v: ConditionValueSpec(URIRef(N + v), "light", v) for v in ("bright", "dark")})
    return Vocabulary(1, {"ORB": orb, "SIFT": sift}, {"light": light}, {})


def _cite(rule: str, reason: str) -> Citation:
    return Citation(rule, rule.rsplit("#", 1)[-1], reason, "sparql")


BRIGHT = Decision({"light": "bright"}, ("SIFT", "ORB"), {}, {"ORB": {"nfeatures": Factor(1.5)}}, {},
                  {"SIFT": Factor(0.2)}, {"SIFT": Evidence(0.02, 5, 300.0), "ORB": Evidence(0.15, 5, 20.0)})
# SIFT over 5× ORB's ATE is pruned by a relative-accuracy rule in the dark: a budget re-judges it
DARK = Decision({"light": "dark"}, ("ORB",), {"SIFT": (_cite(RELATIVE, "over k× the best ATE"),)}, {}, {}, {},
                {"SIFT": Evidence(0.05, 5, 300.0), "ORB": Evidence(0.04, 5, 20.0)})
NOTHING = Decision({"light": None}, (), {"ORB": (_cite(N + "rule_a", "too slow"),),
                                         "SIFT": (_cite(N + "rule_b", "too blurry"),)}, {}, {}, {})
COST = CostModel(extractors={"ORB": ExtractorCost("ORB", 2.0, 5.0, 0.5, nf="nfeatures", nl="nlevels"),
                             "SIFT": ExtractorCost("SIFT", 300.0, mean_per_mp=300.0)}, typical_size=(640, 480))
TERMS = BudgetTerms(agent_defaults={"car": 30.0}, compute={"reference": 1.0, "slow": 2.0},
                    relative_rules=frozenset({RELATIVE}), max_relative_ate=3.0, verification_cap=4.0)


def _table(**decisions: Decision) -> RuleTable:
    table = RuleTable(1, ("light",), {}, [], [], [], 0.0, cost=COST, budget_terms=TERMS)
    for d in decisions.values():
        table.decisions[table.key(d.context)] = d
    return table


TABLE = _table(bright=BRIGHT, dark=DARK, nothing=NOTHING)


def _budget(ms: float) -> Budget:
    return Budget(ms, "given", "reference", 1.0, 640, 480, "given")


def _conditions(light: str | None):  # type: ignore[no-untyped-def]
    return conditions(ConditionsIn(_vocab(), {"light": light} if light else {}, None, None))


def test_the_pipeline_runs_the_seven_stages_of_the_flow_in_order() -> None:
    assert STAGES == ("conditions", "symbolic", "params", "budget", "scoring", "verification", "answer")
    assert [s.name for s in PIPELINE if not s.on_reuse] == ["params", "budget", "verification"]


def test_conditions_keep_what_was_given_and_leave_the_rest_unknown_without_a_frame() -> None:
    cond = _conditions("dark")
    assert cond.values == {"light": "dark"} and cond.image is None and cond.stats is None
    assert [(e.dimension, e.source) for e in cond.entries] == [("light", "given")]
    assert _conditions(None).values == {"light": None}
    with pytest.raises(UnknownName):
        conditions(ConditionsIn(_vocab(), {"light": "twilight"}, None, None))


def test_symbolic_looks_the_context_up_and_resolves_the_budget_in_force() -> None:
    out = symbolic(SymbolicIn(TABLE, _conditions("bright"), budget_ms=12.0, compute="slow", frame_size=(320, 240)))
    assert out.decision is TABLE.decide({"light": "bright"}) and out.decision.candidates == BRIGHT.candidates
    assert out.carried is None and out.key is None  # reuse is off by default
    assert out.budget == Budget(12.0, "given", "slow", 2.0, 320, 240, "given")
    free = symbolic(SymbolicIn(TABLE, _conditions("bright")))
    assert free.budget is None
    with pytest.raises(UnknownName):
        symbolic(SymbolicIn(TABLE, _conditions("bright"), budget_ms=12.0, compute="quantum"))


def test_symbolic_answers_no_candidate_with_every_prune_and_its_rule() -> None:
    with pytest.raises(NoCandidate) as e:
        symbolic(SymbolicIn(TABLE, _conditions(None)))
    assert "ORB: too slow [rule_a]" in str(e.value) and "SIFT: too blurry [rule_b]" in str(e.value)


def test_params_chain_gives_theta_per_candidate_from_the_rules_factors() -> None:
    out = params(ParamsIn(_vocab(), TABLE, BRIGHT, {"light": "bright"}, None, SYMBOLIC))
    assert list(out.candidates) == ["SIFT", "ORB"] and not out.relative and not out.shaped_out
    assert out.candidates["ORB"].params["nfeatures"] == 1500 and out.candidates["ORB"].proposal.source == "rules"
    assert out.candidates["SIFT"].params == {"nfeatures": 1000}
    memo = Memo()
    once = params(ParamsIn(_vocab(), TABLE, BRIGHT, {"light": "bright"}, None, SYMBOLIC, memo=memo))
    assert params(ParamsIn(_vocab(), TABLE, BRIGHT, {"light": "bright"}, None, SYMBOLIC, memo=memo)) is once


def test_params_under_a_budget_gives_what_a_relative_rule_pruned_a_theta_for_the_budget_stage() -> None:
    out = params(ParamsIn(_vocab(), TABLE, DARK, {"light": "dark"}, _budget(30.0), SYMBOLIC))
    assert list(out.candidates) == ["ORB"] and list(out.relative) == ["SIFT"]
    assert not params(ParamsIn(_vocab(), TABLE, DARK, {"light": "dark"}, None, SYMBOLIC)).relative


def _settle(decision: Decision, b: Budget | None) -> Settled:
    p = theta(_vocab(), TABLE, decision, dict(decision.context), b, SYMBOLIC, None)
    return budget(BudgetIn(COST, TERMS, _vocab().extractors, decision, p, b))


def test_budget_without_one_passes_the_candidates_and_the_table_prunes_through() -> None:
    out = _settle(DARK, None)
    assert list(out.candidates) == ["ORB"] and out.outcome is None and set(out.pruned) == {"SIFT"}


def test_budget_fits_theta_prunes_the_unaffordable_and_cites_its_rule() -> None:
    out = _settle(BRIGHT, _budget(5.0))
    assert list(out.candidates) == ["ORB"]  # SIFT's 92 ms cannot fit 5 ms
    orb = out.candidates["ORB"]
    assert orb.params["nfeatures"] < 1500 or orb.params["nlevels"] < 8  # fitted: fewer features or levels
    assert orb.cost is not None and orb.cost.ms is not None and orb.cost.ms <= 5.0
    assert [c.kind for c in out.pruned["SIFT"]] == ["budget"]


def test_budget_readmits_what_was_pruned_relative_to_an_unaffordable_best() -> None:
    cheap = replace(DARK, evidence={"SIFT": Evidence(0.05, 5, 300.0), "ORB": Evidence(0.04, 5, 20.0),
                                    "BRISK": Evidence(0.01, 5, 900.0)})
    out = _settle(cheap, _budget(200.0))
    assert list(out.candidates) == ["ORB", "SIFT"] and "SIFT" not in out.pruned
    assert out.outcome is not None and "SIFT" in out.outcome.readmitted


@given(st.floats(0.5, 400.0))
def test_budget_leaves_a_candidate_for_any_budget_and_never_lists_one_as_pruned(ms: float) -> None:
    out = _settle(BRIGHT, _budget(ms))
    assert out.candidates and not set(out.candidates) & set(out.pruned)


def test_scoring_without_a_frame_ranks_the_prior_bonus_plus_measured_accuracy() -> None:
    settled = _settle(BRIGHT, None)
    memo = Memo()
    i = ScoringIn(_vocab(), lambda: None, BRIGHT, settled.candidates, SYMBOLIC, None, None, Scorer(), COST, memo=memo)
    out = scoring(i)
    assert out.mode == "prior" and out.state is None and out.scoring is not None and out.scoring.outcome == UNSCORED
    assert [(c.extractor, c.score) for c in out.candidates] == [("SIFT", pytest.approx(1.2)),
                                                                ("ORB", pytest.approx(0.02 / 0.15))]
    assert scoring(i).candidates == out.candidates and len(memo) == 1


def test_verification_without_a_budget_is_the_policy_alone() -> None:
    policy = Policy((AcceptRule((), (), _cite(N + "rule_accept", "inliers")),))
    decided = replace(BRIGHT, verification=policy)
    i = VerificationIn(_vocab(), TABLE, decided, {"light": "bright"}, None, SYMBOLIC, {})
    assert verification(i).policy is policy and verification(i).escalations == ()


def test_verification_under_a_budget_offers_what_fits_the_cap_best_first() -> None:
    policy = Policy((AcceptRule((), (), _cite(N + "rule_accept", "inliers")),))
    decided = replace(BRIGHT, verification=policy)
    memo = Memo()
    out = verification(VerificationIn(_vocab(), TABLE, decided, {"light": "bright"}, _budget(25.0), SYMBOLIC, memo))
    assert [c.extractor for c in out.escalations] == ["SIFT", "ORB"]  # 4 × 25 ms fits SIFT's 92 ms
    assert out.escalations[0].evidence.cost is not None and len(memo) == 1
    # without verification in force there is nothing to escalate to
    assert verification(VerificationIn(_vocab(), TABLE, BRIGHT, {"light": "bright"}, _budget(25.0), SYMBOLIC, {})).escalations == ()


def _answer_in(decision: Decision, b: Budget | None, key: tuple | None = None) -> AnswerIn:  # type: ignore[type-arg]
    cond = _conditions(str(decision.context["light"]))
    settled = _settle(decision, b)
    scored = scoring(ScoringIn(_vocab(), lambda: None, decision, settled.candidates, SYMBOLIC, None, None, Scorer(), COST))
    sym = Symbolic(decision, b, key)
    ver = verification(VerificationIn(_vocab(), TABLE, decision, dict(decision.context), b, SYMBOLIC, {}))
    return AnswerIn(_vocab(), decision, cond, sym, settled, scored, ver, {"graph": 1})


def test_answer_is_the_first_ranked_candidate_with_every_prune_and_warning() -> None:
    sel = answer(_answer_in(BRIGHT, _budget(5.0)))
    assert sel.extractor == "ORB" and sel.candidates[0].extractor == "ORB" and sel.mode == "prior"
    assert [p.extractor for p in sel.pruned] == ["SIFT"] and sel.budget is not None and sel.budget["ms"] == 5.0
    assert sel.opencv["constructor"] == "ORB_create" and sel.versions == {"graph": 1} and sel.state is None
    assert answer(_answer_in(BRIGHT, None)).extractor == "SIFT"


def test_answer_keeps_a_decision_a_later_frame_may_reuse_and_answers_a_carried_one() -> None:
    i = _answer_in(BRIGHT, None, key=("k",))
    from nfex_core.advisor.scoring import FrameState

    image = np.zeros((12, 16), np.uint8)
    state = FrameState(image, {})
    cond = replace(i.conditions, image=image, stats={"mean": 1.0})
    first = answer(replace(i, conditions=cond, scored=replace(i.scored, state=state)))
    assert first.state is not None and first.state.decided is not None and first.state.decided.key == ("k",)
    carried = Decided(("k",), {"mean": 1.0}, first.state.decided.selection, reused=1)
    why = Scoring(UNSCORED, "reused")
    again = answer(AnswerIn(_vocab(), BRIGHT, cond, Symbolic(BRIGHT, None, ("k",), carried=carried), None,
                            Scored(list(first.candidates), FrameState(image, {}, {}, carried), first.mode, why), None))
    assert again.reused == 1 and again.extractor == first.extractor and again.scoring is why
    assert again.state is not None and again.state.decided is carried


def test_symbolic_carries_a_stream_decision_whose_statistics_have_not_moved() -> None:
    image = np.zeros((12, 16), np.uint8)
    cond = replace(_conditions("bright"), image=image, stats={"mean": 1.0})
    terms = ReuseTerms(frames=2, change=0.1)
    first = symbolic(SymbolicIn(TABLE, cond, reuse=terms, version=1, model="symbolic"))
    assert first.key is not None and first.carried is None
    from nfex_core.vision.statistics import FRAME_KEYS

    stats = dict.fromkeys(FRAME_KEYS, 1.0)
    last = Decided(first.key, stats, None)
    again = symbolic(SymbolicIn(TABLE, replace(cond, stats=stats), reuse=terms, version=1, model="symbolic", last=last))
    assert again.carried is not None and again.carried.reused == 1
    moved = symbolic(SymbolicIn(TABLE, replace(cond, stats=dict.fromkeys(FRAME_KEYS, 9.0)), reuse=terms, version=1,
                                model="symbolic", last=last))
    assert moved.carried is None


def test_the_scoring_input_of_a_frame_needs_the_registry_only_with_a_frame() -> None:
    def no_registry() -> None:
        raise AssertionError("the registry is built only when a frame is scored")

    settled = _settle(BRIGHT, None)
    out = scoring(ScoringIn(_vocab(), no_registry, BRIGHT, settled.candidates, SYMBOLIC, None, None, Scorer(), COST))
    assert [c.extractor for c in out.candidates] == ["SIFT", "ORB"]


def test_the_memo_keeps_at_most_its_limit_and_answers_only_for_the_same_objects() -> None:
    """A snapshot's memo stops keeping past its limit (a client's budgets and frame sizes cannot grow it), and a
    key that names an object by id answers only for that object."""
    memo = Memo(limit=3)
    made: list[int] = []
    for n in range(10):
        assert memo.get(("budget", n), lambda n=n: made.append(n) or n) == n  # type: ignore[misc]
    assert len(memo) == 3 and made == list(range(10))
    assert memo.get(("budget", 0), lambda: -1) == 0 and memo.get(("budget", 9), lambda: -1) == -1
    a, b = object(), object()
    keyed = Memo()
    assert keyed.get(("x", 1), lambda: "a's", a) == "a's"
    assert keyed.get(("x", 1), lambda: "a's again", a) == "a's"
    assert keyed.get(("x", 1), lambda: "b's", b) == "b's"  # the same key naming another object: made, not a's
