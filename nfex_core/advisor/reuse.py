"""Reusing a stream's decision: a frame whose context and statistics have not moved keeps the last scored answer.

In a session (or any stream that passes the previous FrameState), frame t+1 is answered with frame t's α*, Θ′
and candidates — without extraction or scoring — when

    E(t+1) = E(t)  (every dimension, given or estimated),  the same graph version, budget and model,
    max_k |s_k(t+1) − s_k(t)| / max(|s_k(t+1)|, |s_k(t)|, 1) ≤ nfex:decisionReuseChange   over FRAME_KEYS,
    and the decision has been reused fewer than nfex:decisionReuseFrames times since it was scored.

Both numbers are data (rules/pruning/thresholds.ttl). The shipped nfex:decisionReuseFrames is 0: reuse is
off, so a stream's answers equal per-frame scoring (README's evaluations rely on it); a deployment that
prefers throughput sets it (``nfex kg update``) and the Selection says ``reused: n`` for every reused answer.

A service session (``session=True``) reuses on the evidence the decision rests on instead of the raw
statistics: frame t+1 keeps the decision made on frame d ≤ t when

    the given context, the graph version, the budget and the model are those of frame d; the estimated
    dimensions of E equal frame d's, or have differed for fewer than nfex:sessionConditionFrames frames in a row
    (an estimate that flickers at a threshold for a frame is not a change of conditions); the last verification
    verdict did not reject α* (the pair was accepted on the first proposal, or no verdict was reported); and
    fewer than nfex:sessionDecisionFrames − 1 frames have reused it,

where an estimate differs only if its value differs with a confidence of at least nfex:sessionConditionConfidence
(a dead band about each threshold: vision.context's confidence c = 0.5 + 0.45·min(1, |ln(s/τ)| / ln 2) is the
log-distance of the statistic s from its threshold τ, so c ≥ 0.6 is |ln(s/τ)| ≥ 0.154: s beyond τ by a factor of 1.17; an
estimate inside the band is as likely the decision's value as its own and is no evidence of a change),

so a session re-decides on a change of the given context, on an estimate that holds, on a rejected pair, and
at least every nfex:sessionDecisionFrames frames (both data: rules/pruning/thresholds.ttl). A reused frame
extracts α* alone (the stream's features stay those of neighbouring frames for the next decision's temporal
metrics). A decision due again only because it served its frames (``refreshed``: the rest of the evidence
still holds) re-decides α* as a single answer; where α* comes out the same, a verified pair's later proposals
keep the order the decision scored them in (the pairs accepted α* since), so they are not extracted again.
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from ..kg.store import KnowledgeGraph

FLOOR = 1.0  # a statistic below 1 in size (the fractions, sharpness, anisotropy) changes absolutely, not relatively


@dataclass(frozen=True)
class ReuseTerms:
    """``nfex:decisionReuseFrames`` (how many frames in a row may reuse a decision) and ``nfex:decisionReuseChange``
    (the largest relative change of a frame statistic that still counts as not moved)."""

    frames: int = 0
    change: float = 0.0
    session: int = 0  # nfex:sessionDecisionFrames: a session's decision serves at most this many frames (0, 1: each scored)
    hold: int = 1  # nfex:sessionConditionFrames: frames in a row a changed estimate must hold to re-decide a session
    firm: float = 0.0  # nfex:sessionConditionConfidence: the least confidence of an estimate that differs in a session

    @classmethod
    def load(cls, kg: KnowledgeGraph) -> ReuseTerms:
        from ..kg.rdf.terms import py

        def value(name: str) -> float | None:
            rows = kg.select(f"SELECT ?v WHERE {{ nfex:{name} nfex:value ?v }}").rows
            return float(py(rows[0]["v"])) if rows else None

        frames, change = value("decisionReuseFrames"), value("decisionReuseChange")
        return cls(max(0, int(frames or 0)), max(0.0, change or 0.0), max(0, int(value("sessionDecisionFrames") or 0)),
                   max(1, int(value("sessionConditionFrames") or 1)), max(0.0, value("sessionConditionConfidence") or 0.0))

    def limit(self, session: bool) -> int:
        """How many frames in a row may reuse one decision (0: none)."""
        return max(0, self.session - 1) if session else self.frames


@dataclass(frozen=True)
class Decided:
    """A scored answer a stream may reuse: what it was decided under, the statistics it was decided on, the
    answer (a Selection without its state) and how many frames have reused it so far."""

    key: tuple[Any, ...]
    stats: Mapping[str, float]
    selection: Any
    reused: int = 0
    estimate: tuple[tuple[str, str | None], ...] = ()  # a session's estimated dimensions when it was decided
    differed: int = 0  # frames in a row whose estimate differed from ``estimate``


def moved(before: Mapping[str, float], after: Mapping[str, float], keys: tuple[str, ...]) -> float:
    """The largest change of the statistics ``keys`` between two frames: relative for those larger than 1 (grey
    levels, gradient energy), absolute for the fractions and ratios below 1, whose relative change near 0 is noise."""
    return max((abs(after[k] - before[k]) / max(abs(after[k]), abs(before[k]), FLOOR) for k in keys), default=0.0)


def differs(terms: ReuseTerms, decided: tuple[tuple[str, str | None], ...], estimate: tuple[tuple[str, str | None], ...],
            confidence: Mapping[str, float | None]) -> bool:
    """Whether a session frame's ``estimate`` differs from the ``decided`` one: some dimension's value differs with a
    confidence of at least ``terms.firm`` (an estimate without a confidence always counts; module docstring)."""
    before = dict(decided)
    if set(before) != {d for d, _ in estimate}:
        return True
    return any(value != before[d] and (confidence.get(d) is None or confidence[d] >= terms.firm)  # type: ignore[operator]
               for d, value in estimate)


def reusable(terms: ReuseTerms, last: Decided | None, key: tuple[Any, ...], stats: Mapping[str, float] | None,
             keys: tuple[str, ...], session: bool = False, verdict_held: bool = True,
             estimate: tuple[tuple[str, str | None], ...] = (),
             confidence: Mapping[str, float | None] | None = None) -> Decided | None:
    """``last`` carried to a frame decided under ``key`` with ``stats`` (and, in a session, ``estimate`` with each
    dimension's ``confidence``) if it may answer it (module docstring), else None: in a stream while the statistics
    have not moved, in a session while its evidence holds."""
    if last is None or last.reused >= terms.limit(session):
        return None
    return _holds(terms, last, key, stats, keys, session, verdict_held, estimate, confidence)


def refreshed(terms: ReuseTerms, last: Decided | None, key: tuple[Any, ...], stats: Mapping[str, float] | None,
              keys: tuple[str, ...], verdict_held: bool, estimate: tuple[tuple[str, str | None], ...],
              confidence: Mapping[str, float | None]) -> Decided | None:
    """A session's ``last`` decision when only its count makes it due (``reusable`` would carry it otherwise): the
    frame re-decides α*, and the verification's later proposals may keep the order ``last`` scored
    (stages.scoring); else None."""
    if last is None or last.reused < terms.limit(True):
        return None
    return last if _holds(terms, last, key, stats, keys, True, verdict_held, estimate, confidence) else None


def _holds(terms: ReuseTerms, last: Decided, key: tuple[Any, ...], stats: Mapping[str, float] | None,
           keys: tuple[str, ...], session: bool, verdict_held: bool, estimate: tuple[tuple[str, str | None], ...],
           confidence: Mapping[str, float | None] | None) -> Decided | None:
    """``last`` one frame further if the evidence it was decided on holds on this frame, whatever its count."""
    if stats is None or last.key != key:
        return None
    if not session:
        return replace(last, reused=last.reused + 1) if moved(last.stats, stats, keys) <= terms.change else None
    if not verdict_held:
        return None
    differed = last.differed + 1 if differs(terms, last.estimate, estimate, confidence or {}) else 0
    return replace(last, reused=last.reused + 1, differed=differed) if differed < terms.hold else None
