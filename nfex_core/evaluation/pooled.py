"""Several sequences in one evaluation, each held out of the evidence it is judged by, and pooled.

``evaluate_sequences`` runs ``evaluate`` per sequence with the same methods, conditions and paired runs. Each
evaluation holds its own sequence out of every reader (``kg.scope``); the measurements of the *other* evaluated
sequences stay in scope: leave-one-sequence-out, so a method is never judged on a sequence whose measurements
chose its parameters.

Pooling (per condition and figure, ``figures``):

- the reference is the static method with the best mean rank over the sequences by that figure (per
  sequence as ``Evaluation.best_static`` ranks: failed runs first where a failed run has no value, then the
  mean; ties by the mean ratio, then the name); under a budget, among those that fit it on every sequence;
- the paired test runs over the (sequence, run) pairs where both methods have a value. A figure in metres is
  divided, per sequence, by the reference's mean there (a long sequence drifts more; pooling metres would let
  it decide alone), so the pooled mean of a method is its mean ratio to the reference's mean (about 1 for the
  reference itself); AUC and pair counts pool as they are;
- the detectable difference is ``stats.detectable`` over the pooled pairs.
"""
from __future__ import annotations

from collections.abc import Sequence as Seq
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from .figures import BY_NAME, FIGURES, HEADLINE, Figure, rank
from .run import Evaluation, evaluate
from .stats import Comparison, compare, summary

if TYPE_CHECKING:
    from nfex_slam.datasets.base import Sequence

    from ..kg.store import KnowledgeGraph


@dataclass
class Study:
    """The evaluations of one command, a sequence each."""

    evaluations: list[Evaluation]

    @property
    def labels(self) -> list[str]:
        return [ev.label for ev in self.evaluations]

    def keys(self) -> list[str]:
        return list(dict.fromkeys(k for ev in self.evaluations for k in ev.keys()))

    def conditions(self) -> list[str]:
        return list(dict.fromkeys(c for ev in self.evaluations for c in ev.conditions))

    def static(self) -> list[str]:
        return [m for m in self.evaluations[0].static if all(m in ev.static for ev in self.evaluations)]


def evaluate_sequences(sequences: Seq[Sequence], kg: KnowledgeGraph, **kwargs: Any) -> Study:
    """``evaluate`` on each sequence with the same arguments (module docstring)."""
    from nfex_slam.datasets.schedule import Schedule

    from ..errors import BadInput

    labels = [f"{s.dataset}/{s.name}" for s in sequences]
    twice = sorted({x for x in labels if labels.count(x) > 1})
    if twice:
        raise BadInput(f"a sequence is given twice: {', '.join(twice)}")
    if kwargs.get("schedule"):  # a schedule must fit every sequence: fail before any run
        frames = kwargs.get("frames")
        for label, s in zip(labels, sequences, strict=True):
            try:
                Schedule.parse(kwargs["schedule"], min(frames, len(s)) if frames else len(s))
            except BadInput as e:
                raise BadInput(f"{label}: {e}") from e
    return Study([evaluate(s, kg, **kwargs) for s in sequences])


def _mean(values: Seq[float | None]) -> float | None:
    ok = [v for v in values if v is not None]
    return float(np.mean(ok)) if ok else None


def _fits(ev: Evaluation, method: str, condition: str, budget: float | None) -> bool:
    if budget is None:
        return True
    exp = [r.expected_ms for r in ev.by_key(method, condition)]
    return bool(exp) and all(e is not None for e in exp) and float(np.mean([e for e in exp if e is not None])) <= budget


def reference(study: Study, condition: str, figure: Figure, budget: float | None = None) -> str | None:
    """The pooled best static method by ``figure`` (module docstring)."""
    candidates = [m for m in study.static() if all(_fits(ev, m, condition, budget) for ev in study.evaluations)]
    if not candidates:
        return None
    ranks: dict[str, list[int]] = {m: [] for m in candidates}
    for ev in study.evaluations:
        def key(m: str, ev: Evaluation = ev) -> tuple[int, float, str]:
            recs = ev.by_key(m, condition)
            return (*rank(figure, sum(r.failed for r in recs), _mean(ev.values(m, condition, figure))), m)

        for i, m in enumerate(sorted(candidates, key=key)):
            ranks[m].append(i)
    return min(candidates, key=lambda m: (float(np.mean(ranks[m])), m))


def paired(study: Study, key: str, ref: str, condition: str, figure: Figure) -> tuple[list[float | None], list[float | None]]:
    """The two methods' values over the (sequence, run) pairs, divided by the reference's mean per sequence
    where the figure pools by ratio."""
    a: list[float | None] = []
    b: list[float | None] = []
    for ev in study.evaluations:
        x, y = ev.values(key, condition, figure), ev.values(ref, condition, figure)
        if len(x) != len(y):
            continue
        scale = 1.0
        if figure.pool_by_ratio:
            m = _mean(y)
            if m is None or m == 0:
                continue
            scale = m
        a += [None if v is None else v / scale for v in x]
        b += [None if v is None else v / scale for v in y]
    return a, b


def _budget(key: str) -> float | None:
    return float(key.partition("@")[2].removesuffix("ms")) if "@" in key else None


def pooled_figure(study: Study, key: str, condition: str, figure: Figure) -> dict[str, Any]:
    """One method's pooled figure: its mean and interval (a ratio to the reference where the figure pools
    by ratio) and the paired comparison with the pooled reference."""
    ref = reference(study, condition, figure, _budget(key))
    if ref is None:
        return {"reference": None, "n": 0, "mean": None, "ci95": None, "vs_best_static": None}
    a, b = paired(study, key, ref, condition, figure)
    c = compare(a, b, ref, figure.higher_is_better) if ref != key else None
    return {**summary(a).as_dict(), "reference": ref,
            "scale": f"ratio to {ref}'s mean per sequence" if figure.pool_by_ratio else "as measured",
            "vs_best_static": c.as_dict() if c is not None else None}


def pooled_json(study: Study) -> dict[str, Any]:
    conditions: dict[str, Any] = {}
    for c in study.conditions():
        conditions[c] = {
            "best_static": {f.name: reference(study, c, f) for f in FIGURES},
            "methods": {k: {f.name: pooled_figure(study, k, c, f) for f in FIGURES} for k in study.keys()},
        }
    return {"sequences": study.labels, "pairs": "(sequence, run)", "conditions": conditions}


def pooled_markdown(study: Study) -> str:
    from .report import display, verdict_text

    names = ("auc10", "frontend_ate", "ate")
    head = ["Method", *[f"{BY_NAME[n].title} [95 % CI]" + (" ÷ best static" if BY_NAME[n].pool_by_ratio else "")
                        + " | vs best static" for n in names], "lost / coasted pairs"]
    lines: list[str] = []
    for c in study.conditions():
        lines += [f"### Pooled over {', '.join(study.labels)}: {c}", "",
                  "| " + " | ".join(head) + " |", "|" + "---|" * (1 + 2 * len(names) + 1)]
        for key in study.keys():
            cells = [display(key)]
            for n in names:
                p = pooled_figure(study, key, c, BY_NAME[n])
                ci = p["ci95"]
                cells.append("—" if p["mean"] is None else f"{p['mean']:.3f}" + (f" [{ci[0]:.3f}, {ci[1]:.3f}]" if ci else ""))
                v = p["vs_best_static"]
                comp = Comparison(v["reference"], v["pairs"], v["relative"], v["p_wilcoxon"], v["p_ttest"],
                                  v["detectable_relative"], BY_NAME[n].higher_is_better) if v else None
                cells.append(verdict_text(comp, p["reference"] == key))
            recs = [r for ev in study.evaluations for r in ev.by_key(key, c)]
            cells.append(f"{sum(r.lost for r in recs)} / {sum(r.coasted for r in recs)}")
            lines.append("| " + " | ".join(cells) + " |")
        lines += ["", f"Best static by mean rank over the sequences: {display(ref) if (ref := reference(study, c, HEADLINE)) else '—'} "
                  f"({HEADLINE.title}). Paired tests over the (sequence, run) pairs; ATE divided by the reference's mean on "
                  "each sequence before pooling.", ""]
    return "\n".join(lines) + "\n"


def study_markdown(study: Study) -> str:
    """Every sequence's tables, then (with several sequences) the pooled ones."""
    from .report import markdown

    parts = [markdown(ev) for ev in study.evaluations]
    if len(study.evaluations) > 1:
        parts.append(pooled_markdown(study))
    return "\n".join(parts)


def study_json(study: Study) -> dict[str, Any]:
    """One sequence: its object (``report.as_json``) with ``pooled`` beside; several: ``sequences`` by label."""
    from .report import as_json

    pooled = pooled_json(study)
    if len(study.evaluations) == 1:
        return {**as_json(study.evaluations[0]), "sequence_labels": study.labels, "pooled": pooled}
    first = study.evaluations[0]
    return {"sequence_labels": study.labels, "runs": first.runs, "conditions": study.conditions(),
            "severity": first.severity, "schedule": first.schedule.text if first.schedule else None,
            "sequences": {ev.label: as_json(ev) for ev in study.evaluations}, "pooled": pooled}


def concat_csv(texts: Seq[str]) -> str:
    """CSV texts with one header (each text's first line is the same header)."""
    if not texts:
        return ""
    head, *_ = texts[0].splitlines(keepends=True) or [""]
    return head + "".join("".join(t.splitlines(keepends=True)[1:]) for t in texts)


__all__ = ["Study", "concat_csv", "evaluate_sequences", "paired", "pooled_figure", "pooled_json", "pooled_markdown", "reference",
           "study_json", "study_markdown"]
