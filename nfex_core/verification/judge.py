"""Verification: per frame pair, accept a candidate's estimate, try the next one, or fall back to the motion prior.

The stage after scoring in DESIGN.md's flow. Choosing by condition labels cannot tell which estimate of a
frame pair is right (EVIDENCE.md); the pair itself can. A client (or the VO) matches the first proposal
against the previous frame and reports what the estimate showed; this module decides.

**Signals** of candidate i's estimate (R_i, unit t_i) of the pair (k−1, k), d_i = −R_iᵀt_i its direction of
motion (``motion.motion_direction``), given the motion prior — the last accepted step that translated,
(R_p, t_p) — and the other candidates tried on the same pair:

    inliers, matches, keypoints, parallax (px), extraction_ms     as measured
    rotation         θ(R_i)                                       degrees, θ(R) = arccos((tr R − 1)/2)
    rotation_change  θ(R_pᵀ·R_i)                                  departure from the prior's rotation
    heading_change   ∠(R_p·d_p, d_i)                              as the front-end checks (motion.StepChecks)
    agreement        min_j≠i [θ(R_jᵀ·R_i) + ∠(d_j, d_i)]          over the other candidates with an estimate

A signal that cannot be computed (no prior yet, no second estimate, no estimate at all) is *undefined*, and a
test on it fails: a rule accepts only on the evidence it names.

**Policy** (per context, compiled from the nFEX language; docs/dsl.md, "Verification"):

    accept pair if heading_change <= 4 and rotation_change <= 1.5 when agent is car
    accept pair if agreement <= 2
    escalate at most 2

An estimate is *accepted* when it passed the front-end checks and every test of at least one ``accept``
statement in force holds. After each try: the first accepted estimate in proposal order is taken; else, while
fewer than 1 + N candidates were tried (N: the smallest ``escalate at most N`` in force, default
``DEFAULT_ESCALATIONS``) and proposals remain, the next one is tried; else the pair *falls back* to the motion
prior (the VO repeats the last accepted motion). Where there is no motion prior yet (a stream's first pairs, or
a single affordable candidate that nothing else can vouch for), there is nothing to fall back to: the first
estimate that passed the front-end checks is taken, as without verification — otherwise a stream with one
candidate could never accept its first pair, and so never have a prior. A policy without ``accept`` statements accepts every estimate
that passed the front-end checks — the behaviour of every method without verification.
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from nfex_slam.motion import angle_between, rotation_deg
from nfex_slam.pairs import ACCEPT, FALLBACK, NEXT, PairEvidence, Prior, Verdict

from ..rules.types import Policy

# the pose error (rotation + translation direction, degrees) a lost pair is charged where pair errors are summed or
# capped: the hindsight oracles (evaluation/oracle.py) and the verification learner (sweeps/verification.py)
LOST_PAIR_DEG = 360.0


def signals(tried: Sequence[PairEvidence], i: int, prior: Prior | None) -> dict[str, float | None]:
    """The signals of candidate i among ``tried`` (module docstring); None where undefined."""
    e = tried[i]
    out: dict[str, float | None] = {
        "inliers": float(e.inliers), "matches": float(e.matches), "keypoints": float(e.keypoints),
        "parallax": float(e.parallax_px), "extraction_ms": float(e.extraction_ms),
        "rotation": None, "rotation_change": None, "heading_change": None, "agreement": None,
    }
    if not e.estimated:
        return out
    R, d = e.matrix(), np.asarray(e.direction, dtype=float)
    out["rotation"] = rotation_deg(R)
    if prior is not None:
        out["rotation_change"] = rotation_deg(prior.R.T @ R)
        out["heading_change"] = angle_between(prior.R @ prior.direction, d)
    others = [o for j, o in enumerate(tried) if j != i and o.estimated]
    if others:
        out["agreement"] = min(rotation_deg(o.matrix().T @ R) + angle_between(np.asarray(o.direction, dtype=float), d) for o in others)
    return out


def judge(policy: Policy, tried: Sequence[PairEvidence], prior: Prior | None, remaining: int) -> Verdict:
    """Accept, try the next proposal, or fall back (module docstring). ``remaining``: proposals not yet tried."""
    shown = tuple(signals(tried, i, prior) for i in range(len(tried)))
    if not policy.active:
        first_ok = next((i for i, e in enumerate(tried) if e.estimated), None)
        if first_ok is not None:
            return Verdict(ACCEPT, first_ok, None, "no verification in force: the estimate passed the front-end checks", shown)
        return Verdict(FALLBACK, None, None, "no verification in force and the estimate was lost", shown)
    for i, e in enumerate(tried):
        if not e.estimated:
            continue
        for rule in policy.accept:
            if all(t.holds(shown[i]) for t in rule.tests):
                return Verdict(ACCEPT, i, rule.citation, f"{e.extractor}: {rule.citation.label}", shown)
    if len(tried) < policy.max_tries and remaining > 0:
        return Verdict(NEXT, None, policy.escalation_citation, f"no accept statement held for {len(tried)} tried", shown)
    if prior is None:
        first_ok = next((i for i, e in enumerate(tried) if e.estimated), None)
        if first_ok is not None:  # nothing to fall back to: take what passed the front-end checks, as without verification
            return Verdict(ACCEPT, first_ok, None, "no motion prior yet to fall back to: the first estimate that passed the front-end checks", shown)
    why = f"no accept statement held for the {len(tried)} candidate(s) tried"
    return Verdict(FALLBACK, None, policy.escalation_citation, why + "; the motion prior stands in", shown)

