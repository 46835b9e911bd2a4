"""Learn the verification program (``accept pair if …``, ``escalate at most N``) from the sweeps' pair tables.

Input: the per-pair tables the sweeps write beside their training tables (``*-pairs.csv.gz``, ``table.py``; they
carry each estimate and the true motion) and those training tables (for each cell's agent). Accepting a pair's
estimate is the alternative to falling back to the motion prior, so each pair with a prior has two costs, in
degrees of rotation + direction error against the true motion (``motion.pair_errors``):

    e_est   = the estimate's error (∞ where the pair was lost or rejected: it cannot be accepted),
    e_prior = the error of repeating the motion prior,

and a rule's cost over the pairs is the mean of e_est where it accepts and e_prior where it does not (errors
capped at ``LOST_PAIR_DEG``). Per pair the run-time signals of ``verification.py`` are rebuilt from the table:

- the motion prior of a pair is the same cell's latest earlier pair that translated (parallax ≥ ``STILL_PX``)
  and whose estimate was right (rotation + direction error ≤ 2·``BAD_PAIR_DEG``) — what a verifier should have
  accepted, standing in for the last accepted step the VO keeps as its prior;
  ``rotation_change`` and ``heading_change`` are measured against it;
- ``agreement``: the least disagreement with the estimates of the other extractors the loop would escalate to —
  the N (``escalate at most N``) with the lowest mean pair error in the tables, one configuration each — on the
  same frame pair of the same sequence, condition, severity and seed.

For each agent with at least ``min_pairs`` pairs (else all agents pooled), the policy is run over the pairs
(``simulate``: each configuration's consecutive pairs in order, the prior being the last *accepted* step, a
fallback keeping it, as in the loop) for every combination of

1. a motion-consistency rule ``heading_change <= a and rotation_change <= b`` (or none), and
2. an agreement rule ``agreement <= c`` (or none) — a second candidate's estimate of the same pair agreeing,

a, b, c on the deciles of their signals, and the combination with the least mean pair error whose extra fallbacks
stay within ``MAX_EXTRA_FALLBACK`` of the pairs is written. The
signals' grid is read against a stand-in prior (the same cell's last right estimate).

Every threshold is printed with its cost, the costs of always accepting and of always falling back, and the
pair count, and written into each statement's reason, so a
selection that cites the statement says what it was learned from. ``escalate at most N`` is a prior (the cost of
a pair is then at most 1 + N extractions), written as such.
"""
from __future__ import annotations

import csv
import json
import math
from collections import defaultdict
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from nfex_slam.motion import angle_between, rotation_deg
from nfex_slam.pairs import ACCEPT, NEXT, STILL_PX, PairEvidence

from ..rules.types import AcceptRule, Citation, PairTest, Policy
from ..verification import LOST_PAIR_DEG, PairJudge
from .cells import BAD_PAIR_DEG
from .table import read_pairs

QUANTILES = np.arange(0.1, 0.91, 0.1)
MAX_EXTRA_FALLBACK = 0.1  # a policy may coast on at most this share of pairs beyond those nothing survives
_FITTED = Citation("urn:nfex:fitting", "a candidate rule of the fit", "", "verify")
_NOTHING = AcceptRule((PairTest("rotation", "<", 0.0),), (), _FITTED)  # an angle is never negative: accepts nothing


@dataclass(frozen=True)
class Fitted:
    cost: float  # mean pair error (degrees) of the rule's choices
    accept_all: float  # … of taking every estimate that passed the checks
    fall_back_all: float  # … of always repeating the motion prior
    pairs: int
    accepted: int


@dataclass
class _Pair:
    key: tuple[str, ...]  # the frame pair: dataset, sequence, condition, severity, seed, frame
    extractor: str
    cell: str
    frame: int
    est_err: float  # e_est (module docstring); inf where the pair cannot be accepted
    stand_in: bool  # whether the pair has a stand-in prior (the signals' grid is read over those)
    truth: tuple[np.ndarray, np.ndarray] | None  # the true (R, d) of the pair
    run: tuple[str, str]  # (cell, window start): one configuration's consecutive pairs
    R: np.ndarray | None
    d: np.ndarray | None
    parallax: float
    signals: dict[str, float]
    partners: list[_Pair] = field(default_factory=list)  # the estimates the loop escalates to, in order
    evidence: PairEvidence | None = None  # the estimate as the judge sees it (``_evidence``)


@dataclass
class _Known(PairEvidence):
    """An estimate whose R is already known (the table's rotation vector through Rodrigues, as ``matrix`` makes it)."""

    known: np.ndarray | None = None

    def matrix(self) -> np.ndarray:
        return self.known if self.known is not None else super().matrix()


def _rotation(rx: str, ry: str, rz: str) -> np.ndarray:
    import cv2

    R, _ = cv2.Rodrigues(np.array([[float(rx)], [float(ry)], [float(rz)]]))
    return np.asarray(R, dtype=float)


def _truth(r: Mapping[str, str]) -> tuple[np.ndarray, np.ndarray] | None:
    truth = [r.get(k, "") for k in ("true_rx", "true_ry", "true_rz", "true_dx", "true_dy", "true_dz")]
    if "" in truth:
        return None
    return _rotation(*truth[:3]), np.array([float(v) for v in truth[3:]])


def _coasting(truth: tuple[np.ndarray, np.ndarray], prior: tuple[np.ndarray, np.ndarray]) -> float:
    """The error of repeating the prior's motion (R_p, d_p) on a pair whose true motion is ``truth``."""
    return min(rotation_deg(truth[0].T @ prior[0]) + angle_between(prior[1], truth[1]), LOST_PAIR_DEG)


def _agents(tables: Iterable[Path]) -> dict[str, str]:
    out: dict[str, str] = {}
    for t in tables:
        with t.open(newline="") as f:
            for r in csv.DictReader(f):
                out[r["cell"]] = r.get("ctx.agent", "") or ""
    return out


def read(pair_tables: Sequence[Path], tables: Sequence[Path], escalations: int = 2) -> dict[str, list[_Pair]]:
    """Agent → its pairs with their signals (module docstring)."""
    agents = _agents(tables)
    by_cell: dict[str, list[dict[str, str]]] = defaultdict(list)
    for path in pair_tables:
        for r in read_pairs(path):
            by_cell[r["cell"]].append(r)
    pairs: list[tuple[str, _Pair]] = []
    for cell, rows in by_cell.items():
        rows.sort(key=lambda r: (r["window_start"], int(r["frame"])))
        prior: tuple[np.ndarray, np.ndarray] | None = None
        window = None
        for r in rows:
            if r["window_start"] != window:
                window, prior = r["window_start"], None
            estimated = r["rx"] != "" and r["lost"] == "0" and r["rejected"] == "0"
            R = _rotation(r["rx"], r["ry"], r["rz"]) if r["rx"] != "" else None
            d = np.array([float(r["dx"]), float(r["dy"]), float(r["dz"])]) if r["dx"] != "" else None
            errs = (r["rotation_error_deg"], r["direction_error_deg"])
            est_err = min(sum(float(e) for e in errs), LOST_PAIR_DEG) if estimated and "" not in errs else math.inf
            parallax = float(r["parallax_px"] or 0)
            sig: dict[str, float] = {}
            if estimated and R is not None and d is not None and prior is not None:
                sig["rotation_change"] = rotation_deg(prior[0].T @ R)
                sig["heading_change"] = angle_between(prior[0] @ prior[1], d)
            condition = f"{r['before']}→{r['after']}"  # the images' conditions: equal keys are equal images
            key = (r["dataset"], r["sequence"], condition, r["severity"], r["seed"], r["window_start"], r["frame"])
            truth = _truth(r)
            p = _Pair(key, r["extractor"], cell, int(r["frame"]), est_err, prior is not None, truth, (cell, r["window_start"]),
                      R if estimated else None, d if estimated else None, parallax, sig)
            p.evidence = _evidence(p, (float(r["rx"]), float(r["ry"]), float(r["rz"])) if estimated else None)
            pairs.append((agents.get(cell, ""), p))
            if math.isfinite(est_err) and est_err <= 2 * BAD_PAIR_DEG and R is not None and d is not None and parallax >= STILL_PX:
                prior = (R, d)  # what a verifier should have accepted (module docstring)
    # the loop escalates to at most N other extractors, best first: agreement is with those, one estimate each
    errors: dict[str, list[float]] = defaultdict(list)
    for _, p in pairs:
        errors[p.extractor].append(min(p.est_err, LOST_PAIR_DEG))
    order = sorted(errors, key=lambda x: (float(np.mean(errors[x])), x))
    same: dict[tuple[str, ...], list[_Pair]] = defaultdict(list)
    for _, p in pairs:
        same[p.key].append(p)
    for group in same.values():
        first: dict[str, _Pair] = {}
        for o in sorted(group, key=lambda o: o.cell):
            first.setdefault(o.extractor, o)
        for p in group:
            p.partners = [first[x] for x in order if x != p.extractor and x in first][:escalations]
            if p.R is None or p.d is None:
                continue
            others = [_disagreement(p, o) for o in p.partners if o.R is not None and o.d is not None]
            if others:
                p.signals["agreement"] = min(others)
    out: dict[str, list[_Pair]] = defaultdict(list)
    for agent, p in pairs:
        out[agent].append(p)
    return dict(out)


def _evidence(p: _Pair, rotation: tuple[float, float, float] | None) -> PairEvidence:
    """The estimate as the judge sees it: lost where it cannot be accepted (``_usable``)."""
    if _usable(p) and rotation is not None and p.R is not None and p.d is not None:
        return _Known(p.extractor, rotation=rotation, direction=(float(p.d[0]), float(p.d[1]), float(p.d[2])),
                      parallax_px=p.parallax, known=p.R)
    return _Known(p.extractor, parallax_px=p.parallax, rejected="lost")


def _grid(values: Sequence[float]) -> list[float]:
    return sorted({round(float(q), 2) for q in np.quantile(values, QUANTILES)}) if values else []


def _disagreement(a: _Pair, b: _Pair) -> float:
    assert a.R is not None and a.d is not None and b.R is not None and b.d is not None
    return rotation_deg(b.R.T @ a.R) + angle_between(b.d, a.d)


def _usable(p: _Pair) -> bool:
    return p.R is not None and p.d is not None and math.isfinite(p.est_err)


def policy(motion: tuple[float, float] | None, agreement: float | None, escalations: int) -> Policy:
    """The policy a combination stands for: ``accept pair if heading_change <= a and rotation_change <= b`` (``motion``),
    ``accept pair if agreement <= c`` (``agreement``), ``escalate at most`` ``escalations``. Neither: always fall back
    to the motion prior (one try, accepted only where there is no prior yet, as the loop does)."""
    rules = []
    if motion is not None:
        rules.append(AcceptRule((PairTest("heading_change", "<=", motion[0]), PairTest("rotation_change", "<=", motion[1])),
                                (), _FITTED))
    if agreement is not None:
        rules.append(AcceptRule((PairTest("agreement", "<=", agreement),), (), _FITTED))
    return Policy(tuple(rules), escalations) if rules else Policy((_NOTHING,), 0)


def simulate(pairs: Sequence[_Pair], motion: tuple[float, float] | None, agreement: float | None) -> tuple[float, int, int]:
    """Run the policy (``policy``) over each configuration's consecutive pairs as the loop would, with the loop's pair
    judge (``verification.PairJudge``: one per run, which keeps the motion prior — the last *accepted* step that
    translated — across a fallback), and return (mean pair error, accepted, pairs). Per pair it tries the
    configuration's own estimate, then its ``partners`` (the other extractors' estimates of the same pair, best
    first), until the judge accepts one or falls back; a fallback costs repeating the prior (``LOST_PAIR_DEG``
    without one). ``motion``: the (heading_change, rotation_change) bounds (None: no such rule); ``agreement``: the
    agreement bound (None: no such rule)."""
    runs: dict[tuple[str, str], list[_Pair]] = defaultdict(list)
    for p in pairs:
        runs[p.run].append(p)
    rule = policy(motion, agreement, max((len(p.partners) for p in pairs), default=0))
    total, accepted, n = 0.0, 0, 0
    for run in runs.values():
        run.sort(key=lambda p: p.frame)
        judge = PairJudge()
        for p in run:
            if p.truth is None:
                continue
            candidates = (p, *p.partners)
            judge.open(rule, candidates)
            tried: list[PairEvidence] = []
            for c in candidates:
                assert c.evidence is not None
                tried.append(c.evidence)
                v = judge.judge(tried)
                if v.action != NEXT:
                    break
            if v.action == ACCEPT and v.accepted is not None:
                total += candidates[v.accepted].est_err
                accepted += 1
            else:
                prior = judge.prior
                total += _coasting(p.truth, (prior.R, prior.direction)) if prior is not None else LOST_PAIR_DEG
            n += 1
    return (total / n if n else math.nan), accepted, n


def fit(pairs: Sequence[_Pair], max_extra_fallback: float = MAX_EXTRA_FALLBACK) -> tuple[tuple[float, float] | None, float | None, Fitted] | None:
    """The motion rule's bounds and the agreement rule's bound (either None: no such rule) with the least simulated
    cost, searched jointly over their signals' deciles (the agreement rule matters only where the motion rule
    does not accept, so the two are fitted together). A policy that falls back on more than ``max_extra_fallback``
    of the pairs beyond those no estimate survives is not a front end that tracks (``nfex evaluate`` fails a run
    past 30 % lost pairs) and is not considered."""
    with_prior = [p for p in pairs if p.stand_in]
    heading, rotation, agree = (_grid([p.signals[s] for p in with_prior if s in p.signals])
                                for s in ("heading_change", "rotation_change", "agreement"))
    if not with_prior:
        return None
    accept_all, taken, _ = simulate(pairs, (math.inf, math.inf), None)
    fall_back_all = simulate(pairs, None, None)[0]
    motions: list[tuple[float, float] | None] = [None, *((h, r) for h in heading for r in rotation)]
    agreements: list[float | None] = [None, *agree]
    best: tuple[tuple[float, float] | None, float | None, Fitted] | None = None
    for m in motions:
        for a in agreements:
            if m is None and a is None:
                continue
            cost, accepted, n = simulate(pairs, m, a)
            if (taken - accepted) / max(n, 1) > max_extra_fallback:
                continue
            if best is None or cost < best[2].cost - 1e-9:
                best = (m, a, Fitted(cost, accept_all, fall_back_all, n, accepted))
    return best




def learn(pair_tables: Sequence[Path], tables: Sequence[Path], *, min_pairs: int = 500,
          escalations: int = 2, max_extra_fallback: float = MAX_EXTRA_FALLBACK) -> tuple[str, list[dict[str, object]]]:
    """The verification program's text and one report row per fitted statement."""
    by_agent = read(pair_tables, tables, escalations)
    everyone = [p for ps in by_agent.values() for p in ps]
    groups: list[tuple[str | None, list[_Pair]]] = [(a, ps) for a, ps in sorted(by_agent.items()) if a and len(ps) >= min_pairs]
    if len(groups) < len(by_agent):
        groups.append((None, everyone))  # the agents with too few pairs of their own get the pooled fit
    sources = ", ".join(sorted({p.name for p in pair_tables}))
    lines = [
        "# Verification of frame pairs (docs/dsl.md, \"Verification\"; nfex_core/verification/judge.py).",
        "# Generated by `nfex program learn-verification` from the sweeps' pair tables — do not edit by hand:",
        f"# {sources}. Thresholds minimise the mean pair error (rotation + direction, °) of accepting or repeating the motion prior.",
        "",
        "program verification",
        "",
    ]
    report: list[dict[str, object]] = []
    fitted_agents = [a for a, _ in groups if a]
    for agent, ps in groups:
        when = f" when agent is {agent}" if agent else (f" when agent is not one of ({', '.join(fitted_agents)})" if fitted_agents else "")
        if when.endswith("one of ()"):
            when = ""
        fitted = fit(ps, max_extra_fallback)
        if fitted is None:
            continue
        motion, agreement, f = fitted
        why = (f"learned from {f.pairs} frame pairs of {sources}{' for agent ' + agent if agent else ''} by running the "
               f"policy over them: mean pair error {f.cost:.2f}° against {f.accept_all:.2f}° taking every checked "
               f"estimate and {f.fall_back_all:.2f}° always repeating the motion prior; {f.accepted} accepted")
        for tests in ([f"heading_change <= {motion[0]:g}", f"rotation_change <= {motion[1]:g}"] if motion else [],
                      [f"agreement <= {agreement:g}"] if agreement is not None else []):
            if not tests:
                continue
            lines += [f"accept pair if {' and '.join(tests)}{when}", f"    because {json.dumps(why, ensure_ascii=False)}"]
            report.append({"agent": agent or "(pooled)", "tests": " and ".join(tests), "cost": round(f.cost, 3),
                           "accept_all": round(f.accept_all, 3), "fall_back_all": round(f.fall_back_all, 3),
                           "pairs": f.pairs, "accepted": f.accepted})
    lines += [f"escalate at most {escalations}",
              "    because \"a prior, not learned: a pair costs at most 1 + N extractions; escalation goes to a different extractor\""]
    return "\n".join(lines) + "\n", report
