"""The methods of the paper's Table I as VO choosers (§V-B): ORB and SIFT with OpenCV's default
parameters, ORB and SIFT with "dynamically optimised" parameters, and nFEX.

- ``orb-default`` / ``sift-default``: the graph's defaults (OpenCV's); ``orb_grid-default``: the
  grid-spread ORB registry entry (issue 8) with its defaults.
- ``orb-dyn`` / ``sift-dyn``: per window, the parameters that a sweep on *other* sequences measured
  best for that extractor under the window's known conditions — the configuration with the lowest
  mean ATE over Measurements that share a condition value with the window's context, excluding every
  measurement on the evaluated sequence (read from the graph; defaults where nothing was measured).
- ``nfex``: the advisor (DESIGN.md, "The one flow") per frame, with its stream state, through the VO
  chooser; an optional per-frame budget (ms) is passed where the advisor accepts one.
"""
from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from ..datasets.base import Frame
from ..errors import BadInput
from ..kg.terms import py
from ..vo import Choice, Chooser, FrameRecord, fixed

if TYPE_CHECKING:
    from ..kg.store import KnowledgeGraph

METHODS = ("orb-default", "sift-default", "orb-dyn", "sift-dyn", "nfex", "orb_grid-default")


def best_params(
    kg: KnowledgeGraph, extractor: str, context: Mapping[str, str], exclude_sequence: str | None
) -> tuple[dict[str, Any], str]:
    """The measured-best Θ for ``extractor`` under ``context`` on other sequences, and where it came from."""
    vocab = kg.vocabulary()
    conds = []
    for d, v in context.items():
        if v and d in vocab.dimensions and v in vocab.dimensions[d].values:
            conds.append(f"<{vocab.condition_value(d, v).iri}>")
    if not conds:
        return {}, "defaults (no known condition)"
    exclude = f'FILTER NOT EXISTS {{ ?m nfex:sequence/rdfs:label "{exclude_sequence}" }}' if exclude_sequence else ""
    rows = kg.select(
        f"""SELECT ?cfg (AVG(?ate) AS ?mean) (COUNT(?m) AS ?n) WHERE {{
            ?m a nfex:Measurement ; sosa:usedProcedure ?cfg ; nfex:ateRmse ?ate ; nfex:underCondition ?c .
            ?cfg nfex:ofExtractor/nfex:token "{extractor}" .
            VALUES ?c {{ {' '.join(conds)} }}
            {exclude}
        }} GROUP BY ?cfg ORDER BY ?mean LIMIT 1"""
    ).rows
    if not rows:
        return {}, "defaults (nothing measured)"
    cfg = rows[0]["cfg"]
    settings = kg.select(
        f"SELECT ?name ?v WHERE {{ <{cfg}> nfex:hasSetting ?s . ?s nfex:parameter/nfex:opencvName ?name ; nfex:value ?v }}"
    ).rows
    params = {str(r["name"]): py(r["v"]) for r in settings}
    n = int(py(rows[0]["n"]))
    return params, f"sweep: {cfg} mean ATE {float(py(rows[0]['mean'])):.3f} m over {n} windows"



@dataclass
class AdvisorChooser:
    """The nFEX advisor as a VO chooser: one selection per frame, the stream state carried along."""

    advisor: Any
    context: Mapping[str, str]
    budget_ms: float | None = None
    every: int = 1
    selections: list[dict[str, Any]] = field(default_factory=list)
    _state: Any = None
    _last: Choice | None = None

    def __call__(self, frame: Frame, history: list[FrameRecord]) -> Choice:
        if self._last is not None and frame.index % self.every:
            return self._last
        ctx = {**self.context, **frame.context}
        sel = self.advisor.select(ctx, frame.image, self._state, budget_ms=self.budget_ms)
        self._state = sel.state
        self._last = Choice(sel.extractor, dict(sel.params))
        self.selections.append({
            "frame": frame.index, "extractor": sel.extractor, "params": sel.params, "mode": sel.mode,
            "pruned": [p.extractor for p in sel.pruned],
            "candidates": [{"extractor": c.extractor, "score": c.score, "f_metrics": c.evidence.f_metrics,
                            "measured_accuracy": c.evidence.measured_accuracy,
                            "mean_ate_m": c.evidence.measured.mean_ate if c.evidence.measured else None}
                           for c in sel.candidates],
        })
        return self._last


def chooser_for(
    method: str, kg: KnowledgeGraph, context: Mapping[str, str], sequence_label: str, budget_ms: float | None = None
) -> tuple[Chooser, str]:
    """The chooser of ``method`` and a note saying which parameters it runs with."""
    if method in ("orb-default", "sift-default", "orb_grid-default"):
        return fixed(method.split("-")[0].upper()), "OpenCV defaults"
    if method in ("orb-dyn", "sift-dyn"):
        x = method.split("-")[0].upper()
        params, note = best_params(kg, x, context, sequence_label)
        return fixed(x, params), note + (" " + json.dumps(params, sort_keys=True) if params else "")
    if method == "nfex":
        from ..advisor import Advisor

        return AdvisorChooser(Advisor(kg), context, budget_ms), "advisor per frame" + (
            f", budget {budget_ms} ms" if budget_ms is not None else "")
    raise BadInput(f"unknown method {method!r}; known: {', '.join(METHODS)}")
