"""What the advisor answers: the extractor α*, its parameters Θ′, and why.

Typed dataclasses; the JSON the CLI prints and the service returns is rendered here, in one place
(``as_dict``), from these types. The service's response schema (service/schemas/selection.py) describes it.
"""
from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from ..context import ContextEntry
from ..evidence import ROBUST
from ..evidence.cost import Estimate
from ..kg.vocab import Value
from ..rules.types import NO_POLICY, Adjustment, Citation, Evidence, Factor, MeasuredConfiguration, Policy

__all__ = ["CandidateEvidence", "CandidateScore", "ContextEntry", "PrunedCandidate", "Scoring", "Selection"]

SCORED, SETTLED, UNSCORED = "scored", "settled", "unscored"


@dataclass(frozen=True)
class Scoring:
    """How α* was reached on this request, and the work it took:

    - ``outcome``: ``scored`` (α* was extracted and scored on the frame), ``settled`` (bounds settled α* without
      extracting it: advisor/bounds.py, or SelectorNet's interval bounds), ``unscored`` (no frame, or a stream's
      decision reused);
    - ``reason``: why, in words;
    - ``extractions`` / ``pixels``: feature extractions run for this answer (the previous frame's owed ones
      included) and the pixels they processed."""

    outcome: str
    reason: str
    extractions: int = 0
    pixels: int = 0

    def as_dict(self) -> dict[str, Any]:
        return {"outcome": self.outcome, "reason": self.reason, "extractions": self.extractions, "pixels": self.pixels}


@dataclass(frozen=True)
class CandidateEvidence:
    """What stands behind one candidate's Θ′ and score.

    - ``measured``: the graph's measurements of α under the context's known conditions (the Decision's);
    - ``params_source``: which source of the Θ′ chain set Θ′ (``measured`` | ``paramnet`` | ``rules``);
    - ``configuration`` / ``configuration_because``: the measured configuration Θ′ was taken from;
    - ``cost``: the expected extraction time under a budget (None without one);
    - ``f_metrics``, ``measured_accuracy``: the two terms of the frame score F_metrics + H·A;
    - ``score_without_net``: the score before SelectorNet replaced it by its probability;
    - ``not_scored``: why the candidate has no score: not extracted because it could not win (scoring.Scorer), or
      SelectorNet settled the choice by bounds.
    """

    measured: Evidence | None = None
    params_source: str | None = None
    configuration: MeasuredConfiguration | None = None
    configuration_because: Citation | None = None
    cost: Estimate | None = None
    f_metrics: float | None = None
    measured_accuracy: float | None = None
    score_without_net: float | None = None
    not_scored: str | None = None

    @property
    def expected_ms(self) -> float | None:
        return self.cost.ms if self.cost is not None else None

    def as_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {}
        if self.measured is not None:
            out.update(self.measured.as_dict())
        if self.params_source is not None:
            out["params_source"] = self.params_source
        if self.configuration is not None:
            c = self.configuration
            out["configuration"] = {"iri": c.iri, "ate_m": round(c.ate, 6), "aggregate": ROBUST, "windows": c.windows,
                                    "outliers": c.outliers, "sources": len(c.sources),
                                    "because": self.configuration_because.as_dict() if self.configuration_because else None}
        if self.cost is not None:
            out["expected_ms"] = round(self.cost.ms, 3) if self.cost.ms is not None else None
            out["cost_source"] = self.cost.source
        if self.f_metrics is not None:
            out["f_metrics"] = self.f_metrics
        if self.measured_accuracy is not None:
            out["measured_accuracy"] = round(self.measured_accuracy, 6)
        if self.score_without_net is not None:
            out["score_without_net"] = self.score_without_net
        if self.not_scored is not None:
            out["not_scored"] = self.not_scored
        return out


@dataclass(frozen=True)
class CandidateScore:
    extractor: str
    params: dict[str, Value]
    score: float | None
    bonus: float = 0.0
    metrics: dict[str, float] = field(default_factory=dict)
    adjustments: tuple[Adjustment, ...] = ()
    keypoints: int | None = None
    extraction_ms: float | None = None
    evidence: CandidateEvidence = field(default_factory=CandidateEvidence)

    def as_dict(self) -> dict[str, Any]:
        return {
            "extractor": self.extractor,
            "score": self.score,
            "bonus": self.bonus,
            "metrics": self.metrics,
            "params": self.params,
            "adjustments": [a.as_dict() for a in self.adjustments],
            "keypoints": self.keypoints,
            "extraction_ms": self.extraction_ms,
            "evidence": self.evidence.as_dict(),
        }


@dataclass(frozen=True)
class PrunedCandidate:
    extractor: str
    because: tuple[Citation, ...]

    def as_dict(self) -> dict[str, Any]:
        return {"extractor": self.extractor, "because": [c.as_dict() for c in self.because]}


@dataclass(frozen=True)
class Selection:
    extractor: str
    params: dict[str, Value]
    mode: str  # "metrics" (F_metrics on the frame) | "prior" (no frame: rules and measurements) | "selectornet"
    candidates: tuple[CandidateScore, ...]  # best first: the order in which a verifying client tries them
    pruned: tuple[PrunedCandidate, ...]
    context: tuple[ContextEntry, ...]
    weights: dict[str, Factor]
    versions: dict[str, Any]
    timings_ms: dict[str, float]
    opencv: dict[str, Any] = field(default_factory=dict)  # ExtractorSpec.opencv: constructor, norm, args, grid
    state: Any = field(default=None, compare=False, repr=False)  # for the next frame of a stream
    budget: dict[str, Any] | None = None  # the per-frame budget in force (ms, source, compute, frame size)
    warnings: tuple[str, ...] = ()
    verification: Policy = NO_POLICY  # how the client (or the VO) judges each proposal's pair estimate
    escalations: tuple[CandidateScore, ...] = ()  # under a budget: candidates within the per-frame cap, best first
    reused: int = 0  # in a stream: frames this answer has been reused without scoring (advisor/reuse.py); 0: scored here
    scoring: Scoring | None = None  # how α* was reached and the extractions it took
    recipe: Callable[[str, Mapping[str, Value]], dict[str, Any]] | None = field(default=None, compare=False, repr=False)
    # (extractor, Θ′) → its ``opencv`` (ExtractorSpec.opencv): each proposal carries one, so a client runs it as the server would

    @property
    def proposals(self) -> tuple[CandidateScore, ...]:
        """The candidates to try on the frame pair, in order: the best of each extractor (escalation goes to a
        *different* extractor, whose errors are less correlated), then under a budget the extractors that fit only
        the per-frame cap; at most the policy's 1 + N; α* alone without verification."""
        out: dict[str, CandidateScore] = {}
        for c in (*self.candidates, *self.escalations):
            out.setdefault(c.extractor, c)
        return tuple(out.values())[: self.verification.max_tries]

    @property
    def constructor(self) -> str:
        return str(self.opencv.get("constructor", ""))

    @property
    def norm(self) -> str:
        return str(self.opencv.get("norm", ""))

    def as_dict(self) -> dict[str, Any]:
        return {
            "extractor": self.extractor,
            "params": self.params,
            "opencv": self.opencv,
            "mode": self.mode,
            "candidates": [c.as_dict() for c in self.candidates],
            "pruned": [p.as_dict() for p in self.pruned],
            "context": [c.as_dict() for c in self.context],
            "weights": {
                m: {"value": f.value, "because": [c.as_dict() for c in f.citations]} for m, f in self.weights.items()
            },
            "budget": self.budget,
            "verification": {
                "max_tries": self.verification.max_tries,
                "accept": [{"tests": [t.text() for t in r.tests], "because": r.citation.as_dict()} for r in self.verification.accept],
                "escalation": self.verification.escalation_citation.as_dict() if self.verification.escalation_citation else None,
                "proposals": [{"extractor": c.extractor, "params": c.params, "expected_ms": c.evidence.expected_ms,
                               **({"opencv": self.recipe(c.extractor, c.params)} if self.recipe is not None else {})}
                              for c in self.proposals],
            },
            "warnings": list(self.warnings),
            "versions": self.versions,
            "timings_ms": {k: round(v, 3) for k, v in self.timings_ms.items()},
            "reused": self.reused,
            "scoring": self.scoring.as_dict() if self.scoring is not None else None,
        }
