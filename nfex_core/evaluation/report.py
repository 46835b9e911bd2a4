"""An evaluation as tables (Markdown), CSV and the ``--json`` object.

Per condition, first the front-end table (``figures``): per method the pose AUC at 5/10/20° and the
front-end ATE, each a mean over the paired runs with its 95 % interval, the paired comparison of AUC@10° and of
the front-end ATE with the best static method by that figure, with the smallest relative difference the runs
could have detected (``stats``), and the lost and coasted pairs. Then, one row per method: mean monocular ATE
over the paired runs with its 95 % confidence interval, the
paired comparison with the best static method (Wilcoxon signed-rank p; ``stats``) — for a budgeted nFEX,
with the best static method whose expected cost fits that budget — RPE, extraction ms per frame (mean and
the largest single frame), the cost model's expected ms, candidates tried per pair, and lost / rejected /
fell-back pairs. Under a schedule, per-segment ATE and the transition pairs; with oracles, the headroom: where nFEX stands between the best
static method and the per-pair oracle.
"""
from __future__ import annotations

import csv
import io
import json
from typing import Any

import numpy as np

from .figures import BY_NAME, FIGURES, HEADLINE, Figure
from .methods import NFEX, ORACLES, TUNED
from .outcomes import MOTION_PRIOR, outcome
from .run import SCHEDULE, Evaluation, RunRecord
from .stats import Comparison, compare, summary


def display(key: str) -> str:
    """``orb_grid-dyn`` → ``ORB_GRID (dynamic)``; ``nfex@20ms`` → ``nFEX @ 20 ms``."""
    method, _, budget = key.partition("@")
    if method == NFEX:
        name = "nFEX"
    elif method == TUNED:
        name = "tuned static"
    elif method in ORACLES:
        name = method.replace("-", " ")
    elif method == MOTION_PRIOR:
        name = "motion prior (control)"
    else:
        x, _, kind = method.rpartition("-")
        name = f"{x.upper()} ({'dynamic' if kind == 'dyn' else kind})"
    return name + (f" @ {budget.removesuffix('ms')} ms" if budget else "")


def _budget(key: str) -> float | None:
    return float(key.partition("@")[2].removesuffix("ms")) if "@" in key else None


def comparison(ev: Evaluation, key: str, condition: str, figure: Figure = BY_NAME["ate"]) -> Comparison | None:
    """``key`` against the best static method by ``figure`` (that fits its budget, if it has one)."""
    ref = ev.best_static(condition, _budget(key), figure)
    if ref is None or ref == key:
        return None
    return compare(ev.values(key, condition, figure), ev.values(ref, condition, figure), ref, figure.higher_is_better)


def _num(x: float | None, fmt: str = ".3f") -> str:
    return "—" if x is None else format(x, fmt)


def verdict_text(c: Comparison | None, reference: bool) -> str:
    """``-12.3 %, p = 0.002: better (detectable ±8 %)``; ``(reference)``; ``—``."""
    if c is None or c.relative is None:
        return "(reference)" if reference else "—"
    mde = f"±{100 * c.detectable:.0f} %" if c.detectable is not None else f"none with {c.pairs} pairs"
    return f"{100 * c.relative:+.1f} %, p = {_num(c.p_wilcoxon)}: {c.verdict} (detectable {mde})"


def _mean_ci(s: Any, fmt: str = ".3f") -> str:
    return _num(s.mean, fmt) + (f" [{format(s.ci95[0], fmt)}, {format(s.ci95[1], fmt)}]" if s.ci95 else "")


def _frontend_row(ev: Evaluation, key: str, condition: str, recs: list[RunRecord]) -> list[str]:
    cells = [display(key)]
    for name in ("auc5", "auc10", "auc20"):
        cells.append(_mean_ci(summary(ev.values(key, condition, BY_NAME[name]))))
    is_ref = key in ev.static
    cells.append(verdict_text(comparison(ev, key, condition, HEADLINE),
                              is_ref and ev.best_static(condition, None, HEADLINE) == key))
    fe = BY_NAME["frontend_ate"]
    s = summary(ev.values(key, condition, fe))
    failed = sum(r.failed for r in recs)
    cells.append(_mean_ci(s) + (f" ({failed}/{len(recs)} fail)" if failed else ""))
    cells.append(verdict_text(comparison(ev, key, condition, fe), is_ref and ev.best_static(condition, None, fe) == key))
    cells.append(f"{sum(r.lost for r in recs)} / {sum(r.coasted for r in recs)}")
    return cells


def frontend_table(ev: Evaluation, condition: str) -> list[str]:
    head = ["Method", "AUC@5° [95 % CI]", "AUC@10°", "AUC@20°", "AUC@10° vs best static (Wilcoxon)",
            "front-end ATE (m)", "front-end ATE vs best static", "lost / coasted pairs"]
    lines = ["Front-end accuracy (pose AUC: a pair's error is the larger of its rotation and direction errors, a lost "
             "or coasted pair 180°; front-end ATE: each step's length from the ground truth, SE(3)):", "",
             "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for key in ev.keys():
        recs = ev.by_key(key, condition)
        if recs:
            lines.append("| " + " | ".join(_frontend_row(ev, key, condition, recs)) + " |")
    return lines


def _row(ev: Evaluation, key: str, condition: str, recs: list[RunRecord]) -> list[str]:
    s = summary(ev.ates(key, condition))
    ate = _num(s.mean) + (f" ({sum(r.failed for r in recs)}/{len(recs)} fail)" if any(r.failed for r in recs) else "")
    ci = f"{s.ci95[0]:.3f}–{s.ci95[1]:.3f}" if s.ci95 else "—"
    vs = verdict_text(comparison(ev, key, condition), ref_is(ev, key, condition))
    rpe = summary([r.rpe_rmse for r in recs if not r.failed]).mean
    ext = f"{np.mean([r.extraction_ms for r in recs]):.1f} / {max(r.extraction_max_ms for r in recs):.1f}"
    exp = [r.expected_ms for r in recs]
    expected = _num(float(np.mean(exp)), ".1f") if exp and all(e is not None for e in exp) else "—"  # type: ignore[arg-type]
    lost = (f"{sum(r.lost for r in recs)} / {sum(r.coasted for r in recs)} "
            f"({sum(r.rejected for r in recs)}, {sum(r.fell_back for r in recs)})")
    tries = f"{np.mean([r.tries for r in recs]):.2f} / {max(r.tries_max for r in recs)}"
    return [display(key), ate, ci, vs, _num(rpe), ext, expected, tries, lost]


def ref_is(ev: Evaluation, key: str, condition: str) -> bool:
    return key in ev.static and ev.best_static(condition) == key


def markdown(ev: Evaluation) -> str:
    lines: list[str] = []
    head = ["Method", "Mean ATE (m)", "95 % CI", "vs best static (Wilcoxon)", "RPE (m)", "extraction ms/frame mean / max",
            "expected ms", "tries/pair mean / max", "lost / coasted pairs (rejected, fell back)"]
    for condition in ev.conditions:
        title = f"schedule {ev.schedule.text}" if condition == SCHEDULE and ev.schedule else condition
        lines += [f"### {ev.dataset} {ev.sequence}: {title}", ""] + frontend_table(ev, condition) + [""]
        lines += ["Monocular ATE (Sim(3)) and cost:", "", "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
        for key in ev.keys():
            recs = ev.by_key(key, condition)
            if recs:
                lines.append("| " + " | ".join(_row(ev, key, condition, recs)) + " |")
        lines.append("")
        best = ev.best_static(condition)
        lines.append(f"Best static method: {display(best) if best else '—'}." + "".join(
            f" Best static within {b:g} ms: {display(m) if (m := ev.best_static(condition, b)) else 'none fits'}."
            for b in sorted({r.budget_ms for r in ev.records if r.budget_ms is not None})))
        lines.append("")
        if condition == SCHEDULE and ev.schedule:
            lines += _segment_table(ev, condition) + [""] + _transition_table(ev, condition) + [""]
        if any(r.method in ORACLES for r in ev.records):
            lines += _headroom(ev, condition) + [""]
    lines.append(
        f"{ev.dataset} {ev.sequence}, {ev.frames} frames, {ev.runs} paired runs per cell (run r: seed r for the corruption "
        f"draws and RANSAC, for every method); ATE/RPE RMSE after Sim(3) alignment; severity {ev.severity:g}; front-end "
        f"checks: {ev.checks}; evidence: {ev.scope}. Extraction ms/frame includes re-extracting the previous frame "
        "when the configuration changes; 'expected ms' is the cost model's (what a budget is judged by). "
        "A difference is claimed only where Wilcoxon's signed-rank p < 0.05; 'detectable' is the smallest relative "
        "difference these runs could have detected (α = 0.05, 80 % power). A run fails on loss beyond 30 % of its pairs "
        f"or coasting beyond {_num(ev.max_coasted, '.0%') if ev.max_coasted is not None else '—'} (nfex:maxCoastedFraction)"
        + (f"; {ev.control}" if ev.control else "") + "."
        + "".join(f" Not run on this sequence: {m} ({why})." for m, why in ev.skipped.items()))
    return "\n".join(lines) + "\n"


def _segment_table(ev: Evaluation, condition: str) -> list[str]:
    assert ev.schedule is not None
    segs = [s.label for s in ev.schedule.segments]
    lines = ["Per segment, mean over runs of the pose AUC@10° of the segment's pairs / the ATE (m) of its frames (one "
             "Sim(3) alignment of the whole run):", "",
             "| Method | " + " | ".join(segs) + " |", "|" + "---|" * (len(segs) + 1)]
    for key in ev.keys():
        recs = [r for r in ev.by_key(key, condition) if r.segments]
        if recs:
            cells = [_num(summary([next(x["ate"] for x in r.segments if x["segment"] == s) for r in recs]).mean)
                     for s in segs]
            auc = [_num(summary([next(x.get("auc10") for x in r.segments if x["segment"] == s) for r in recs]).mean)
                   for s in segs]
            lines.append(f"| {display(key)} | " + " | ".join(f"{a} / {c}" for a, c in zip(auc, cells, strict=True)) + " |")
    return lines


def _transition_table(ev: Evaluation, condition: str) -> list[str]:
    assert ev.schedule is not None
    names = [f"{k - 1}-{k} {ev.schedule.transition_name(k)}" for k in ev.schedule.transitions]
    lines = ["Transition pairs: lost or rejected in how many runs; median rotation error (°) of the estimates:", "",
             "| Method | " + " | ".join(names) + " |", "|" + "---|" * (len(names) + 1)]
    for key in ev.keys():
        recs = [r for r in ev.by_key(key, condition) if r.transitions]
        if not recs:
            continue
        cells = []
        for i in range(len(names)):
            rows = [r.transitions[i] for r in recs if i < len(r.transitions)]
            bad = sum(t["lost"] for t in rows)
            rot = [t["rotation_error_deg"] for t in rows if t["rotation_error_deg"] is not None]
            cells.append(f"{bad}/{len(rows)} lost, {np.median(rot):.1f}°" if rot else f"{bad}/{len(rows)} lost")
        lines.append(f"| {display(key)} | " + " | ".join(cells) + " |")
    return lines


def _headroom(ev: Evaluation, condition: str) -> list[str]:
    best = ev.best_static(condition)
    if best is None:
        return []
    means = {k: Evaluation.mean_ate(ev.by_key(k, condition)) for k in ev.keys()}
    b, pair = means.get(best), means.get("oracle-pair")
    lines = ["Headroom (mean ATE, m): best static → nFEX → oracles; share = (best static − method) / (best static − oracle pair):",
             "", "| | mean ATE | share of the headroom |", "|---|---|---|"]
    for key in [best, *[k for k in ev.keys() if k.startswith(NFEX)], *ORACLES]:
        m = means.get(key)
        share = "—"
        if b is not None and pair is not None and m is not None and b != pair:
            share = f"{100 * (b - m) / (b - pair):.0f} %"
        lines.append(f"| {display(key)} | {_num(m)} | {share} |")
    return lines


def csv_text(ev: Evaluation) -> str:
    buf = io.StringIO()
    w = csv.writer(buf)
    w.writerow(["method", "budget_ms", "condition", "run", "ate_rmse", "rpe_rmse", "failed", "lost_pairs", "rejected_pairs",
                "frames", "extraction_ms", "extraction_max_ms", "matching_ms", "expected_ms", "tries", "tries_max", "fell_back",
                "wall_s", "note", "coasted_pairs", "auc5", "auc10", "auc20", "frontend_ate", "dataset", "sequence"])
    for r in ev.records:
        w.writerow([r.method, "" if r.budget_ms is None else r.budget_ms, r.condition, r.run, _csv(r.ate_rmse), _csv(r.rpe_rmse),
                    int(r.failed), r.lost, r.rejected, r.frames, f"{r.extraction_ms:.3f}", f"{r.extraction_max_ms:.3f}",
                    f"{r.matching_ms:.3f}", _csv(r.expected_ms), f"{r.tries:.3f}", r.tries_max, r.fell_back, f"{r.wall_s:.2f}", r.note,
                    r.coasted, *(_csv(r.auc.get(t)) for t in (5.0, 10.0, 20.0)), _csv(r.frontend_ate), ev.dataset, ev.sequence])
    return buf.getvalue()


def _csv(x: float | None) -> str:
    return "" if x is None else f"{x:.6f}"


def frames_csv(ev: Evaluation) -> str:
    """One row per (method, condition, run, frame): the configuration run and what its pair showed."""
    buf = io.StringIO()
    w = csv.writer(buf)
    w.writerow(["method", "budget_ms", "condition", "run", "frame", "segment", "extractor", "params", "keypoints", "matches",
                "inliers", "lost", "reason", "rotation_error_deg", "direction_error_deg", "extraction_ms", "tries", "tried",
                "outcome", "pair_error_deg", "severity", "dataset", "sequence"])
    for r in ev.records:
        if r.result is None:
            continue
        err = r.front.error_deg if r.front is not None else None
        for f in r.result.frames:
            scheduled = r.condition == SCHEDULE and ev.schedule is not None
            seg = ev.schedule.segment_of(f.index).corruption if scheduled and ev.schedule else r.condition
            sev = ev.schedule.severity_at(f.index, ev.severity) if scheduled and ev.schedule else (
                0.0 if r.condition == "none" else ev.severity)
            w.writerow([r.method, "" if r.budget_ms is None else r.budget_ms, r.condition, r.run, f.index, seg, f.extractor,
                        json.dumps(f.params, sort_keys=True), f.keypoints, f.matches, f.inliers, int(f.lost), f.reason,
                        _csv(f.errors[0] if f.errors else None), _csv(f.errors[1] if f.errors else None),
                        f"{f.extraction_ms:.3f}", f.tries, json.dumps(f.verdict) if f.verdict else "",
                        outcome(f) if f.index > 0 else "", _csv(float(err[f.index - 1]) if err is not None and f.index > 0 else None),
                        f"{sev:g}", ev.dataset, ev.sequence])
    return buf.getvalue()


def selections_csv(ev: Evaluation) -> str:
    """nFEX's choice per frame and run with every candidate's score, F_metrics, measured accuracy A and
    mean ATE: one row per (run, frame, candidate); empty when no run asked the advisor."""
    buf = io.StringIO()
    w = csv.writer(buf)
    w.writerow(["method", "budget_ms", "condition", "run", "frame", "chosen", "mode", "candidate", "score",
                "f_metrics", "measured_accuracy", "ate_m"])
    for r in ev.records:
        for sel in r.selections:
            for c in sel.get("candidates", []):
                w.writerow([r.method, "" if r.budget_ms is None else r.budget_ms, r.condition, r.run, sel["frame"],
                            sel["extractor"], sel["mode"], c["extractor"], *("" if c[k] is None else c[k] for k in
                            ("score", "f_metrics", "measured_accuracy", "ate_m"))])
    return buf.getvalue()


def as_json(ev: Evaluation) -> dict[str, Any]:
    methods: dict[str, Any] = {}
    for key in ev.keys():
        by_condition: dict[str, Any] = {}
        for condition in ev.conditions:
            recs = ev.by_key(key, condition)
            if not recs:
                continue
            c = comparison(ev, key, condition)
            by_condition[condition] = {
                "ate": summary(ev.ates(key, condition)).as_dict(),
                "ate_runs": ev.ates(key, condition),
                "rpe_mean": summary([r.rpe_rmse for r in recs if not r.failed]).mean,
                "failed_runs": sum(r.failed for r in recs),
                "vs_best_static": c.as_dict() if c is not None else None,
                "extraction_ms_mean": float(np.mean([r.extraction_ms for r in recs])),
                "extraction_ms_max": max(r.extraction_max_ms for r in recs),
                "matching_ms_mean": float(np.mean([r.matching_ms for r in recs])),
                "expected_ms_mean": (float(np.mean([r.expected_ms for r in recs]))
                                     if all(r.expected_ms is not None for r in recs) else None),
                "lost_pairs": sum(r.lost for r in recs), "rejected_pairs": sum(r.rejected for r in recs),
                "fell_back_pairs": sum(r.fell_back for r in recs),
                "tries_per_pair_mean": float(np.mean([r.tries for r in recs])), "tries_per_pair_max": max(r.tries_max for r in recs),
                "coasted_pairs": sum(r.coasted for r in recs),
                "figures": {f.name: _figure_json(ev, key, condition, f) for f in FIGURES},
                "segments": [r.segments for r in recs] if recs[0].segments else None,
                "transitions": [r.transitions for r in recs] if recs[0].transitions else None,
                "note": recs[0].note,
            }
        first = by_condition.get(ev.conditions[0]) if ev.conditions else None
        methods[key] = {"ate_rmse_mean": first["ate"]["mean"] if first else None, "budget_ms": _budget(key),
                        "by_condition": by_condition}
    return {
        "dataset": ev.dataset, "sequence": ev.sequence, "frames": ev.frames, "runs": ev.runs, "severity": ev.severity,
        "schedule": ev.schedule.text if ev.schedule else None, "checks": ev.checks, "evidence": ev.scope,
        "skipped": ev.skipped,
        "conditions": ev.conditions, "statistics": "mean, 95 % CI (Student t), Wilcoxon signed-rank and paired t "
        "against the best static method over paired runs",
        "best_static": {c: ev.best_static(c) for c in ev.conditions},
        "best_static_by_figure": {c: {f.name: ev.best_static(c, None, f) for f in FIGURES} for c in ev.conditions},
        "max_coasted_fraction": ev.max_coasted, "control": ev.control, "methods": methods,
    }


def _figure_json(ev: Evaluation, key: str, condition: str, figure: Figure) -> dict[str, Any]:
    c = comparison(ev, key, condition, figure)
    values = ev.values(key, condition, figure)
    return {**summary(values).as_dict(), "runs": values, "higher_is_better": figure.higher_is_better,
            "vs_best_static": c.as_dict() if c is not None else None}
