"""What the advisor answers: the extractor α*, its parameters Θ′, and why.

Plain dataclasses; ``as_dict`` gives the JSON the CLI prints and the service returns.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from ..context import ContextEntry
from ..fitness import Adjustment
from ..kg.vocab import Value
from ..rules.engine import Citation, Factor

__all__ = ["CandidateScore", "ContextEntry", "PrunedCandidate", "Selection"]


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
    evidence: dict[str, Any] = field(default_factory=dict)

    def as_dict(self) -> dict[str, Any]:
        return {
            "extractor": self.extractor,
            "score": self.score,
            "bonus": self.bonus,
            "metrics": self.metrics,
            "params": self.params,
            "adjustments": [
                {
                    "parameter": a.parameter,
                    "from": a.before,
                    "to": a.after,
                    "factor": round(a.factor, 6),
                    "clamped": a.clamped,
                    "because": [c.as_dict() for c in a.citations],
                }
                for a in self.adjustments
            ],
            "keypoints": self.keypoints,
            "extraction_ms": self.extraction_ms,
            "evidence": self.evidence,
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
    candidates: tuple[CandidateScore, ...]
    pruned: tuple[PrunedCandidate, ...]
    context: tuple[ContextEntry, ...]
    weights: dict[str, Factor]
    versions: dict[str, Any]
    timings_ms: dict[str, float]
    opencv: dict[str, Any] = field(default_factory=dict)  # ExtractorSpec.opencv: constructor, norm, args, grid
    state: Any = field(default=None, compare=False, repr=False)  # for the next frame of a stream
    budget: dict[str, Any] | None = None  # the per-frame budget in force (ms, source, compute, frame size)
    warnings: tuple[str, ...] = ()

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
            "warnings": list(self.warnings),
            "versions": self.versions,
            "timings_ms": {k: round(v, 3) for k, v in self.timings_ms.items()},
        }
