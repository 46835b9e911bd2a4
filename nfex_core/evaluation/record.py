"""One run of one method on one sequence under one condition, as ``nfex evaluate`` records it (run.py makes it,
figures.py reads its figures, report.py writes it)."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from nfex_slam.vo import VOResult

from .outcomes import FrontEnd


@dataclass
class RunRecord:
    method: str
    condition: str  # a corruption name, "none", or "schedule"
    run: int
    ate_rmse: float | None
    rpe_rmse: float | None
    failed: bool
    lost: int  # pairs the geometry lost (coasted pairs are not counted)
    rejected: int  # pairs the front-end checks rejected (counted in coasted)
    frames: int
    extraction_ms: float  # mean per frame
    extraction_max_ms: float
    matching_ms: float  # mean per frame pair
    expected_ms: float | None  # the cost model's mean expected extraction ms of the configurations run
    wall_s: float
    note: str = ""
    budget_ms: float | None = None
    tries: float = 1.0  # candidates tried per frame pair, mean (verification; 1 without)
    tries_max: int = 1
    fell_back: int = 0  # pairs verification sent to the motion prior (counted in coasted)
    segments: list[dict[str, Any]] = field(default_factory=list)
    transitions: list[dict[str, Any]] = field(default_factory=list)
    result: VOResult | None = field(default=None, repr=False)
    selections: list[dict[str, Any]] = field(default_factory=list, repr=False)
    coasted: int = 0  # pairs that fell back to the motion prior (front-end checks or verification)
    auc: dict[float, float] = field(default_factory=dict)  # pose AUC by threshold (degrees)
    frontend_ate: float | None = None  # ATE with ground-truth step lengths, SE(3)
    front: FrontEnd | None = field(default=None, repr=False)

    @property
    def key(self) -> str:
        return self.method if self.budget_ms is None else f"{self.method}@{self.budget_ms:g}ms"
