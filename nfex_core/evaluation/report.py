"""Table I of the paper for the data at hand (Mean ATE over R runs, "fail" where every run failed),
with extraction and extraction + matching ms/frame columns (issue 8), as Markdown, CSV and the ``--json`` object."""
from __future__ import annotations

import csv
import io
from typing import Any

import numpy as np

from .run import Evaluation

NAMES = {"orb-default": "ORB (default)", "sift-default": "SIFT (default)", "orb-dyn": "ORB (dynamic)",
         "sift-dyn": "SIFT (dynamic)", "nfex": "nFEX", "orb_grid-default": "ORB grid (default)"}


def _ate_text(ev: Evaluation, recs: list[Any]) -> str:
    m = ev.mean_ate(recs)
    if m is None:
        return "fail"
    failed = sum(r.failed for r in recs)
    return f"{m:.3f}" + (f" ({failed}/{len(recs)} fail)" if failed else "")


def rows(ev: Evaluation) -> list[tuple[str, float | None, list[Any]]]:
    out: list[tuple[str, float | None, list[Any]]] = [(m, None, ev.cell(m)) for m in ev.methods()]
    budgets = sorted({r.budget_ms for r in ev.records if r.budget_ms is not None})
    out += [("nfex", b, ev.cell("nfex", budget=b)) for b in budgets]
    return out


def markdown(ev: Evaluation) -> str:
    corr = ev.corruptions()
    head = ["Method", *[f"Mean ATE (m), {c}" for c in corr], "extraction ms/frame", "ms/frame", "lost frames"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for method, budget, recs in rows(ev):
        name = NAMES.get(method, method) + (f" @ {budget:g} ms" if budget is not None else "")
        cells = [_ate_text(ev, [r for r in recs if r.corruption == c]) for c in corr]
        ms = float(np.mean([r.ms_per_frame for r in recs])) if recs else float("nan")
        ext = float(np.mean([r.extraction_ms for r in recs])) if recs else float("nan")
        lost = sum(r.lost for r in recs)
        lines.append("| " + " | ".join([name, *cells, f"{ext:.1f}", f"{ms:.1f}", str(lost)]) + " |")
    runs = max((r.run for r in ev.records), default=0) + 1
    lines.append("")
    lines.append(f"{ev.dataset} {ev.sequence}, {ev.frames} frames, {runs} run(s) per cell; ATE RMSE after Sim(3) "
                 "alignment; extraction ms/frame is what a budget bounds (it includes re-extracting the previous frame when the "
                 "configuration changes); ms/frame = extraction + matching, mean per frame.")
    return "\n".join(lines) + "\n"


def csv_text(ev: Evaluation) -> str:
    buf = io.StringIO()
    w = csv.writer(buf)
    w.writerow(["method", "budget_ms", "corruption", "run", "ate_rmse", "failed", "lost_frames", "frames",
                "extraction_ms", "matching_ms", "ms_per_frame", "wall_s", "note"])
    for r in ev.records:
        w.writerow([r.method, "" if r.budget_ms is None else r.budget_ms, r.corruption, r.run,
                    "" if r.ate_rmse is None else f"{r.ate_rmse:.6f}", int(r.failed), r.lost, r.frames,
                    f"{r.extraction_ms:.3f}", f"{r.matching_ms:.3f}", f"{r.ms_per_frame:.3f}", f"{r.wall_s:.2f}", r.note])
    return buf.getvalue()


def selections_csv(ev: Evaluation) -> str:
    """nFEX's choice per frame and run with every candidate's score, F_metrics, measured accuracy A and
    mean ATE: one row per (run, frame, candidate); empty when no run asked the advisor."""
    buf = io.StringIO()
    w = csv.writer(buf)
    w.writerow(["method", "budget_ms", "corruption", "run", "frame", "chosen", "mode", "candidate", "score",
                "f_metrics", "measured_accuracy", "ate_m"])
    for r in ev.records:
        for sel in r.selections:
            for c in sel.get("candidates", []):
                w.writerow([r.method, "" if r.budget_ms is None else r.budget_ms, r.corruption, r.run, sel["frame"],
                            sel["extractor"], sel["mode"], c["extractor"], *("" if c[k] is None else c[k] for k in
                            ("score", "f_metrics", "measured_accuracy", "ate_m"))])
    return buf.getvalue()


def as_json(ev: Evaluation) -> dict[str, Any]:
    methods: dict[str, Any] = {}
    for method, budget, recs in rows(ev):
        key = method if budget is None else f"{method}@{budget:g}ms"
        methods[key] = {
            "ate_rmse_mean": ev.mean_ate(recs),
            "runs": len(recs),
            "failed_runs": sum(r.failed for r in recs),
            "ms_per_frame": float(np.mean([r.ms_per_frame for r in recs])) if recs else None,
            "extraction_ms": float(np.mean([r.extraction_ms for r in recs])) if recs else None,
            "lost_frames": sum(r.lost for r in recs),
            "budget_ms": budget,
            "by_corruption": {c: {"ate_rmse_mean": ev.mean_ate([r for r in recs if r.corruption == c]),
                                  "failed_runs": sum(r.failed for r in recs if r.corruption == c)}
                              for c in ev.corruptions()},
            "note": recs[0].note if recs else "",
        }
    return {"dataset": ev.dataset, "sequence": ev.sequence, "frames": ev.frames, "methods": methods}
