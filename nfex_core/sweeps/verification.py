"""Learn the verification program (``accept pair if …``, ``escalate at most N``) from the sweeps' pair tables.

Input: the per-pair tables the sweeps write beside their training tables (``*-pairs.csv.gz``, ``table.py``) and
those training tables (for each cell's agent). Accepting a pair's estimate is the alternative to falling back to
the motion prior, so a pair is **good** — worth accepting — when its configuration estimated it (not lost, not
rejected by the front-end checks) and the estimate is closer to the true motion than the motion prior is
(rotation error + direction error, degrees, ``motion.pair_errors``); where there is no prior, when both its errors
are ≤ ``BAD_PAIR_DEG`` (5°). Per pair the run-time signals of ``verification.py`` are rebuilt from the table:

- the motion prior of a pair is the same cell's latest earlier pair that was estimated, not rejected and
  translated (parallax ≥ ``STILL_PX``) — what the VO keeps as its prior while that configuration runs;
  ``rotation_change`` and ``heading_change`` are measured against it;
- ``agreement``: the least disagreement with the estimate of another *extractor* on the same frame pair of the
  same sequence, condition (corruption or schedule), severity and seed.

For each agent with at least ``min_pairs`` pairs (else all agents pooled), two accept statements are fitted:

1. motion consistency: ``heading_change <= a and rotation_change <= b``; (a, b) on the grid of the signals'
   quantiles (5 %, 10 %, …, 95 %) maximising Youden's J = TPR − FPR of "accepted ⇒ good";
2. agreement: ``agreement <= c``, c maximising J the same way.

Every threshold is printed with its J, TPR, FPR and pair count, and written into each statement's reason, so a
selection that cites the statement says what it was learned from. ``escalate at most N`` is a prior (the cost of
a pair is then at most 1 + N extractions), written as such.
"""
from __future__ import annotations

import csv
import json
import math
from collections import defaultdict
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..motion import angle_between, rotation_deg
from ..verification import STILL_PX
from .cells import BAD_PAIR_DEG
from .table import read_pairs

QUANTILES = np.arange(0.05, 0.96, 0.05)


@dataclass(frozen=True)
class Fitted:
    signals: tuple[tuple[str, float], ...]  # (signal, threshold) tested with <=
    j: float
    tpr: float
    fpr: float
    pairs: int
    good: int


@dataclass
class _Pair:
    key: tuple[str, ...]  # the frame pair: dataset, sequence, condition, severity, seed, frame
    extractor: str
    cell: str
    frame: int
    good: bool
    R: np.ndarray | None
    d: np.ndarray | None
    parallax: float
    signals: dict[str, float]


def _rotation(rx: str, ry: str, rz: str) -> np.ndarray:
    import cv2

    R, _ = cv2.Rodrigues(np.array([[float(rx)], [float(ry)], [float(rz)]]))
    return np.asarray(R, dtype=float)


def _better_than_prior(r: Mapping[str, str], errors: Sequence[float], prior: tuple[np.ndarray, np.ndarray] | None) -> bool:
    """The label: the estimate is closer to the truth than the motion prior it would replace (rotation + direction
    error, degrees); without a prior (or without the true motion in the table), its errors are both ≤ 5°."""
    if not errors:
        return False
    truth = [r.get(k, "") for k in ("true_rx", "true_ry", "true_rz", "true_dx", "true_dy", "true_dz")]
    if prior is None or "" in truth:
        return max(errors) <= BAD_PAIR_DEG
    R_true = _rotation(*truth[:3])
    d_true = np.array([float(v) for v in truth[3:]])
    coasting = rotation_deg(R_true.T @ prior[0]) + angle_between(prior[1], d_true)
    return sum(errors) < coasting


def _agents(tables: Iterable[Path]) -> dict[str, str]:
    out: dict[str, str] = {}
    for t in tables:
        with t.open(newline="") as f:
            for r in csv.DictReader(f):
                out[r["cell"]] = r.get("ctx.agent", "") or ""
    return out


def read(pair_tables: Sequence[Path], tables: Sequence[Path]) -> dict[str, list[_Pair]]:
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
            good = estimated and "" not in errs and _better_than_prior(r, [float(e) for e in errs] if "" not in errs else [], prior)
            parallax = float(r["parallax_px"] or 0)
            sig: dict[str, float] = {}
            if estimated and R is not None and d is not None and prior is not None:
                sig["rotation_change"] = rotation_deg(prior[0].T @ R)
                sig["heading_change"] = angle_between(prior[0] @ prior[1], d)
            condition = f"{r['before']}→{r['after']}"  # the images' conditions: equal keys are equal images
            key = (r["dataset"], r["sequence"], condition, r["severity"], r["seed"], r["window_start"], r["frame"])
            p = _Pair(key, r["extractor"], cell, int(r["frame"]), good, R if estimated else None, d if estimated else None, parallax, sig)
            pairs.append((agents.get(cell, ""), p))
            if estimated and R is not None and d is not None and parallax >= STILL_PX:
                prior = (R, d)
    same: dict[tuple[str, ...], list[_Pair]] = defaultdict(list)
    for _, p in pairs:
        same[p.key].append(p)
    for group in same.values():
        for p in group:
            if p.R is None or p.d is None:
                continue
            others = [rotation_deg(o.R.T @ p.R) + angle_between(o.d, p.d) for o in group
                      if o.extractor != p.extractor and o.R is not None and o.d is not None]
            if others:
                p.signals["agreement"] = min(others)
    out: dict[str, list[_Pair]] = defaultdict(list)
    for agent, p in pairs:
        out[agent].append(p)
    return dict(out)


def _grid(values: Sequence[float]) -> list[float]:
    return sorted({round(float(q), 2) for q in np.quantile(values, QUANTILES)}) if values else []


def fit(pairs: Sequence[_Pair], signals: Sequence[str]) -> Fitted | None:
    """Thresholds on ``signals`` (all tested with <=) maximising Youden's J over the pairs where all are defined
    (a pair where one is undefined is not accepted by the statement, as at run time)."""
    good = sum(p.good for p in pairs)
    bad = len(pairs) - good
    if good == 0 or bad == 0:
        return None
    grids = [_grid([p.signals[s] for p in pairs if s in p.signals]) for s in signals]
    if any(not g for g in grids):
        return None
    best: Fitted | None = None
    for bounds in _product(grids):
        acc = [all(s in p.signals and p.signals[s] <= b for s, b in zip(signals, bounds, strict=True)) for p in pairs]
        tp = sum(a and p.good for a, p in zip(acc, pairs, strict=True))
        fp = sum(a and not p.good for a, p in zip(acc, pairs, strict=True))
        tpr, fpr = tp / good, fp / bad
        if best is None or tpr - fpr > best.j + 1e-12:
            best = Fitted(tuple(zip(signals, bounds, strict=True)), tpr - fpr, tpr, fpr, len(pairs), good)
    return best


def _product(grids: Sequence[Sequence[float]]) -> Iterable[tuple[float, ...]]:
    if not grids:
        yield ()
        return
    for v in grids[0]:
        for rest in _product(grids[1:]):
            yield (v, *rest)


RULES = (("heading_change", "rotation_change"), ("agreement",))


def learn(pair_tables: Sequence[Path], tables: Sequence[Path], *, min_pairs: int = 500,
          escalations: int = 2) -> tuple[str, list[dict[str, object]]]:
    """The verification program's text and one report row per fitted statement."""
    by_agent = read(pair_tables, tables)
    everyone = [p for ps in by_agent.values() for p in ps]
    groups: list[tuple[str | None, list[_Pair]]] = [(a, ps) for a, ps in sorted(by_agent.items()) if a and len(ps) >= min_pairs]
    if len(groups) < len(by_agent):
        groups.append((None, everyone))  # the agents with too few pairs of their own get the pooled fit
    sources = ", ".join(sorted({p.name for p in pair_tables}))
    lines = [
        "# Verification of frame pairs (docs/dsl.md, \"Verification\"; nfex_core/verification.py).",
        "# Generated by `nfex program learn-verification` from the sweeps' pair tables — do not edit by hand:",
        f"# {sources}. Thresholds maximise Youden's J of \"accepted ⇒ the estimate beats the motion prior\".",
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
        for signals in RULES:
            f = fit(ps, signals)
            if f is None:
                continue
            tests = " and ".join(f"{s} <= {b:g}" for s, b in f.signals)
            why = (f"learned from {f.pairs} frame pairs ({f.good} good) of {sources}"
                   f"{' for agent ' + agent if agent else ''}: J {f.j:.2f}, TPR {f.tpr:.2f}, FPR {f.fpr:.2f}")
            lines += [f"accept pair if {tests}{when}", f"    because {json.dumps(why, ensure_ascii=False)}"]
            report.append({"agent": agent or "(pooled)", "tests": tests, "j": round(f.j, 3), "tpr": round(f.tpr, 3),
                           "fpr": round(f.fpr, 3), "pairs": f.pairs, "good": f.good})
    lines += [f"escalate at most {escalations}",
              "    because \"a prior, not learned: a pair costs at most 1 + N extractions; escalation goes to a different extractor\""]
    return "\n".join(lines) + "\n", report


def quantile_summary(pairs: Mapping[str, Sequence[_Pair]]) -> dict[str, dict[str, float]]:
    """Per signal: the median among good and among bad pairs (for the docs' table)."""
    out: dict[str, dict[str, float]] = {}
    everyone = [p for ps in pairs.values() for p in ps]
    for s in ("rotation_change", "heading_change", "agreement"):
        g = [p.signals[s] for p in everyone if s in p.signals and p.good]
        b = [p.signals[s] for p in everyone if s in p.signals and not p.good]
        out[s] = {"good_median": float(np.median(g)) if g else math.nan, "bad_median": float(np.median(b)) if b else math.nan,
                  "good": len(g), "bad": len(b)}
    return out
