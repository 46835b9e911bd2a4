"""The methods of the paper's Table I as VO choosers (§V-B): ORB and SIFT with OpenCV's default
parameters, ORB and SIFT with "dynamically optimised" parameters, and nFEX.

- ``orb-default`` / ``sift-default``: the graph's defaults (OpenCV's); ``orb_grid-default``: the
  grid-spread ORB registry entry (issue 8) with its defaults.
- ``orb-dyn`` / ``sift-dyn``: per window, the parameters that a sweep on *other* sequences measured
  best for that extractor under the window's known conditions — the configuration with the lowest
  median ATE over the admitted Measurements that share a condition value with the window's context,
  excluding every measurement on the evaluated sequence (read from the graph; defaults where nothing was measured).
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
from ..evidence import Observation, admitted, read_observations, robust
from ..kg.terms import py
from ..vo import Choice, Chooser, FrameRecord, fixed

if TYPE_CHECKING:
    from ..kg.store import KnowledgeGraph

METHODS = ("orb-default", "sift-default", "orb-dyn", "sift-dyn", "nfex", "orb_grid-default")


def best_params(
    kg: KnowledgeGraph, extractor: str, context: Mapping[str, str], exclude_sequence: str | None
) -> tuple[dict[str, Any], str]:
    """The measured-best Θ for ``extractor`` under ``context`` on other sequences, and where it came from:
    the configuration with the lowest median ATE (evidence/aggregate.py) over the admitted Measurements
    (evidence/trust.py) that share a known condition value with ``context``, each window counted once."""
    vocab = kg.vocabulary()
    known = {(d, v) for d, v in context.items() if v and d in vocab.dimensions and v in vocab.dimensions[d].values}
    if not known:
        return {}, "defaults (no known condition)"
    per_cfg: dict[str, list[Observation]] = {}
    for o in admitted(kg, read_observations(kg)):
        if o.extractor == extractor and o.ate is not None and o.conditions & known and (
                exclude_sequence is None or o.sequence_label != exclude_sequence):
            per_cfg.setdefault(o.configuration, []).append(o)
    if not per_cfg:
        return {}, "defaults (nothing measured)"
    aggs = {cfg: robust([o.ate for o in obs if o.ate is not None], (o.source for o in obs)) for cfg, obs in per_cfg.items()}
    cfg, agg = min(aggs.items(), key=lambda kv: (kv[1].value, kv[0]))
    settings = kg.select(
        f"SELECT ?name ?v WHERE {{ <{cfg}> nfex:hasSetting ?s . ?s nfex:parameter/nfex:opencvName ?name ; nfex:value ?v }}"
    ).rows
    params = {str(r["name"]): py(r["v"]) for r in settings}
    return params, f"sweep: {cfg} {agg.describe()}"


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
                            "ate_m": c.evidence.measured.ate if c.evidence.measured else None}
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
